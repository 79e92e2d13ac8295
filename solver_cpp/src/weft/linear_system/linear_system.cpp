#include "weft/linear_system/linear_system.h"

#include <Eigen/IterativeLinearSolvers>
#include <algorithm>
#include <stdexcept>

#include "weft/common/timer.h"
#include "weft/linear_system/rcm.h"

namespace weft {

namespace {
template <int K, class Visitor>
void for_each_block(const int* vertices, const Eigen::Matrix<double, 3 * K, 3 * K>& m, Visitor&& visit) {
  for (int a = 0; a < K; ++a)
    for (int b = 0; b < K; ++b) visit(vertices[a], vertices[b], m.template block<3, 3>(3 * a, 3 * b));
}

void add_block(SparseMatrix& m, int row_vertex, int col_vertex, const Mat3& block) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m.coeffRef(3 * row_vertex + r, 3 * col_vertex + c) += block(r, c);
}

// The 3x3-block pattern of every element's couplings, built straight in compressed rows (a
// triplet list would take several GB at 640k vertices).
SparseMatrix make_pattern(const ClothMesh& mesh) {
  const int n = mesh.vertex_count;
  std::vector<std::pair<int, int>> edges;
  for (int f = 0; f < mesh.faces.rows(); ++f)
    for (int a = 0; a < 3; ++a) edges.emplace_back(mesh.faces(f, a), mesh.faces(f, (a + 1) % 3));
  for (const Hinge& h : mesh.hinges) edges.emplace_back(h[2], h[3]);
  const Graph g = graph_from_edges(n, edges);
  SparseMatrix m(3 * n, 3 * n);
  Eigen::VectorXi per_row(3 * n);
  for (int i = 0; i < n; ++i)
    for (int r = 0; r < 3; ++r) per_row[3 * i + r] = 3 * (g.degree(i) + 1);
  m.reserve(per_row);
  for (int i = 0; i < n; ++i) {
    std::vector<int> cols(g.neighbors.begin() + g.offsets[i], g.neighbors.begin() + g.offsets[i + 1]);
    cols.insert(std::lower_bound(cols.begin(), cols.end(), i), i);
    for (int r = 0; r < 3; ++r)
      for (int j : cols)
        for (int c = 0; c < 3; ++c) m.insert(3 * i + r, 3 * j + c) = 0.0;
  }
  m.makeCompressed();
  return m;
}
}  // namespace

ReferenceAssembler::ReferenceAssembler(const ClothMesh& mesh)
    : mesh_(mesh), matrix_(make_pattern(mesh)), row_locks_(mesh.vertex_count) {
  for (auto& lock : row_locks_) omp_init_lock(&lock);
}

ReferenceAssembler::~ReferenceAssembler() {
  for (auto& lock : row_locks_) omp_destroy_lock(&lock);
}

