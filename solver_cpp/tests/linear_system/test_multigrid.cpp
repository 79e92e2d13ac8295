// Smoothed-aggregation multigrid (multigrid.h): the V-cycle is a symmetric positive-definite
// operator, multigrid-preconditioned CG solves the same filtered system as block-Jacobi PCG,
// with far fewer iterations, bitwise independent of the thread count.
#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include "small_cloth.h"
#include "weft/linear_system/fast_linear_system.h"
#include "weft/linear_system/multigrid.h"

using namespace weft;
using weft_test::SmallCloth;

namespace {

constexpr double kStep = 1.0 / 96.0;

// Pins at two corners, a contact-like direction constraint in the middle and on the edge.
ConstraintFilter sheet_filter(int nx, int ny) {
  ConstraintFilter filter;
  filter.reset(nx * ny);
  filter.constrain_fully(0, Vec3(0.0, 0.01, 0.0));
  filter.constrain_fully(nx - 1, Vec3::Zero());
  filter.constrain_direction((ny / 2) * nx + nx / 2, Vec3(0.0, 1.0, 0.0), 0.02);
  filter.constrain_direction((ny - 1) * nx + nx / 3, Vec3(1.0, 2.0, 2.0).normalized(), -0.01);
  return filter;
}

LinearSystemOptions multigrid_options() {
  LinearSystemOptions options;
  options.preconditioner = Preconditioner::kMultigrid;
  return options;
}

// The fixed-pattern blocks of the fast system (row order) and the filter in row order.
struct RowOrderSystem {
  SmoothedAggregation multigrid;
  ConstraintFilter filter;
};

RowOrderSystem multigrid_of(const FastLinearSystem<float>& fast, const ClothMesh& mesh, const ConstraintFilter& f,
                            int threads, const MultigridOptions& options = {}) {
  const auto& order = fast.order();
  std::vector<std::pair<int, int>> edges;
  for (Eigen::Index t = 0; t < mesh.faces.rows(); ++t)
    for (int c = 0; c < 3; ++c)
      edges.emplace_back(fast.new_of_old()[mesh.faces(t, c)], fast.new_of_old()[mesh.faces(t, (c + 1) % 3)]);
  ConstraintFilter filter;
  filter.reset(mesh.vertex_count);
  filter.constrained_vertices = f.constrained_vertices;
  for (int r = 0; r < mesh.vertex_count; ++r) {
    filter.projection[r] = f.projection[order[r]];
    filter.prescribed.segment<3>(3 * r) = f.prescribed.segment<3>(3 * order[r]);
  }
  RowOrderSystem s{
      SmoothedAggregation::from_pattern(fast.matrix(), graph_from_edges(mesh.vertex_count, edges), options), filter};
  s.multigrid.update(fast.matrix(), s.filter, threads);
  return s;
}

// A stiff sheet's float32 fast system, built once, and the hierarchy of its sheet_filter system.
struct SheetHierarchy {
  SmallCloth cloth;
  FastLinearSystem<float> fast;
  RowOrderSystem system;
  SheetHierarchy(int nx, int ny, double stretch_scale)
      : cloth(nx, ny, stretch_scale),
        fast(cloth.mesh, *cloth.model, LinearSystemOptions{}, 2),
        system(build_and_coarsen(fast, cloth, sheet_filter(nx, ny))) {}
  static RowOrderSystem build_and_coarsen(FastLinearSystem<float>& fast, const SmallCloth& cloth,
                                          const ConstraintFilter& filter) {
    fast.build(cloth.x, cloth.v, 0.0, kStep);
    return multigrid_of(fast, cloth.mesh, filter, 1);
  }
};

// The same system solved from zero with each preconditioner.
struct BothSolves {
  VectorX jacobi, multigrid;
  PcgStats sj, sm;
};
template <class Scalar>
BothSolves solve_both(FastLinearSystem<Scalar>& fast, const ConstraintFilter& filter, const PcgSettings& pcg) {
  const Eigen::Index n = 3 * static_cast<Eigen::Index>(fast.order().size());
  BothSolves b{VectorX::Zero(n), VectorX::Zero(n), {}, {}};
  b.sj = fast.solve_with(filter, b.jacobi, pcg, Preconditioner::kBlockJacobi);
  b.sm = fast.solve_with(filter, b.multigrid, pcg, Preconditioner::kMultigrid);
  return b;
}

// ||S (b - A dv)|| / ||S (b - A z)||: the relative residual CG works on, recomputed from dv.
template <class Scalar>
double filtered_residual(const FastLinearSystem<Scalar>& fast, const ConstraintFilter& filter, const VectorX& dv) {
  VectorX r, r0;
  fast.residual(dv, r);
  fast.residual(filter.prescribed, r0);
  filter.apply(r);
  filter.apply(r0);
  return r.norm() / r0.norm();
}

MultigridOptions unlumped() {
  MultigridOptions options;
  options.lumped_fine_operator = false;
  return options;
}

VectorX random_right_hand_side(int rows, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  VectorX b(3 * static_cast<Eigen::Index>(rows));
  for (Eigen::Index k = 0; k < b.size(); ++k) b[k] = g(rng);
  return b;
}

// Preconditioned CG on `a` from zero to a relative residual of 1e-6: the iterations it took
// (1000: not within 200), each preconditioned residual checked positive.
int cg_iterations(const BlockRowsF& a, const SmoothedAggregation& m, const VectorX& b) {
  const Eigen::Index n = b.size();
  VectorX x = VectorX::Zero(n), r = b, z(n), p, q;
  m.apply(r, z, 1);
  EXPECT_GT(r.dot(z), 0.0);
  p = z;
  double rz = r.dot(z);
  for (int it = 1; it <= 200; ++it) {
    a.multiply(p, q, 1);
    const double alpha = rz / p.dot(q);
    x += alpha * p;
    r -= alpha * q;
    if (r.norm() < 1e-6 * b.norm()) return it;
    m.apply(r, z, 1);
    const double next = r.dot(z);
    EXPECT_GT(next, 0.0) << "the preconditioner is positive definite";
    p = z + (next / rz) * p;
    rz = next;
  }
  return 1000;
}

}  // namespace

