// Fast linear system: BCRS SpMV against dense double products, RCM, the pre-filtered PCG,
// transient elements and thread-count independence.
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <cstring>
#include <random>

#include "weft/linear_system/bcrs.h"
#include "weft/linear_system/fast_linear_system.h"
#include "weft/linear_system/linear_system.h"
#include "weft/linear_system/pcg.h"
#include "weft/linear_system/rcm.h"
#include "small_cloth.h"

using namespace weft;
using weft_test::SmallCloth;

namespace {

// Random symmetric block pattern: each row couples to up to `spread` neighbours at most
// `reach` rows away, plus the diagonal.
std::pair<std::vector<int>, std::vector<int>> random_pattern(int rows, int reach, std::mt19937& rng) {
  std::vector<std::vector<int>> cols(rows);
  for (int r = 0; r < rows; ++r) cols[r].push_back(r);
  std::uniform_int_distribution<int> offset(1, reach);
  for (int r = 0; r < rows; ++r)
    for (int k = 0; k < 5; ++k) {
      const int c = r + offset(rng);
      if (c >= rows) continue;
      cols[r].push_back(c);
      cols[c].push_back(r);
    }
  std::vector<int> start{0}, flat;
  for (auto& c : cols) {
    std::sort(c.begin(), c.end());
    c.erase(std::unique(c.begin(), c.end()), c.end());
    flat.insert(flat.end(), c.begin(), c.end());
    start.push_back(static_cast<int>(flat.size()));
  }
  return {start, flat};
}

template <class Scalar>
void fill_random(BcrsMatrix<Scalar>& m, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (size_t k = 0; k < m.block_count(); ++k)
    for (int i = 0; i < 9; ++i) m.block(static_cast<int>(k))[i] = static_cast<Scalar>(u(rng));
}

// Reference product in double over the stored values, straight from the pattern.
VectorX reference_product(const BcrsMatrix<float>& m, const VectorX& x) {
  VectorX y = VectorX::Zero(x.size());
  for (int r = 0; r < m.rows(); ++r)
    for (int k = m.row_begin(r); k < m.row_end(r); ++k) {
      const int c = m.column(k, r);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) y[3 * r + i] += static_cast<double>(m.block(k)[3 * j + i]) * x[3 * c + j];
    }
  return y;
}

// Scale for float32 round-off of a row: sum of |a_ij x_j|.
double row_scale(const Eigen::MatrixXd& dense, const VectorX& x, int row) {
  return (dense.row(row).cwiseAbs() * x.cwiseAbs())(0);
}

}  // namespace

TEST(Bcrs, MultiplyMatchesDenseDoubleWithinFloatTolerance) {
  std::mt19937 rng(7);
  for (int rows : {1, 5, 37, 300}) {
    auto [start, cols] = random_pattern(rows, 9, rng);
    BcrsMatrix<float> m;
    m.set_pattern(start, cols);
    fill_random(m, rng);
    EXPECT_TRUE(m.narrow_columns());
    const Eigen::MatrixXd dense = m.to_dense();
    VectorX x = VectorX::Random(3 * rows);
    VectorX y(3 * rows);
    for (int threads : {1, 2}) {
      m.multiply(x.data(), y.data(), threads);
      const VectorX exact = dense * x;
      for (int i = 0; i < 3 * rows; ++i)
        EXPECT_NEAR(y[i], exact[i], 4e-7 * row_scale(dense, x, i) + 1e-30) << "rows " << rows << " entry " << i;
    }
  }
}