void ReferenceAssembler::assemble(const ElementBuffers& e, const std::vector<double>& vertex_mass, const Positions& v,
                                  double h, int threads) {
  const int n = mesh_.vertex_count;
  std::fill(matrix_.valuePtr(), matrix_.valuePtr() + matrix_.nonZeros(), 0.0);
  rhs_.setZero(3 * n);
  diagonal_blocks_.assign(n, Mat3::Zero());
  const auto vflat = flat(v);

  auto scatter = [&](const int* vertices, auto k_const, const auto& force, const auto& stiffness,
                     const auto& damping) {
    constexpr int K = decltype(k_const)::value;
    Eigen::Matrix<double, 3 * K, 1> v_local;
    for (int a = 0; a < K; ++a) v_local.template segment<3>(3 * a) = vflat.segment<3>(3 * vertices[a]);
    const Eigen::Matrix<double, 3 * K, 1> local_rhs = h * (force - h * (stiffness * v_local));
    const Eigen::Matrix<double, 3 * K, 3 * K> local_matrix = h * h * stiffness + h * damping;
    for (int a = 0; a < K; ++a) {
      const int r = vertices[a];
      omp_set_lock(&row_locks_[r]);
      rhs_.segment<3>(3 * r) += local_rhs.template segment<3>(3 * a);
      for (int b = 0; b < K; ++b) {
        const Mat3 block = local_matrix.template block<3, 3>(3 * a, 3 * b);
        add_block(matrix_, r, vertices[b], block);
        if (r == vertices[b]) diagonal_blocks_[r] += block;
      }
      omp_unset_lock(&row_locks_[r]);
    }
  };

  const int face_count = static_cast<int>(mesh_.faces.rows());
  const int hinge_count = static_cast<int>(mesh_.hinges.size());
#pragma omp parallel num_threads(threads)
  {
#pragma omp for schedule(static) nowait
  for (int f = 0; f < face_count; ++f) {
    const int vertices[3] = {mesh_.faces(f, 0), mesh_.faces(f, 1), mesh_.faces(f, 2)};
    scatter(vertices, std::integral_constant<int, 3>{}, e.membrane_force[f], e.membrane_stiffness[f],
            e.membrane_damping[f]);
  }
#pragma omp for schedule(static) nowait
  for (int k = 0; k < hinge_count; ++k)
    scatter(mesh_.hinges[k].data(), std::integral_constant<int, 4>{}, e.hinge_force[k], e.hinge_stiffness[k],
            e.hinge_damping[k]);
#pragma omp for schedule(static)
  for (int i = 0; i < n; ++i) {
    const Mat3 block = (vertex_mass[i] + h * e.vertex_damping[i]) * Mat3::Identity();
    omp_set_lock(&row_locks_[i]);
    add_block(matrix_, i, i, block);
    diagonal_blocks_[i] += block;
    rhs_.segment<3>(3 * i) += h * e.vertex_force[i];
    omp_unset_lock(&row_locks_[i]);
  }
  }
}

void form_prefiltered(const SparseMatrix& a, const VectorX& b, const ConstraintFilter& filter, SparseMatrix& a_out,
                      VectorX& b_out) {
  a_out = a;
  VectorX az(a.rows());
  az.noalias() = a * filter.prescribed;
  b_out = b - az;
  filter.apply(b_out);
  if (filter.constrained_vertices == 0) return;
  const int n = static_cast<int>(filter.projection.size());
  std::vector<int> constrained;
  for (int i = 0; i < n; ++i)
    if (filter.projection[i] != Mat3::Identity()) constrained.push_back(i);
  auto get = [&](int i, int j) {
    Mat3 m;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) m(r, c) = a_out.coeff(3 * i + r, 3 * j + c);
    return m;
  };
  auto set = [&](int i, int j, const Mat3& m) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) a_out.coeffRef(3 * i + r, 3 * j + c) = m(r, c);
  };
  auto neighbors = [&](int i) {  // block columns of block row i (the pattern is symmetric)
    std::vector<int> js;
    for (SparseMatrix::InnerIterator it(a_out, 3 * i); it; ++it)
      if (js.empty() || js.back() != it.col() / 3) js.push_back(static_cast<int>(it.col() / 3));
    return js;
  };
  for (int i : constrained)
    for (int j : neighbors(i)) set(i, j, filter.projection[i] * get(i, j));
  for (int i : constrained)
    for (int j : neighbors(i)) set(j, i, get(j, i) * filter.projection[i]);
  for (int i : constrained) set(i, i, get(i, i) + (Mat3::Identity() - filter.projection[i]));
}

PcgStats eigen_cg_prefiltered(const SparseMatrix& a, const VectorX& b, const ConstraintFilter& filter, VectorX& dv,
                              const PcgSettings& settings, int threads, double* cg_seconds) {
  SparseMatrix filtered;
  VectorX rhs;
  form_prefiltered(a, b, filter, filtered, rhs);
  Eigen::setNbThreads(threads);
  const Timer timer;
  Eigen::ConjugateGradient<SparseMatrix, Eigen::Lower | Eigen::Upper> cg;
  cg.setTolerance(settings.tolerance);
  cg.setMaxIterations(settings.max_iterations);
  cg.compute(filtered);
  VectorX guess = dv;
  filter.apply(guess);
  const VectorX y = cg.solveWithGuess(rhs, guess);
  if (cg_seconds) *cg_seconds = timer.seconds();
  PcgStats stats;
  stats.iterations = static_cast<int>(cg.iterations());
  stats.relative_residual = cg.error();
  stats.converged = cg.info() == Eigen::Success;
  dv = y + filter.prescribed;
  return stats;
}

