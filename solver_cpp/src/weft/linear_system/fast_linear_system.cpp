#include "weft/linear_system/fast_linear_system.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "weft/common/timer.h"

namespace weft {

template <class Scalar>
FastLinearSystem<Scalar>::FastLinearSystem(const ClothMesh& mesh, const ForceModel& model,
                                           const LinearSystemOptions& options, int pinned_vertices)
    : mesh_(mesh), model_(model), options_(options) {
  const int n = mesh.vertex_count;
  layout_ = build_force_elements(mesh, model.environment().air_drag > 0.0, pinned_vertices);
  const int element_count = layout_.size();
  if (static_cast<long long>(element_count) * kElementSlots * 2 >= (1LL << 32))
    throw std::invalid_argument("mesh too large for the fast linear system's 32-bit element slots");

  // Coupling graph of the elements and its RCM order.
  std::vector<std::pair<int, int>> edges;
  edges.reserve(static_cast<size_t>(element_count) * 6);
  for (int e = 0; e < element_count; ++e)
    for (int a = 0; a < layout_.count[e]; ++a)
      for (int b = a + 1; b < layout_.count[e]; ++b) edges.emplace_back(layout_.vertices[e][a], layout_.vertices[e][b]);
  const Graph graph = graph_from_edges(n, edges);
  edges.clear();
  edges.shrink_to_fit();
  bandwidth_natural_ = bandwidth(graph, {});
  order_ = reverse_cuthill_mckee(graph);
  new_of_old_.resize(n);
  for (int k = 0; k < n; ++k) new_of_old_[order_[k]] = k;
  // Elements in RCM order too (by their lowest row), so that the gather over block rows reads
  // element storage nearly sequentially instead of all over a large mesh's buffers.
  {
    std::vector<int> key(element_count), perm(element_count);
    for (int e = 0; e < element_count; ++e) {
      key[e] = n;
      for (int a = 0; a < layout_.count[e]; ++a) key[e] = std::min(key[e], new_of_old_[layout_.vertices[e][a]]);
    }
    std::iota(perm.begin(), perm.end(), 0);
    std::stable_sort(perm.begin(), perm.end(), [&](int a, int b) { return key[a] < key[b]; });
    permute_elements(layout_, perm);
  }

  // Fixed pattern in RCM order: each row's neighbours plus the diagonal, ascending.
  std::vector<int> row_start(n + 1, 0), columns;
  columns.reserve(graph.neighbors.size() + n);
  for (int r = 0; r < n; ++r) {
    const int old = order_[r];
    const size_t first = columns.size();
    columns.push_back(r);
    for (int k = graph.offsets[old]; k < graph.offsets[old + 1]; ++k) columns.push_back(new_of_old_[graph.neighbors[k]]);
    std::sort(columns.begin() + first, columns.end());
    row_start[r + 1] = static_cast<int>(columns.size());
  }
  diagonal_index_.resize(n);
  for (int r = 0; r < n; ++r)
    diagonal_index_[r] = static_cast<int>(std::lower_bound(columns.begin() + row_start[r], columns.begin() + row_start[r + 1], r) -
                                          columns.begin());
  auto find_block = [&](int r, int c) {
    return static_cast<int>(std::lower_bound(columns.begin() + row_start[r], columns.begin() + row_start[r + 1], c) -
                            columns.begin());
  };

  // Gather lists (counting sort keeps element order within each block and row).
  const size_t block_count = columns.size();
  block_source_start_.assign(block_count + 1, 0);
  rhs_source_start_.assign(n + 1, 0);
  for (int e = 0; e < element_count; ++e)
    for (int a = 0; a < layout_.count[e]; ++a) {
      const int r = new_of_old_[layout_.vertices[e][a]];
      ++rhs_source_start_[r + 1];
      for (int b = 0; b < layout_.count[e]; ++b) ++block_source_start_[find_block(r, new_of_old_[layout_.vertices[e][b]]) + 1];
    }
  std::partial_sum(block_source_start_.begin(), block_source_start_.end(), block_source_start_.begin());
  std::partial_sum(rhs_source_start_.begin(), rhs_source_start_.end(), rhs_source_start_.begin());
  block_source_.resize(block_source_start_.back());
  rhs_source_.resize(rhs_source_start_.back());
  std::vector<int> block_fill(block_source_start_.begin(), block_source_start_.end() - 1);
  std::vector<int> rhs_fill(rhs_source_start_.begin(), rhs_source_start_.end() - 1);
  for (int e = 0; e < element_count; ++e)
    for (int a = 0; a < layout_.count[e]; ++a) {
      const int r = new_of_old_[layout_.vertices[e][a]];
      rhs_source_[rhs_fill[r]++] = static_cast<std::uint32_t>(e) * 4u + static_cast<std::uint32_t>(a);
      for (int b = 0; b < layout_.count[e]; ++b) {
        const int k = find_block(r, new_of_old_[layout_.vertices[e][b]]);
        const std::uint32_t slot = static_cast<std::uint32_t>(e) * kElementSlots + element_slot(std::min(a, b), std::max(a, b));
        block_source_[block_fill[k]++] = (slot << 1) | (a > b ? 1u : 0u);
      }
    }

  matrix_.set_pattern(std::move(row_start), columns);
  const auto& mass = model.materials().vertex_mass;
  row_mass_.resize(n);
  for (int r = 0; r < n; ++r) row_mass_[r] = mass[order_[r]];
  rhs_.setZero(3 * n);
  diagonal_.assign(n, Mat3::Zero());
  permuted_filter_.reset(n);
  permuted_dv_.setZero(3 * n);
}

namespace {
constexpr int kGatherPrefetch = 8;  // sources ahead whose element block the gather prefetches
}  // namespace

template <class Scalar>
void FastLinearSystem<Scalar>::build(const Positions& x, const Positions& v, double time, double h) {
  const int n = mesh_.vertex_count;
  const int threads = options_.threads;
  if (h != last_h_) multigrid_stale_ = true;  // h^2 K against M: a different operator
  last_h_ = h;
  if (first_h_ == 0.0) first_h_ = h;
  compute_force_elements(model_, layout_, x, v, time, h, threads, storage_);
  reduce_transient(transient_, new_of_old_, v, h, threads, transient_rows_);
  const bool any_transient = !transient_rows_.rows.empty();
  // Transient entries outside the fixed pattern, per touched row slot.
  std::vector<std::vector<std::pair<int, Mat3>>> outside(transient_rows_.rows.size());

  const Scalar* blocks = storage_.blocks.data();
  const double* element_rhs = storage_.rhs.data();
#pragma omp parallel for schedule(static) num_threads(threads)
  for (int r = 0; r < n; ++r) {
    const int begin = matrix_.row_begin(r), end = matrix_.row_end(r);
    const int t = any_transient ? transient_rows_.slot[r] : -1;
    int next_transient = t >= 0 ? transient_rows_.start[t] : 0;
    const int transient_end = t >= 0 ? transient_rows_.start[t + 1] : 0;
    for (int k = begin; k < end; ++k) {
      double acc[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
      for (int s = block_source_start_[k]; s < block_source_start_[k + 1]; ++s) {
        // The element blocks a few sources ahead: a large mesh's element storage is read in
        // nearly but not quite sequential order, and these loads wait on memory otherwise.
        if (s + kGatherPrefetch < static_cast<int>(block_source_.size()))
          __builtin_prefetch(blocks + 9 * static_cast<size_t>(block_source_[s + kGatherPrefetch] >> 1));
        const std::uint32_t code = block_source_[s];
        const Scalar* src = blocks + 9 * static_cast<size_t>(code >> 1);
        if (code & 1u) {
          for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) acc[3 * i + j] += static_cast<double>(src[3 * j + i]);
        } else {
          for (int i = 0; i < 9; ++i) acc[i] += static_cast<double>(src[i]);
        }
      }
      const int c = matrix_.column(k, r);
      if (t >= 0) {  // transient entries of this row, columns ascending like the pattern's
        while (next_transient < transient_end && transient_rows_.columns[next_transient] < c) {
          outside[t].emplace_back(transient_rows_.columns[next_transient], transient_rows_.blocks[next_transient]);
          ++next_transient;
        }
        if (next_transient < transient_end && transient_rows_.columns[next_transient] == c) {
          const Mat3& a = transient_rows_.blocks[next_transient++];
          for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) acc[3 * i + j] += a(i, j);
        }
      }
      if (k == diagonal_index_[r]) {
        acc[0] += row_mass_[r];
        acc[4] += row_mass_[r];
        acc[8] += row_mass_[r];
      }
      Scalar* dst = matrix_.block(k);  // column-major
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) dst[3 * j + i] = static_cast<Scalar>(acc[3 * i + j]);
      if (k == diagonal_index_[r])
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) diagonal_[r](i, j) = static_cast<double>(dst[3 * j + i]);
    }
    for (; next_transient < transient_end; ++next_transient)
      outside[t].emplace_back(transient_rows_.columns[next_transient], transient_rows_.blocks[next_transient]);
    Vec3 b = Vec3::Zero();
    for (int s = rhs_source_start_[r]; s < rhs_source_start_[r + 1]; ++s) {
      const double* src = element_rhs + 3 * static_cast<size_t>(rhs_source_[s]);
      b += Vec3(src[0], src[1], src[2]);
    }
    if (t >= 0) b += transient_rows_.rhs[t];
    rhs_.segment<3>(3 * r) = b;
  }

  // Transient part of the matrix: what did not overlap the fixed pattern (32-bit columns).
  std::vector<int> rows, start{0};
  std::vector<std::int32_t> cols;
  std::vector<Scalar> values;
  for (size_t t = 0; t < outside.size(); ++t) {
    if (outside[t].empty()) continue;
    rows.push_back(transient_rows_.rows[t]);
    for (const auto& [c, a] : outside[t]) {
      cols.push_back(c);
      for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 3; ++i) values.push_back(static_cast<Scalar>(a(i, j)));
    }
    start.push_back(static_cast<int>(cols.size()));
  }
  matrix_.set_transient(std::move(rows), std::move(start), std::move(cols), std::move(values));
}