TEST(Multigrid, VCycleIsSymmetricAndPositiveDefinite) {
  const int nx = 40, ny = 36;
  SheetHierarchy sheet(nx, ny, 10.0);
  RowOrderSystem& s = sheet.system;
  ASSERT_GE(s.multigrid.levels(), 3);
  EXPECT_LE(s.multigrid.level_rows().back(), MultigridOptions{}.coarse_rows);
  std::mt19937 rng(3);
  std::normal_distribution<double> g(0.0, 1.0);
  const Eigen::Index n = 3 * nx * ny;
  auto random_vector = [&] {
    VectorX u(n);
    for (Eigen::Index k = 0; k < n; ++k) u[k] = g(rng);
    return u;
  };
  VectorX bu(n), bv(n);
  for (int trial = 0; trial < 10; ++trial) {
    const VectorX u = random_vector(), v = random_vector();
    s.multigrid.apply(u, bu, 1);
    s.multigrid.apply(v, bv, 1);
    // Symmetric up to round-off: the level products run in float32 (x rounded to float32), as
    // CG's own product does.
    const double scale = std::sqrt(u.dot(bu) * v.dot(bv));
    EXPECT_NEAR(v.dot(bu), u.dot(bv), 1e-6 * scale) << "u.Bv == v.Bu";
    EXPECT_GT(u.dot(bu), 0.0);
    EXPECT_GT(v.dot(bv), 0.0);
  }
  // Positive also on smooth vectors (the coarse-grid part of the cycle).
  VectorX smooth(n);
  for (Eigen::Index k = 0; k < n; ++k) smooth[k] = std::sin(0.01 * static_cast<double>(k / 3)) + (k % 3 == 1 ? 1.0 : 0.0);
  s.multigrid.apply(smooth, bu, 1);
  EXPECT_GT(smooth.dot(bu), 0.0);
}