TEST(Bcrs, FusedDotAndTransientBlocks) {
  std::mt19937 rng(11);
  const int rows = 9000;  // several reduction chunks
  auto [start, cols] = random_pattern(rows, 40, rng);
  BcrsMatrix<float> m;
  m.set_pattern(start, cols);
  fill_random(m, rng);
  // Two transient blocks far outside the band.
  std::vector<float> tv(18);
  for (auto& v : tv) v = std::uniform_real_distribution<float>(-1, 1)(rng);
  m.set_transient({10, 8000}, {0, 1, 2}, {8000, 10}, tv);
  VectorX x = VectorX::Random(3 * rows), y(3 * rows), y2(3 * rows);
  std::vector<double> dots((rows + kReductionChunk - 1) / kReductionChunk);
  m.multiply(x.data(), y.data(), 2, dots.data());
  VectorX exact = reference_product(m, x);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      exact[3 * 10 + i] += static_cast<double>(tv[3 * j + i]) * x[3 * 8000 + j];
      exact[3 * 8000 + i] += static_cast<double>(tv[9 + 3 * j + i]) * x[3 * 10 + j];
    }
  EXPECT_LT((y - exact).lpNorm<Eigen::Infinity>(), 1e-4);
  EXPECT_GT(dots.size(), 2u);
  EXPECT_NEAR(std::accumulate(dots.begin(), dots.end(), 0.0), x.dot(y), 1e-9 * x.cwiseAbs().dot(y.cwiseAbs()));
  m.multiply(x.data(), y2.data(), 1);
  EXPECT_EQ(0, std::memcmp(y.data(), y2.data(), sizeof(double) * y.size())) << "thread count changed the bits";
}

TEST(Bcrs, WideBandwidthFallsBackTo32BitColumns) {
  const int rows = 40000;
  std::vector<int> start{0}, cols;
  for (int r = 0; r < rows; ++r) {
    if (r == rows - 1) cols.push_back(0);
    cols.push_back(r);
    if (r == 0) cols.push_back(rows - 1);
    start.push_back(static_cast<int>(cols.size()));
  }
  BcrsMatrix<float> m;
  m.set_pattern(start, cols);
  std::mt19937 rng(3);
  fill_random(m, rng);
  EXPECT_FALSE(m.narrow_columns());
  EXPECT_EQ(m.bandwidth(), rows - 1);
  VectorX x = VectorX::Random(3 * rows), y(3 * rows);
  m.multiply(x.data(), y.data(), 2);
  const VectorX exact = reference_product(m, x);
  EXPECT_LT((y - exact).lpNorm<Eigen::Infinity>(), 1e-5);
}

TEST(Rcm, ReturnsPermutationAndShrinksBandwidthOfShuffledGrid) {
  const int nx = 60, ny = 40, n = nx * ny;
  std::vector<int> shuffle(n);
  std::iota(shuffle.begin(), shuffle.end(), 0);
  std::mt19937 rng(5);
  std::shuffle(shuffle.begin(), shuffle.end(), rng);
  std::vector<std::pair<int, int>> edges;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int v = shuffle[j * nx + i];
      if (i + 1 < nx) edges.emplace_back(v, shuffle[j * nx + i + 1]);
      if (j + 1 < ny) edges.emplace_back(v, shuffle[(j + 1) * nx + i]);
      if (i + 1 < nx && j + 1 < ny) edges.emplace_back(v, shuffle[(j + 1) * nx + i + 1]);
    }
  // A second, disconnected component.
  edges.emplace_back(n, n + 1);
  const Graph g = graph_from_edges(n + 2, edges);
  const std::vector<int> order = reverse_cuthill_mckee(g);
  std::vector<int> sorted = order;
  std::sort(sorted.begin(), sorted.end());
  std::vector<int> identity(n + 2);
  std::iota(identity.begin(), identity.end(), 0);
  EXPECT_EQ(sorted, identity);
  const int before = bandwidth(g, {}), after = bandwidth(g, order);
  EXPECT_GT(before, n / 2);
  EXPECT_LE(after, 2 * std::min(nx, ny) + 2);
  EXPECT_EQ(order, reverse_cuthill_mckee(g)) << "deterministic";
}

namespace {
// Random SPD matrix with a 3x3 block structure.
Eigen::MatrixXd random_spd(int vertices, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::MatrixXd b(3 * vertices, 3 * vertices);
  for (int i = 0; i < b.rows(); ++i)
    for (int j = 0; j < b.cols(); ++j) b(i, j) = u(rng);
  return b * b.transpose() + 0.5 * Eigen::MatrixXd::Identity(b.rows(), b.cols());
}
}  // namespace