template <class Scalar>
PcgStats FastLinearSystem<Scalar>::solve(const ConstraintFilter& filter, VectorX& dv) {
  return solve_with(filter, dv, options_.pcg);
}

template <class Scalar>
PcgStats FastLinearSystem<Scalar>::solve_with(const ConstraintFilter& filter, VectorX& dv, const PcgSettings& pcg) {
  return solve_with(filter, dv, pcg, options_.preconditioner);
}

template <class Scalar>
bool FastLinearSystem<Scalar>::uses_multigrid(Preconditioner preconditioner) const {
  return preconditioner == Preconditioner::kMultigrid ||
         (preconditioner == Preconditioner::kAuto && (mesh_.vertex_count >= kMultigridAutoVertices || auto_switched_));
}

template <class Scalar>
PcgStats FastLinearSystem<Scalar>::solve_with(const ConstraintFilter& filter, VectorX& dv, const PcgSettings& pcg,
                                              Preconditioner preconditioner) {
  const int n = mesh_.vertex_count;
  // Each CG iteration has three barriers; below a few thousand rows they cost more than the
  // work they split (and far more on a loaded machine), so small systems solve on one thread.
  // The iterates are bitwise the same either way (fixed-order reductions).
  const int threads = n >= kParallelSolveRows ? options_.threads : 1;
  if (dv.size() != 3 * n) throw std::invalid_argument("dv must have 3 entries per vertex");
  // Filter and warm start into row order; only constrained vertices carry a non-identity S.
  permuted_filter_.constrained_vertices = filter.constrained_vertices;
#pragma omp parallel for schedule(static) num_threads(threads)
  for (int r = 0; r < n; ++r) {
    const int old = order_[r];
    permuted_filter_.projection[r] = filter.projection[old];
    permuted_filter_.prescribed.segment<3>(3 * r) = filter.prescribed.segment<3>(3 * old);
    permuted_dv_.segment<3>(3 * r) = dv.segment<3>(3 * old);
  }
  auto apply = [this, threads](const VectorX& in, VectorX& out, double* chunk_dots) {
    out.resize(in.size());
    matrix_.multiply(in.data(), out.data(), threads, chunk_dots);
  };
  PcgStats stats;
  ++solves_;
  // kAuto on a small system: block Jacobi first, at most kAutoBlockJacobiIterations; a solve
  // that needs more goes on from its iterate with multigrid (and the frame's later solves
  // start with it). Decided afresh each frame, so a resumed run decides as the original did.
  bool tried_block_jacobi = false;
  int block_jacobi_iterations = 0;  // of a first attempt that did not converge
  if (preconditioner == Preconditioner::kAuto && !uses_multigrid(preconditioner) && !multigrid_unusable_ &&
      pcg.max_iterations > kAutoBlockJacobiIterations) {
    tried_block_jacobi = true;
    PcgSettings capped = pcg;
    capped.max_iterations = kAutoBlockJacobiIterations;
    stats = prefiltered_pcg(apply, diagonal_, permuted_filter_, rhs_, permuted_dv_, capped, threads);
    if (!stats.converged && std::isfinite(stats.relative_residual)) {
      auto_switched_ = true;
      block_jacobi_iterations = stats.iterations;
    }
  }
  const bool go_on = !tried_block_jacobi || block_jacobi_iterations > 0;
  PcgSettings rest = pcg;
  rest.max_iterations = pcg.max_iterations - block_jacobi_iterations;
  last_multigrid_ = go_on && uses_multigrid(preconditioner) && prepare_multigrid(threads);
  if (last_multigrid_) {
    const double setup = multigrid_last_setup_seconds_;
    auto cycle = [this, threads](const VectorX& r, VectorX& z) { multigrid_->apply(r, z, threads); };
    stats = prefiltered_pcg(apply, diagonal_, permuted_filter_, rhs_, permuted_dv_, rest, threads, cycle);
    double setup_seconds = setup;
    int reused_iterations = 0;  // of a first attempt with reused values or bounds, if it failed
    if (!stats.converged && !multigrid_all_fresh_) {
      // Reused values (or bounds) that no longer fit: once more from where CG stopped, with
      // everything fresh.
      multigrid_stale_ = true;
      if (prepare_multigrid(threads)) {
        reused_iterations = stats.iterations;
        setup_seconds += multigrid_last_setup_seconds_;
        stats = prefiltered_pcg(apply, diagonal_, permuted_filter_, rhs_, permuted_dv_, rest, threads, cycle);
      }
    }
    if (multigrid_refreshed_) multigrid_fresh_iterations_ = stats.iterations;
    multigrid_last_iterations_ = stats.iterations;
    stats.iterations += reused_iterations + block_jacobi_iterations;
    stats.preconditioner_setup_seconds = setup_seconds;
  } else if (go_on) {  // block Jacobi (after a first attempt: multigrid unusable after all)
    stats = prefiltered_pcg(apply, diagonal_, permuted_filter_, rhs_, permuted_dv_, rest, threads);
    stats.iterations += block_jacobi_iterations;
  }
#pragma omp parallel for schedule(static) num_threads(threads)
  for (int r = 0; r < n; ++r) dv.segment<3>(3 * order_[r]) = permuted_dv_.segment<3>(3 * r);
  return stats;
}