// The smoother's steps reuse work between passes (the first step from a zero start stores
// nothing but x, each step rounds the vector the next product reads, the last one x for the
// residual's product): with one, two and three Chebyshev steps the cycle stays a symmetric
// positive-definite operator, and more steps reduce the residual of one cycle more.
TEST(Multigrid, EverySmootherDegreeGivesASymmetricPositiveCycle) {
  const int nx = 30, ny = 28;
  SmallCloth cloth(nx, ny, 10.0);
  FastLinearSystem<float> fast(cloth.mesh, *cloth.model, LinearSystemOptions{}, 2);
  fast.build(cloth.x, cloth.v, 0.0, kStep);
  const Eigen::Index n = 3 * nx * ny;
  std::mt19937 rng(5);
  std::normal_distribution<double> g(0.0, 1.0);
  VectorX u(n), v(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    u[k] = g(rng);
    v[k] = g(rng);
  }
  double previous_reduction = 1.0;
  for (const int degree : {1, 2, 3}) {
    MultigridOptions options;
    options.smoother_degree = degree;
    RowOrderSystem s = multigrid_of(fast, cloth.mesh, sheet_filter(nx, ny), 1, options);
    ASSERT_GE(s.multigrid.levels(), 2);
    VectorX bu(n), bv(n), again(n);
    s.multigrid.apply(u, bu, 1);
    s.multigrid.apply(v, bv, 1);
    const double scale = std::sqrt(u.dot(bu) * v.dot(bv));
    EXPECT_NEAR(v.dot(bu), u.dot(bv), 1e-6 * scale) << "degree " << degree;
    EXPECT_GT(u.dot(bu), 0.0) << "degree " << degree;
    s.multigrid.apply(u, again, 2);  // work vectors reused, two threads: the same result
    EXPECT_EQ(0, std::memcmp(again.data(), bu.data(), sizeof(double) * static_cast<size_t>(n))) << "degree " << degree;
    // One cycle as a solver of the finest level's filtered operator: the residual shrinks.
    VectorX a_bu;
    s.multigrid.level_matrix(0).multiply(bu, a_bu, 1);
    const double reduction = (u - a_bu).norm() / u.norm();
    EXPECT_LT(reduction, previous_reduction) << "degree " << degree;
    previous_reduction = reduction;
  }
}

TEST(Multigrid, SolvesTheSameSystemAsBlockJacobiWithPinsAndContacts) {
  const int nx = 30, ny = 25;
  SmallCloth cloth(nx, ny);
  LinearSystemOptions opt;
  opt.precision = MatrixPrecision::kFloat64;
  FastLinearSystem<double> fast(cloth.mesh, *cloth.model, opt, 2);
  // A transient spring outside the fixed pattern: CG multiplies with it, the hierarchy not.
  fast.transient()->add_spring(5, nx * ny - 7, Vec3(0.1, 0.0, 0.0), 50.0 * Mat3::Identity(), Mat3::Zero());
  fast.build(cloth.x, cloth.v, 0.0, kStep);
  ASSERT_GT(fast.info().transient_blocks, 0);
  const ConstraintFilter filter = sheet_filter(nx, ny);
  const auto [jacobi, multigrid, sj, sm] = solve_both(fast, filter, PcgSettings{1e-10, 5000});
  ASSERT_TRUE(sj.converged);
  ASSERT_TRUE(sm.converged);
  EXPECT_EQ(fast.info().preconditioner, "multigrid");
  EXPECT_LT((jacobi - multigrid).norm(), 1e-7 * jacobi.norm());
  // Pins exact (bitwise), directions up to round-off.
  EXPECT_EQ(multigrid.segment<3>(0), Vec3(0.0, 0.01, 0.0));
  EXPECT_EQ(multigrid.segment<3>(3 * (nx - 1)), Vec3::Zero());
  EXPECT_NEAR(multigrid[3 * ((ny / 2) * nx + nx / 2) + 1], 0.02, 1e-12);
  EXPECT_LT(filtered_residual(fast, filter, multigrid), 2e-10);
  EXPECT_LT(sm.iterations, sj.iterations);
}

TEST(Multigrid, FarFewerIterationsThanBlockJacobiOnAStiffSheet) {
  const int nx = 64, ny = 64;
  SmallCloth cloth(nx, ny, 20.0);
  LinearSystemOptions opt;
  FastLinearSystem<float> fast(cloth.mesh, *cloth.model, opt, 2);
  fast.build(cloth.x, cloth.v, 0.0, kStep);
  const ConstraintFilter filter = sheet_filter(nx, ny);
  const auto [jacobi, multigrid, sj, sm] = solve_both(fast, filter, PcgSettings{1e-5, 2000});
  ASSERT_TRUE(sj.converged);
  ASSERT_TRUE(sm.converged);
  std::cout << "64x64 stiff sheet: block Jacobi " << sj.iterations << " iterations, multigrid " << sm.iterations
            << " (levels";
  for (int rows : fast.info().multigrid_rows) std::cout << ' ' << rows;
  std::cout << ")\n";
  EXPECT_GT(sj.iterations, 100);
  EXPECT_LT(sm.iterations * 5, sj.iterations);
  // Both meet the tolerance on the true residual; the solutions then agree to what the
  // tolerance allows on a system this stiff (condition number ~1e5).
  EXPECT_LT(filtered_residual(fast, filter, jacobi), 1.5e-5);
  EXPECT_LT(filtered_residual(fast, filter, multigrid), 1.5e-5);
  EXPECT_LT((jacobi - multigrid).norm(), 2e-2 * jacobi.norm());
}