void ReferenceLinearSystem::build(const Positions& x, const Positions& v, double time, double h) {
  model_.compute(x, v, time, kAllForces, /*project_spd=*/true, options_.threads, elements_);
  assembler_.assemble(elements_, model_.materials().vertex_mass, v, h, options_.threads);
}

PcgStats ReferenceLinearSystem::solve(const ConstraintFilter& filter, VectorX& dv) {
  response_filter_ = filter;
  response_filter_.prescribed.setZero();
  return eigen_cg_prefiltered(assembler_.matrix(), assembler_.rhs(), filter, dv, options_.pcg, options_.threads);
}

PcgStats ReferenceLinearSystem::solve_response(const VectorX& rhs, VectorX& y, const PcgSettings& pcg) {
  if (response_filter_.projection.size() * 3 != static_cast<size_t>(rhs.size()))
    throw std::logic_error("solve_response needs a solve of the same system before it");
  y.setZero(rhs.size());
  return eigen_cg_prefiltered(assembler_.matrix(), rhs, response_filter_, y, pcg, options_.threads);
}

LinearSystemInfo ReferenceLinearSystem::info() const {
  LinearSystemInfo i;
  i.path = "reference";
  i.precision = "float64";
  // One element per triangle (stretch and shear together), per hinge and per particle.
  i.force_elements = mesh_.faces.rows() + static_cast<long long>(mesh_.hinges.size()) + mesh_.vertex_count;
  i.per_force_elements = 2LL * mesh_.faces.rows() + static_cast<long long>(mesh_.hinges.size()) +
                         mesh_.vertex_count * (model_.environment().air_drag > 0.0 ? 2LL : 1LL);
  long long blocks = assembler_.matrix().nonZeros() / 9;
  i.blocks = blocks;
  return i;
}

GlobalJacobians assemble_jacobians(const ClothMesh& mesh, const ElementBuffers& e) {
  const int n = mesh.vertex_count;
  GlobalJacobians g;
  g.force.setZero(3 * n);
  std::vector<Eigen::Triplet<double>> dx, dv;
  auto scatter = [&](const int* vertices, int k, const auto& force, const auto& stiffness, const auto& damping) {
    for (int a = 0; a < k; ++a) {
      g.force.segment<3>(3 * vertices[a]) += force.template segment<3>(3 * a);
      for (int b = 0; b < k; ++b)
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) {
            dx.emplace_back(3 * vertices[a] + r, 3 * vertices[b] + c, -stiffness(3 * a + r, 3 * b + c));
            dv.emplace_back(3 * vertices[a] + r, 3 * vertices[b] + c, -damping(3 * a + r, 3 * b + c));
          }
    }
  };
  for (int f = 0; f < mesh.faces.rows(); ++f) {
    const int vertices[3] = {mesh.faces(f, 0), mesh.faces(f, 1), mesh.faces(f, 2)};
    scatter(vertices, 3, e.membrane_force[f], e.membrane_stiffness[f], e.membrane_damping[f]);
  }
  for (size_t k = 0; k < mesh.hinges.size(); ++k)
    scatter(mesh.hinges[k].data(), 4, e.hinge_force[k], e.hinge_stiffness[k], e.hinge_damping[k]);
  for (int i = 0; i < n; ++i) {
    g.force.segment<3>(3 * i) += e.vertex_force[i];
    for (int r = 0; r < 3; ++r) dv.emplace_back(3 * i + r, 3 * i + r, -e.vertex_damping[i]);
  }
  g.force_dx.resize(3 * n, 3 * n);
  g.force_dv.resize(3 * n, 3 * n);
  g.force_dx.setFromTriplets(dx.begin(), dx.end());
  g.force_dv.setFromTriplets(dv.begin(), dv.end());
  return g;
}

}  // namespace weft