template <class Scalar>
PcgStats FastLinearSystem<Scalar>::solve_response(const VectorX& rhs, VectorX& y, const PcgSettings& pcg) {
  const int n = mesh_.vertex_count;
  if (rhs.size() != 3 * n) throw std::invalid_argument("rhs must have 3 entries per vertex");
  if (solves_ == 0) throw std::logic_error("solve_response needs a solve of the same system before it");
  const int threads = n >= kParallelSolveRows ? options_.threads : 1;
  // The last solve's filter (row order) with nothing prescribed: y stays zero along it.
  response_filter_.projection = permuted_filter_.projection;
  response_filter_.constrained_vertices = permuted_filter_.constrained_vertices;
  response_filter_.prescribed.setZero(3 * n);
  response_rhs_.resize(3 * n);
  response_y_.setZero(3 * n);
  for (int r = 0; r < n; ++r) response_rhs_.segment<3>(3 * r) = rhs.segment<3>(3 * order_[r]);
  auto apply = [this, threads](const VectorX& in, VectorX& out, double* chunk_dots) {
    out.resize(in.size());
    matrix_.multiply(in.data(), out.data(), threads, chunk_dots);
  };
  PcgStats stats;
  if (last_multigrid_) {  // the hierarchy as the last solve left it: current for this filter
    auto cycle = [this, threads](const VectorX& r, VectorX& z) { multigrid_->apply(r, z, threads); };
    stats = prefiltered_pcg(apply, diagonal_, response_filter_, response_rhs_, response_y_, pcg, threads, cycle);
  } else {
    stats = prefiltered_pcg(apply, diagonal_, response_filter_, response_rhs_, response_y_, pcg, threads);
  }
  y.resize(3 * n);
  for (int r = 0; r < n; ++r) y.segment<3>(3 * order_[r]) = response_y_.segment<3>(3 * r);
  return stats;
}