TEST(Multigrid, BitwiseIndependentOfThreadCount) {
  const int nx = 96, ny = 90;  // above kParallelSolveRows: the solve and the fine levels run threaded
  SmallCloth cloth(nx, ny, 5.0);
  std::vector<VectorX> solutions;
  std::vector<int> iterations;
  for (int threads : {1, 2, 3}) {
    LinearSystemOptions opt;
    opt.threads = threads;
    opt.preconditioner = Preconditioner::kMultigrid;
    FastLinearSystem<float> fast(cloth.mesh, *cloth.model, opt, 2);
    fast.build(cloth.x, cloth.v, 0.25, kStep);
    VectorX dv = VectorX::Zero(3 * nx * ny);
    const PcgStats stats = fast.solve(sheet_filter(nx, ny), dv);
    EXPECT_TRUE(stats.converged);
    EXPECT_GT(stats.preconditioner_setup_seconds, 0.0);
    solutions.push_back(dv);
    iterations.push_back(stats.iterations);
  }
  for (size_t k = 1; k < solutions.size(); ++k) {
    EXPECT_EQ(iterations[0], iterations[k]);
    EXPECT_EQ(0, std::memcmp(solutions[0].data(), solutions[k].data(), sizeof(double) * solutions[0].size()))
        << "thread count changed the bits";
  }
}

TEST(Multigrid, AllPinnedAggregatesKeepTheHierarchyPositiveDefinite) {
  // A whole pinned border row and column: aggregates with no free direction (G_J = 0) and
  // aggregates with one constrained direction everywhere (rank-deficient G_J).
  const int nx = 24, ny = 20;
  SmallCloth cloth(nx, ny);
  LinearSystemOptions opt;
  opt.precision = MatrixPrecision::kFloat64;  // a float32 product cannot show a 1e-9 residual
  FastLinearSystem<double> fast(cloth.mesh, *cloth.model, opt, 0);
  fast.build(cloth.x, cloth.v, 0.0, kStep);
  ConstraintFilter filter;
  filter.reset(nx * ny);
  for (int i = 0; i < nx; ++i) filter.constrain_fully(i, Vec3::Zero());
  for (int j = 1; j < ny; ++j) filter.constrain_direction(j * nx, Vec3(0.0, 0.0, 1.0), 0.0);
  const auto [reference, dv, sj, sm] = solve_both(fast, filter, PcgSettings{1e-9, 5000});
  EXPECT_TRUE(sj.converged);
  EXPECT_TRUE(sm.converged);
  for (int i = 0; i < nx; ++i) EXPECT_EQ(dv.segment<3>(3 * i), Vec3::Zero());
  EXPECT_LT(filtered_residual(fast, filter, dv), 2e-9);
  EXPECT_LT((dv - reference).norm(), 1e-4 * reference.norm());
}

TEST(Multigrid, LanczosEstimateOfTheSpectralRadiusIsCloseAboveIt) {
  // The Chebyshev smoother needs an upper bound of rho(D^-1 A); ten power iterations were 18%
  // low on this kind of sheet (and the V-cycle then indefinite). The largest Ritz value of ten
  // Lanczos steps is below the top too; with its residual added it is at or above it.
  SheetHierarchy sheet(48, 40, 20.0);
  const RowOrderSystem& s = sheet.system;
  for (int l = 0; l + 1 < s.multigrid.levels(); ++l) {
    const BlockRowsF& a = s.multigrid.level_matrix(l);
    std::vector<Mat3> inverse_diagonal(a.rows);
    for (int i = 0; i < a.rows; ++i)
      for (int k = a.start[i]; k < a.start[i + 1]; ++k)
        if (a.column[k] == i) inverse_diagonal[i] = a.value[k].cast<double>().inverse();
    VectorX x = VectorX::Random(3 * a.rows), t;
    double lambda = 0.0;
    for (int it = 0; it < 3000; ++it) {
      a.multiply(x, t, 1);
      for (int i = 0; i < a.rows; ++i) x.segment<3>(3 * i) = inverse_diagonal[i] * t.segment<3>(3 * i);
      lambda = x.norm();
      x /= lambda;
    }
    EXPECT_GE(s.multigrid.spectral_radius(l), 0.999 * lambda) << "level " << l;
    EXPECT_LE(s.multigrid.spectral_radius(l), 1.1 * lambda) << "level " << l;
  }
}