TEST(PrefilteredPcg, HonoursConstraintsExactlyAndConverges) {
  std::mt19937 rng(13);
  const int n = 40;
  const Eigen::MatrixXd a = random_spd(n, rng);
  const VectorX b = VectorX::Random(3 * n);
  ConstraintFilter filter;
  filter.reset(n);
  filter.constrain_fully(3, Vec3(0.25, -0.5, 1.0));
  filter.constrain_fully(17, Vec3(-1.0, 0.0, 2.0));
  const Vec3 normal = Vec3(1.0, 2.0, -2.0).normalized();
  filter.constrain_direction(25, normal, 0.75);
  std::vector<Mat3> diagonal(n);
  for (int i = 0; i < n; ++i) diagonal[i] = a.block<3, 3>(3 * i, 3 * i);
  for (int threads : {1, 2}) {
    VectorX x = VectorX::Random(3 * n);  // arbitrary warm start, constrained parts included
    auto apply = [&](const VectorX& in, VectorX& out) { out = a * in; };
    const PcgStats stats = prefiltered_pcg(apply, diagonal, filter, b, x, PcgSettings{1e-10, 1000}, threads);
    EXPECT_TRUE(stats.converged);
    EXPECT_EQ(x.segment<3>(9), Vec3(0.25, -0.5, 1.0)) << "fully constrained vertex must be exact";
    EXPECT_EQ(x.segment<3>(51), Vec3(-1.0, 0.0, 2.0));
    EXPECT_NEAR(normal.dot(x.segment<3>(75)), 0.75, 1e-10);  // a direction: exact up to round-off
    // Solution of the filtered system: S (A x - b) = 0.
    VectorX residual = a * x - b;
    filter.apply(residual);
    EXPECT_LT(residual.norm(), 1e-8 * b.norm());
  }
}

TEST(PrefilteredPcg, FusedDotMatchesPlainPathAndThreadCounts) {
  std::mt19937 rng(17);
  const int n = 30;
  const Eigen::MatrixXd a = random_spd(n, rng);
  const VectorX b = VectorX::Random(3 * n);
  ConstraintFilter filter;
  filter.reset(n);
  filter.constrain_fully(4, Vec3(0.1, 0.2, 0.3));
  std::vector<Mat3> diagonal(n);
  for (int i = 0; i < n; ++i) diagonal[i] = a.block<3, 3>(3 * i, 3 * i);
  auto plain = [&](const VectorX& in, VectorX& out) { out = a * in; };
  auto fused = [&](const VectorX& in, VectorX& out, double* dots) {
    out = a * in;
    if (dots) dots[0] = in.dot(out);
  };
  VectorX x1 = VectorX::Zero(3 * n), x2 = VectorX::Zero(3 * n), x3 = VectorX::Zero(3 * n);
  prefiltered_pcg(plain, diagonal, filter, b, x1, PcgSettings{1e-9, 500}, 1);
  prefiltered_pcg(fused, diagonal, filter, b, x2, PcgSettings{1e-9, 500}, 1);
  prefiltered_pcg(fused, diagonal, filter, b, x3, PcgSettings{1e-9, 500}, 2);
  EXPECT_LT((x1 - x2).norm(), 1e-7 * x1.norm());
  EXPECT_EQ(0, std::memcmp(x2.data(), x3.data(), sizeof(double) * x2.size()));
}

namespace {
// The global A and b of the fast system in original vertex order, dense.
template <class Scalar>
Eigen::MatrixXd dense_original(const FastLinearSystem<Scalar>& s) {
  return Eigen::MatrixXd(s.to_sparse_original());
}
}  // namespace