// The finest level lumps a hinge's wing coupling W (multigrid.h): exact on translations and
// smooth bending of a flat hinge, it stiffens a folded hinge's wings by about |W| theta^2, which
// CG does not notice while |W| is small beside the wing masses (cloth of a centimetre or more:
// h^2 k_bend w_e |g_2| |g_3| / m is 0.03-0.05 on `weft bench solver`'s sheets, 1.5-6 for cotton at
// 1 cm and 1/96 s) and does once it is not (a crumpled 1 cm test sheet: as many iterations at
// 16-65, 1.7x at 160-650; gtest Multigrid.StiffWingsStayOnTheFinestLevel). The ratio uses the
// rest shape and the first build's step, so a resumed run decides as the original did.
std::vector<std::pair<int, int>> stiff_wing_pairs(const ClothMesh& mesh, const ClothMaterials& materials,
                                                  const std::vector<int>& new_of_old, double h) {
  std::vector<std::pair<int, int>> pairs;
  for (size_t e = 0; e < mesh.hinges.size(); ++e) {
    const Hinge& hinge = mesh.hinges[e];
    const double a0 = mesh.rest_area[mesh.hinge_faces[e][0]], a1 = mesh.rest_area[mesh.hinge_faces[e][1]];
    const double edge_squared = mesh.hinge_weight[e] * (a0 + a1) / 3.0;  // w_e = 3 |e|^2 / (A0 + A1)
    // |g_w| = |e| / (2 A_w): the angle's gradient at a wing vertex, one over its height.
    const double coupling = h * h * materials.hinge_bend[e] * mesh.hinge_weight[e] * edge_squared / (4.0 * a0 * a1);
    const double mass = std::min(materials.vertex_mass[hinge[2]], materials.vertex_mass[hinge[3]]);
    if (!(coupling <= kLumpedWingRatio * mass)) pairs.emplace_back(new_of_old[hinge[2]], new_of_old[hinge[3]]);
  }
  return pairs;
}