// The hierarchy's values are reused from solve to solve within a frame (only the finest level's
// operator follows the matrix) and recomputed at a new frame, a new step size, a new filter or
// when the reused values cost clearly more iterations than fresh ones did.
TEST(Multigrid, ReusesTheHierarchyWithinAFrameAndRefreshesWhenDue) {
  const int nx = 40, ny = 36;
  SmallCloth cloth(nx, ny, 10.0);
  FastLinearSystem<float> fast(cloth.mesh, *cloth.model, multigrid_options(), 2);
  const ConstraintFilter filter = sheet_filter(nx, ny);
  const PcgSettings pcg{1e-6, 2000};
  // The upper half of the sheet turned by `angle` about its middle row: a different matrix.
  auto folded = [&](double angle) {
    Positions x = cloth.x;
    const double z0 = cloth.x(nx * (ny / 2), 2), c = std::cos(angle), s = std::sin(angle);
    for (int i = nx * (ny / 2); i < nx * ny; ++i) {
      const double dz = cloth.x(i, 2) - z0;
      x(i, 1) = cloth.x(i, 1) + s * dz;
      x(i, 2) = z0 + c * dz;
    }
    return x;
  };
  auto solve_at = [&](FastLinearSystem<float>& system, const Positions& x, double h, const ConstraintFilter& f) {
    system.build(x, cloth.v, 0.0, h);
    VectorX dv = VectorX::Zero(3 * nx * ny);
    const PcgStats stats = system.solve_with(f, dv, pcg);
    EXPECT_TRUE(stats.converged);
    EXPECT_LT(filtered_residual(system, f, dv), 1.5e-6);
    return stats;
  };
  auto refreshes = [&] { return fast.info().multigrid_refreshes; };

  fast.start_frame();
  const PcgStats first = solve_at(fast, cloth.x, kStep, filter);
  EXPECT_EQ(refreshes(), 1);
  // A substep's worth of motion (3 degrees): the reused values precondition nearly as well.
  const PcgStats reused = solve_at(fast, folded(0.05), kStep, filter);
  EXPECT_EQ(refreshes(), 1) << "same frame, step and filter: values reused";
  FastLinearSystem<float> fresh(cloth.mesh, *cloth.model, multigrid_options(), 2);
  const PcgStats fresh_stats = solve_at(fresh, folded(0.05), kStep, filter);
  std::cout << "sheet folded 3 degrees: " << reused.iterations << " iterations with reused values, "
            << fresh_stats.iterations << " with fresh ones\n";
  EXPECT_LE(reused.iterations, fresh_stats.iterations + std::max(2, fresh_stats.iterations / 4));
  // A 40-degree fold in one solve: the reused values fall behind, and the next solve refreshes.
  const PcgStats behind = solve_at(fast, folded(0.7), kStep, filter);
  EXPECT_EQ(refreshes(), 1);
  EXPECT_GT(behind.iterations, first.iterations + std::max(2, first.iterations / 4));
  solve_at(fast, folded(0.7), kStep, filter);
  EXPECT_EQ(refreshes(), 2) << "too many iterations with reused values";

  const double rho = fast.multigrid()->spectral_radius(0);
  solve_at(fast, folded(0.7), kStep / 2, filter);
  EXPECT_EQ(refreshes(), 3) << "a new step size";
  const double rho_half_step = fast.multigrid()->spectral_radius(0);
  EXPECT_NE(rho_half_step, rho) << "a new step size: the smoothers' bounds estimated again";
  ConstraintFilter contact = filter;
  contact.constrain_direction(nx * (ny / 4) + nx / 2, Vec3(0.0, 1.0, 0.0), 0.0);
  solve_at(fast, folded(0.7), kStep / 2, contact);
  EXPECT_EQ(refreshes(), 4) << "a new filter";
  EXPECT_EQ(fast.multigrid()->spectral_radius(0), rho_half_step) << "a new filter: the bounds kept";
  solve_at(fast, folded(0.7), kStep / 2, contact);
  EXPECT_EQ(refreshes(), 4);
  fast.start_frame();
  solve_at(fast, folded(0.7), kStep / 2, contact);
  EXPECT_EQ(refreshes(), 5) << "a new frame";
  EXPECT_NE(fast.multigrid()->spectral_radius(0), rho_half_step) << "a new frame: the bounds of the new filter";
}