TEST(FastLinearSystem, MatchesReferenceAssemblyAndMovesOverlappingTransientEntries) {
  SmallCloth cloth(9, 7);
  const double h = 1.0 / 96.0;
  LinearSystemOptions opt;
  opt.threads = 2;
  opt.precision = MatrixPrecision::kFloat64;
  FastLinearSystem<double> fast(cloth.mesh, *cloth.model, opt, 0);
  fast.build(cloth.x, cloth.v, 0.0, h);
  ReferenceAssembler reference(cloth.mesh);
  ElementBuffers buffers;
  cloth.model->compute(cloth.x, cloth.v, 0.0, kAllForces, true, 1, buffers);
  reference.assemble(buffers, cloth.model->materials().vertex_mass, cloth.v, h, 1);
  const Eigen::MatrixXd a_ref = Eigen::MatrixXd(reference.matrix());
  const Eigen::MatrixXd a_fast = dense_original(fast);
  EXPECT_LT((a_fast - a_ref).lpNorm<Eigen::Infinity>(), 1e-12 * a_ref.lpNorm<Eigen::Infinity>());
  EXPECT_LT((fast.rhs_original() - reference.rhs()).lpNorm<Eigen::Infinity>(), 1e-12 * reference.rhs().lpNorm<Eigen::Infinity>());
  EXPECT_LT(fast.info().force_elements, fast.info().per_force_elements);

  // Synthetic transient springs: vertices 0-1 are mesh neighbours (overlap the fixed pattern),
  // 0-62 are not (transient part).
  const Mat3 k = Vec3(3.0, 2.0, 1.0).asDiagonal(), d = 0.1 * Mat3::Identity();
  const Vec3 f(0.5, -0.25, 0.125);
  fast.transient()->add_spring(0, 1, f, k, d);
  fast.transient()->add_spring(0, 62, f, k, d);
  fast.transient()->add_spring(62, 0, -f, k, d);  // same pair twice, reduced per row
  fast.build(cloth.x, cloth.v, 0.0, h);
  EXPECT_EQ(fast.info().transient_blocks, 2);  // (0, 62) and (62, 0); the 0-1 blocks merged
  Eigen::MatrixXd expected = a_ref;
  VectorX expected_b = reference.rhs();
  auto add_spring = [&](int i, int j, const Vec3& force) {
    const Mat3 a = h * h * k + h * d;
    const Vec3 dvk = h * h * k * (cloth.v.row(i) - cloth.v.row(j)).transpose();
    expected.block<3, 3>(3 * i, 3 * i) += a;
    expected.block<3, 3>(3 * j, 3 * j) += a;
    expected.block<3, 3>(3 * i, 3 * j) -= a;
    expected.block<3, 3>(3 * j, 3 * i) -= a;
    expected_b.segment<3>(3 * i) += h * force - dvk;
    expected_b.segment<3>(3 * j) += -h * force + dvk;
  };
  add_spring(0, 1, f);
  add_spring(0, 62, f);
  add_spring(62, 0, -f);
  EXPECT_LT((dense_original(fast) - expected).lpNorm<Eigen::Infinity>(), 1e-12 * expected.lpNorm<Eigen::Infinity>());
  EXPECT_LT((fast.rhs_original() - expected_b).lpNorm<Eigen::Infinity>(), 1e-12 * expected_b.lpNorm<Eigen::Infinity>());
  // The SpMV with transient rows equals the dense product (in row order).
  const Eigen::MatrixXd rows_dense = fast.matrix().to_dense();
  VectorX x = VectorX::Random(rows_dense.rows()), y(rows_dense.rows());
  fast.matrix().multiply(x.data(), y.data(), 2);
  EXPECT_LT((y - rows_dense * x).lpNorm<Eigen::Infinity>(), 1e-12 * (rows_dense.cwiseAbs() * x.cwiseAbs()).maxCoeff());
}