template <class Scalar>
bool FastLinearSystem<Scalar>::prepare_multigrid(int threads) {
  if (multigrid_unusable_) return false;
  Timer timer;
  if (!multigrid_) {
    // Strength of connection: the triangle edges (stretch and shear); couplings through a
    // hinge alone (bending) are weak. Pattern-only, so a resumed run aggregates the same.
    std::vector<std::pair<int, int>> edges;
    edges.reserve(3 * static_cast<size_t>(mesh_.faces.rows()));
    for (Eigen::Index f = 0; f < mesh_.faces.rows(); ++f)
      for (int c = 0; c < 3; ++c)
        edges.emplace_back(new_of_old_[mesh_.faces(f, c)], new_of_old_[mesh_.faces(f, (c + 1) % 3)]);
    try {
      multigrid_ = std::make_unique<SmoothedAggregation>(SmoothedAggregation::from_pattern(
          matrix_, graph_from_edges(mesh_.vertex_count, edges), MultigridOptions{},
          graph_from_edges(mesh_.vertex_count, stiff_wing_pairs(mesh_, model_.materials(), new_of_old_, first_h_))));
    } catch (const std::invalid_argument&) {  // no useful hierarchy (coarsening stalled)
      multigrid_unusable_ = true;
      return false;
    }
    multigrid_structure_seconds_ = timer.seconds();
    timer.restart();
  }
  multigrid_refreshed_ = multigrid_refresh_due();
  multigrid_all_fresh_ = multigrid_refreshed_ && multigrid_stale_;
  multigrid_last_setup_seconds_ = 0.0;
  if (!multigrid_refreshed_) {
    ++multigrid_age_;
    multigrid_->update_fine(matrix_, permuted_filter_, threads);
    multigrid_last_setup_seconds_ = timer.seconds();
    multigrid_setup_seconds_ += multigrid_last_setup_seconds_;
    return true;
  }
  try {
    // Within a frame and at the same step size the smoothers' spectral radii are kept: a
    // refresh for a new contact filter skips its Lanczos steps (a fifth of the setup).
    multigrid_->update(matrix_, permuted_filter_, threads, !multigrid_stale_);
  } catch (const std::runtime_error&) {  // coarsest level not SPD (a broken matrix)
    multigrid_stale_ = true;
    return false;
  }
  multigrid_stale_ = false;
  multigrid_age_ = 0;
  refreshed_constrained_ = permuted_filter_.constrained_vertices;
  if (refreshed_constrained_ > 0) refreshed_projection_ = permuted_filter_.projection;
  ++multigrid_refreshes_;
  multigrid_last_setup_seconds_ = timer.seconds();
  multigrid_setup_seconds_ += multigrid_last_setup_seconds_;
  return true;
}