TEST(Multigrid, AReusedHierarchyThatFailsToConvergeIsRefreshedAndTheSolveResumed) {
  const int nx = 30, ny = 25;
  SmallCloth cloth(nx, ny, 10.0);
  FastLinearSystem<float> fast(cloth.mesh, *cloth.model, multigrid_options(), 2);
  const ConstraintFilter filter = sheet_filter(nx, ny);
  const PcgSettings three{1e-12, 3};  // no solve converges in three iterations
  fast.build(cloth.x, cloth.v, 0.0, kStep);
  VectorX dv = VectorX::Zero(3 * nx * ny);
  const PcgStats first = fast.solve_with(filter, dv, three);
  EXPECT_FALSE(first.converged);
  EXPECT_EQ(first.iterations, 3);
  EXPECT_EQ(fast.info().multigrid_refreshes, 1);
  const PcgStats second = fast.solve_with(filter, dv, three);  // reused values, then fresh ones
  EXPECT_FALSE(second.converged);
  EXPECT_EQ(second.iterations, 6);
  EXPECT_EQ(fast.info().multigrid_refreshes, 2);
}

// `auto` below kMultigridAutoVertices: block Jacobi first; a solve that needs more than
// kAutoBlockJacobiIterations goes on with multigrid from the block-Jacobi iterate (the
// reported iterations count both) and the frame's later solves start with multigrid; a new
// frame starts with block Jacobi again. A small soft patch's solve (at the shots' default
// tolerance) stays on block Jacobi.
TEST(Multigrid, AutoGoesOnWithMultigridWhereBlockJacobiNeedsMany) {
  const int nx = 24, ny = 20;  // 480 vertices: below kMultigridAutoVertices
  ASSERT_LT(nx * ny, kMultigridAutoVertices);
  const ConstraintFilter filter = sheet_filter(nx, ny);
  const PcgSettings pcg{1e-6, 2000};
  auto solve = [&](FastLinearSystem<float>& fast, VectorX& dv, Preconditioner preconditioner,
                   const PcgSettings& settings) {
    dv = VectorX::Zero(3 * nx * ny);
    const PcgStats stats = fast.solve_with(filter, dv, settings, preconditioner);
    EXPECT_TRUE(stats.converged);
    EXPECT_LT(filtered_residual(fast, filter, dv), 1.5 * settings.tolerance);
    return stats;
  };
  SmallCloth stiff(nx, ny, 20.0);
  FastLinearSystem<float> fast(stiff.mesh, *stiff.model, LinearSystemOptions{}, 2);
  fast.build(stiff.x, stiff.v, 0.0, kStep);
  fast.start_frame();
  VectorX jacobi, automatic, again;
  const PcgStats sj = solve(fast, jacobi, Preconditioner::kBlockJacobi, pcg);
  ASSERT_GT(sj.iterations, 2 * kAutoBlockJacobiIterations) << "not a case for the switch";
  const PcgStats first = solve(fast, automatic, Preconditioner::kAuto, pcg);
  EXPECT_EQ(fast.info().preconditioner, "multigrid");
  EXPECT_GT(first.iterations, kAutoBlockJacobiIterations);
  EXPECT_LT(first.iterations, sj.iterations);
  EXPECT_LT((automatic - jacobi).norm(), 1e-3 * jacobi.norm());
  const PcgStats later = solve(fast, again, Preconditioner::kAuto, pcg);
  EXPECT_EQ(fast.info().preconditioner, "multigrid");
  EXPECT_LT(later.iterations, kAutoBlockJacobiIterations) << "the frame's later solves start with multigrid";
  fast.start_frame();
  const PcgStats next_frame = solve(fast, again, Preconditioner::kAuto, pcg);
  EXPECT_EQ(next_frame.iterations, first.iterations) << "a new frame decides afresh, as the first did";

  const int sx = 10, sy = 8;  // a small soft patch
  SmallCloth soft(sx, sy, 0.05);
  FastLinearSystem<float> soft_fast(soft.mesh, *soft.model, LinearSystemOptions{}, 2);
  soft_fast.build(soft.x, soft.v, 0.0, kStep);
  soft_fast.start_frame();
  const ConstraintFilter soft_filter = sheet_filter(sx, sy);
  VectorX soft_dv = VectorX::Zero(3 * sx * sy);
  const PcgStats soft_stats = soft_fast.solve_with(soft_filter, soft_dv, PcgSettings{1e-3, 2000}, Preconditioner::kAuto);
  EXPECT_TRUE(soft_stats.converged);
  EXPECT_LE(soft_stats.iterations, kAutoBlockJacobiIterations);
  EXPECT_EQ(soft_fast.info().preconditioner, "block_jacobi");
}