// The fast path assembles from the forces' factored forms (forces.h: rank-one hinges, membrane
// blocks built per corner pair); the reference from the full element matrices. Here with every
// term large: biphasic stretch past its knee on most faces, strong bending and its damping,
// drag against wind.
TEST(FastLinearSystem, FactoredAssemblyMatchesFullElementMatricesWithEveryTerm) {
  SmallCloth cloth(9, 7);
  ClothMaterials m = cloth.model->materials();
  const size_t faces = m.face_stretch_warp.size();
  m.face_stretch_knee.assign(faces, 0.01);
  m.face_stretch_ratio.assign(faces, 8.0);
  m.face_damping.assign(faces, 0.05);
  m.hinge_bend.assign(m.hinge_bend.size(), 5e-3);
  Environment env = cloth.model->environment();
  env.wind_velocity = Vec3(2.0, 0.5, -1.0);
  const ForceModel model(cloth.mesh, m, env);
  const double h = 1.0 / 96.0;
  LinearSystemOptions opt;
  opt.threads = 2;
  opt.precision = MatrixPrecision::kFloat64;
  FastLinearSystem<double> fast(cloth.mesh, model, opt, 0);
  fast.build(cloth.x, cloth.v, 0.0, h);
  ReferenceAssembler reference(cloth.mesh);
  ElementBuffers buffers;
  model.compute(cloth.x, cloth.v, 0.0, kAllForces, true, 1, buffers);
  reference.assemble(buffers, model.materials().vertex_mass, cloth.v, h, 1);
  const Eigen::MatrixXd a_ref = Eigen::MatrixXd(reference.matrix());
  EXPECT_LT((dense_original(fast) - a_ref).lpNorm<Eigen::Infinity>(), 1e-12 * a_ref.lpNorm<Eigen::Infinity>());
  EXPECT_LT((fast.rhs_original() - reference.rhs()).lpNorm<Eigen::Infinity>(),
            1e-12 * reference.rhs().lpNorm<Eigen::Infinity>());
  // The knee is passed somewhere (the stiffer branch is exercised), and bending matters.
  int past_knee = 0;
  for (Eigen::Index f = 0; f < cloth.mesh.faces.rows(); ++f) {
    Vec3 w_u, w_v;
    const Mat2& d = cloth.mesh.rest_dm_inverse[f];
    const Vec3 x0 = cloth.x.row(cloth.mesh.faces(f, 0)), x1 = cloth.x.row(cloth.mesh.faces(f, 1)),
               x2 = cloth.x.row(cloth.mesh.faces(f, 2));
    w_u = (x1 - x0) * d(0, 0) + (x2 - x0) * d(1, 0);
    w_v = (x1 - x0) * d(0, 1) + (x2 - x0) * d(1, 1);
    past_knee += (w_u.norm() - 1.0 > 0.01 || w_v.norm() - 1.0 > 0.01) ? 1 : 0;
  }
  EXPECT_GT(past_knee, static_cast<int>(faces) / 4);
}

TEST(FastLinearSystem, BitwiseIndependentOfThreadCount) {
  SmallCloth cloth(40, 30);  // enough rows for several reduction chunks
  const double h = 1.0 / 96.0;
  std::vector<VectorX> solutions;
  std::vector<Eigen::MatrixXd> matrices;
  for (int threads : {1, 2, 3}) {
    LinearSystemOptions opt;
    opt.threads = threads;
    FastLinearSystem<float> fast(cloth.mesh, *cloth.model, opt, 1);
    for (int e = 0; e < 50; ++e) fast.transient()->add_spring(e, 1199 - e, Vec3(0.1, 0.2, 0.3), Mat3::Identity(), Mat3::Zero());
    fast.build(cloth.x, cloth.v, 0.5, h);
    ConstraintFilter filter;
    filter.reset(cloth.mesh.vertex_count);
    filter.constrain_fully(0, Vec3(0.0, 0.1, 0.0));
    VectorX dv = VectorX::Zero(3 * cloth.mesh.vertex_count);
    const PcgStats stats = fast.solve(filter, dv);
    EXPECT_TRUE(stats.converged);
    solutions.push_back(dv);
    matrices.push_back(fast.matrix().to_dense());
  }
  for (size_t k = 1; k < solutions.size(); ++k) {
    EXPECT_EQ(0, std::memcmp(solutions[0].data(), solutions[k].data(), sizeof(double) * solutions[0].size()));
    EXPECT_TRUE(matrices[0] == matrices[k]);
  }
}