// The hierarchy's values (filtered fine operator, smoother bounds, prolongators, coarse
// operators) are a preconditioner: any symmetric positive-definite one keeps CG exact, and
// those of a recent substep's matrix precondition this one nearly as well at no setup cost
// (the setup is worth about 5 CG iterations; docs/multigrid.md, "Reuse"). The finest level's
// operator is always the current one (the smoother needs it); the rest is recomputed at the
// first solve of every frame (so a resumed run repeats the original bit for bit; the
// smoothers' spectral radii only then and at a new step size), when the
// step size or the constraint filter changed (a new contact set cost a drape 60% more
// iterations), after kMultigridMaxAge reuses, when the last solve needed
// clearly more iterations than the one right after the last refresh, and - in solve_with -
// at once when a solve with reused values did not converge.
template <class Scalar>
bool FastLinearSystem<Scalar>::multigrid_refresh_due() const {
  if (multigrid_stale_ || multigrid_age_ >= kMultigridMaxAge) return true;
  if (permuted_filter_.constrained_vertices != refreshed_constrained_) return true;
  if (refreshed_constrained_ > 0 && permuted_filter_.projection != refreshed_projection_) return true;
  const int fresh = multigrid_fresh_iterations_;
  return multigrid_last_iterations_ > fresh + std::max(2, fresh / 4);
}

template <class Scalar>
void FastLinearSystem<Scalar>::residual(const VectorX& dv, VectorX& r) const {
  const int n = mesh_.vertex_count;
  const int threads = n >= kParallelSolveRows ? options_.threads : 1;
  VectorX in(3 * n), out(3 * n);
  for (int row = 0; row < n; ++row) in.segment<3>(3 * row) = dv.segment<3>(3 * order_[row]);
  matrix_.multiply(in.data(), out.data(), threads, nullptr);
  r.resize(3 * n);
  for (int row = 0; row < n; ++row) r.segment<3>(3 * order_[row]) = rhs_.segment<3>(3 * row) - out.segment<3>(3 * row);
}

template <class Scalar>
LinearSystemInfo FastLinearSystem<Scalar>::info() const {
  LinearSystemInfo i;
  i.path = "fast";
  i.precision = sizeof(Scalar) == 4 ? "float32" : "float64";
  i.force_elements = layout_.size();
  i.per_force_elements = layout_.per_force_elements;
  i.bandwidth_natural = bandwidth_natural_;
  i.bandwidth = matrix_.bandwidth();
  i.narrow_columns = matrix_.narrow_columns();
  i.blocks = static_cast<long long>(matrix_.block_count());
  i.transient_blocks = static_cast<long long>(matrix_.transient_block_count());
  i.bytes_per_multiply = matrix_.bytes_per_multiply();
  i.preconditioner = last_multigrid_ ? "multigrid" : "block_jacobi";
  if (multigrid_) {
    i.multigrid_rows = multigrid_->level_rows();
    i.multigrid_operator_complexity = multigrid_->operator_complexity();
  }
  i.multigrid_structure_seconds = multigrid_structure_seconds_;
  i.multigrid_setup_seconds = multigrid_setup_seconds_;
  i.multigrid_refreshes = multigrid_refreshes_;
  i.solves = solves_;
  return i;
}

template <class Scalar>
Eigen::SparseMatrix<double, Eigen::RowMajor> FastLinearSystem<Scalar>::to_sparse_original() const {
  const int n = mesh_.vertex_count;
  std::vector<Eigen::Triplet<double>> entries;
  auto add = [&](int r, int c, const Scalar* a) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        entries.emplace_back(3 * order_[r] + i, 3 * order_[c] + j, static_cast<double>(a[3 * j + i]));
  };
  for (int r = 0; r < n; ++r)
    for (int k = matrix_.row_begin(r); k < matrix_.row_end(r); ++k) add(r, matrix_.column(k, r), matrix_.block(k));
  for (const auto& [r, c, a] : matrix_.transient_entries()) add(r, c, a);
  Eigen::SparseMatrix<double, Eigen::RowMajor> m(3 * n, 3 * n);
  m.setFromTriplets(entries.begin(), entries.end());
  return m;
}

template <class Scalar>
VectorX FastLinearSystem<Scalar>::rhs_original() const {
  VectorX b(rhs_.size());
  for (int r = 0; r < mesh_.vertex_count; ++r) b.segment<3>(3 * order_[r]) = rhs_.segment<3>(3 * r);
  return b;
}

template class FastLinearSystem<float>;
template class FastLinearSystem<double>;

}  // namespace weft