// The finest prolongator smoothed with the filtered operator A^F (hinge couplings lumped onto
// the diagonal, multigrid.h): a sparser P and hierarchy, still an SPD preconditioner, and CG on
// the filtered fine operator converges about as fast as with P smoothed by A itself. (Both
// hierarchies keep A itself as their finest operator: with lumped_fine_operator the weak blocks
// are not in it at all.)
TEST(Multigrid, FilteredProlongatorSmoothingIsSparserAndConvergesAsWell) {
  const int nx = 48, ny = 40;
  SmallCloth cloth(nx, ny, 10.0);
  FastLinearSystem<float> fast(cloth.mesh, *cloth.model, LinearSystemOptions{}, 2);
  fast.build(cloth.x, cloth.v, 0.0, kStep);
  const RowOrderSystem filtered = multigrid_of(fast, cloth.mesh, sheet_filter(nx, ny), 1, unlumped());
  std::vector<std::pair<int, int>> edges;
  for (Eigen::Index t = 0; t < cloth.mesh.faces.rows(); ++t)
    for (int c = 0; c < 3; ++c)
      edges.emplace_back(fast.new_of_old()[cloth.mesh.faces(t, c)], fast.new_of_old()[cloth.mesh.faces(t, (c + 1) % 3)]);
  MultigridOptions plain_options = unlumped();
  plain_options.filtered_smoothing = false;
  SmoothedAggregation plain = SmoothedAggregation::from_pattern(
      fast.matrix(), graph_from_edges(cloth.mesh.vertex_count, edges), plain_options);
  plain.update(fast.matrix(), filtered.filter, 1);

  // The same aggregates, fewer blocks: P reaches only the aggregates of strong neighbours.
  ASSERT_EQ(filtered.multigrid.level_rows(), plain.level_rows());
  EXPECT_LT(filtered.multigrid.prolongator_blocks(0), plain.prolongator_blocks(0));
  EXPECT_LT(filtered.multigrid.operator_complexity(), plain.operator_complexity());

  // CG on the filtered fine operator (the same in both), preconditioned by each hierarchy.
  const BlockRowsF& a = plain.level_matrix(0);
  const VectorX b = random_right_hand_side(a.rows, 11);
  const int with_filtered = cg_iterations(a, filtered.multigrid, b), with_plain = cg_iterations(a, plain, b);
  std::cout << "CG to 1e-6: P smoothed by A " << with_plain << " iterations, by A^F " << with_filtered << "\n";
  EXPECT_LT(with_plain, 60);
  EXPECT_LE(with_filtered, with_plain + with_plain / 4);
}

// The finest level's lumped operator A^L (lumped_fine_operator, multigrid.h): the hinges' wing
// couplings dropped and completed on the diagonal. Fewer blocks than the system's matrix,
// u.A^L u >= u.A u for every u (A^L - A is PSD, so the hierarchy stays SPD however stiff the
// bending), and as a preconditioner of the filtered system itself (CG multiplies with A) as good
// as the hierarchy built on A while the wings are light beside their bending (the ratio of
// kLumpedWingRatio: 1.6-6.5 and 16-65 on this crumpled 1 cm sheet); worse once they are not
// (160-650), where FastLinearSystem keeps them (StiffWingsStayOnTheFinestLevel).
TEST(Multigrid, LumpedFineOperatorDropsTheWeakBlocksAndBoundsTheMatrix) {
  const int nx = 48, ny = 40;
  for (const double bend : {1e-5, 1e-4, 1e-3}) {
    SmallCloth cloth(nx, ny, 10.0, bend);
    FastLinearSystem<float> fast(cloth.mesh, *cloth.model, LinearSystemOptions{}, 2);
    fast.build(cloth.x, cloth.v, 0.0, kStep);
    const RowOrderSystem lumped = multigrid_of(fast, cloth.mesh, sheet_filter(nx, ny), 1);
    const RowOrderSystem plain = multigrid_of(fast, cloth.mesh, sheet_filter(nx, ny), 1, unlumped());
    const SmoothedAggregation& l = lumped.multigrid;
    const SmoothedAggregation& p = plain.multigrid;
    EXPECT_EQ(static_cast<size_t>(l.pattern_blocks()), fast.matrix().block_count());
    EXPECT_EQ(p.fine_blocks(), p.pattern_blocks());
    // A regular sheet: 7 blocks a row (itself and six triangle neighbours) of 11-13.
    EXPECT_LT(l.fine_blocks(), 0.6 * l.pattern_blocks()) << "bend " << bend;
    // Filtered A^L against filtered A (the unlumped hierarchy's finest operator).
    const BlockRowsF& a = p.level_matrix(0);
    const BlockRowsF& al = l.level_matrix(0);
    for (unsigned seed = 1; seed <= 10; ++seed) {
      const VectorX u = random_right_hand_side(a.rows, seed);
      VectorX au, alu;
      a.multiply(u, au, 1);
      al.multiply(u, alu, 1);
      EXPECT_GE(u.dot(alu), u.dot(au) * (1.0 - 1e-6)) << "bend " << bend << ", vector " << seed;
    }
    const VectorX b = random_right_hand_side(a.rows, 17);
    const int with_lumped = cg_iterations(a, l, b), with_plain = cg_iterations(a, p, b);
    std::cout << "bend " << bend << ": CG to 1e-6 on A: hierarchy of A " << with_plain << " iterations, of A^L "
              << with_lumped << " (finest blocks " << l.fine_blocks() << " of " << l.pattern_blocks() << ")\n";
    EXPECT_LT(with_plain, 40) << "bend " << bend;
    if (bend < 1e-3) {
      EXPECT_LE(with_lumped, with_plain + 2) << "bend " << bend;
    } else {
      EXPECT_GT(with_lumped, with_plain + 5) << "stiff wings lumped: why FastLinearSystem keeps them";
    }
  }
}

// FastLinearSystem lumps the wings of cloth-like hinges and keeps those whose bending is stiff
// beside the wing masses (stiff_wing_pairs, kLumpedWingRatio); either way the multigrid solve
// is the block-Jacobi one.
TEST(Multigrid, StiffWingsStayOnTheFinestLevel) {
  const int nx = 36, ny = 30;
  for (const double bend : {1e-5, 1e-2}) {
    SmallCloth cloth(nx, ny, 10.0, bend);
    LinearSystemOptions opt;
    opt.precision = MatrixPrecision::kFloat64;
    FastLinearSystem<double> fast(cloth.mesh, *cloth.model, opt, 2);
    fast.build(cloth.x, cloth.v, 0.0, kStep);
    const ConstraintFilter filter = sheet_filter(nx, ny);
    const auto [jacobi, multigrid, sj, sm] = solve_both(fast, filter, PcgSettings{1e-10, 5000});
    ASSERT_TRUE(sj.converged);
    ASSERT_TRUE(sm.converged);
    const SmoothedAggregation& m = *fast.multigrid();
    const size_t wings = stiff_wing_pairs(cloth.mesh, cloth.model->materials(), fast.new_of_old(), kStep).size();
    if (bend < 1e-3) {
      EXPECT_EQ(wings, 0u);
      EXPECT_LT(m.fine_blocks(), 0.6 * m.pattern_blocks());
    } else {
      EXPECT_EQ(wings, cloth.mesh.hinges.size());
      EXPECT_EQ(m.fine_blocks(), m.pattern_blocks());
    }
    EXPECT_LT((jacobi - multigrid).norm(), 1e-7 * jacobi.norm()) << "bend " << bend;
    EXPECT_LT(sm.iterations, sj.iterations) << "bend " << bend;
  }
}
