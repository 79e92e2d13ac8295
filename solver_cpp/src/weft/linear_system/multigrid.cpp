#include "weft/linear_system/multigrid.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "weft/common/ordered_sum.h"

namespace weft {

namespace {

// A coarsest level this large would make the per-solve dense Cholesky the whole cost.
constexpr int kMaxCoarsestRows = 2000;

// Sorted, unique columns of each row, from a row -> candidate-columns callback.
template <class T, class Emit>
void build_pattern(BlockRowsOf<T>& m, int rows, int cols, Emit&& emit) {
  m.rows = rows;
  m.cols = cols;
  m.start.assign(1, 0);
  m.column.clear();
  std::vector<int> mark(cols, -1), row;
  for (int i = 0; i < rows; ++i) {
    row.clear();
    emit(i, [&](int c) {
      if (mark[c] != i) {
        mark[c] = i;
        row.push_back(c);
      }
    });
    std::sort(row.begin(), row.end());
    m.column.insert(m.column.end(), row.begin(), row.end());
    m.start.push_back(static_cast<int>(m.column.size()));
  }
  m.value.assign(m.column.size(), BlockRowsOf<T>::Block::Zero());
}

// c = x y on c's (precomputed) pattern; each row of c summed in double in x's then y's column
// order, then stored in c's value type.
template <class TX, class TY, class TC>
void multiply_values(const BlockRowsOf<TX>& x, const BlockRowsOf<TY>& y, BlockRowsOf<TC>& c, int threads) {
#pragma omp parallel num_threads(threads) if (threads > 1)
  {
    std::vector<int> where(c.cols, -1);
    std::vector<Mat3> acc;
#pragma omp for schedule(static)
    for (int i = 0; i < c.rows; ++i) {
      acc.assign(c.start[i + 1] - c.start[i], Mat3::Zero());
      for (int k = c.start[i]; k < c.start[i + 1]; ++k) where[c.column[k]] = k - c.start[i];
      for (int a = x.start[i]; a < x.start[i + 1]; ++a) {
        const Mat3 xa = x.value[a].template cast<double>();
        const int j = x.column[a];
        for (int b = y.start[j]; b < y.start[j + 1]; ++b)
          acc[where[y.column[b]]].noalias() += xa * y.value[b].template cast<double>();
      }
      for (int k = c.start[i]; k < c.start[i + 1]; ++k) c.value[k] = acc[k - c.start[i]].template cast<TC>();
    }
  }
}

// Exact symmetry: each pair of blocks (i, j), (j, i) and each diagonal block replaced by the
// float32 rounding of their double average.
void symmetrize(BlockRowsF& m, const std::vector<int>& transpose, int threads) {
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1)
  for (int i = 0; i < m.rows; ++i)
    for (int k = m.start[i]; k < m.start[i + 1]; ++k) {
      const int j = m.column[k], t = transpose[k];
      if (j < i) continue;
      const Mat3 average = 0.5 * (m.value[k].cast<double>() + m.value[t].cast<double>().transpose());
      m.value[k] = average.cast<float>();
      if (t != k) m.value[t] = m.value[k].transpose();
    }
}

// Standard aggregation (Vanek et al.; pyamg's standard_aggregation), greedy in node order:
// (1) a node whose neighbours are all free seeds an aggregate with them; (2) every free node
// joins the aggregate of its first neighbour aggregated in (1); (3) what is left seeds
// aggregates with its free neighbours. Returns the aggregate count.
int standard_aggregation(const Graph& g, std::vector<int>& aggregate) {
  const int n = g.size();
  aggregate.assign(n, -1);
  int count = 0;
  for (int i = 0; i < n; ++i) {
    if (aggregate[i] >= 0) continue;
    bool free = true;
    for (int k = g.offsets[i]; k < g.offsets[i + 1] && free; ++k) free = aggregate[g.neighbors[k]] < 0;
    if (!free) continue;
    aggregate[i] = count;
    for (int k = g.offsets[i]; k < g.offsets[i + 1]; ++k) aggregate[g.neighbors[k]] = count;
    ++count;
  }
  const std::vector<int> first_pass = aggregate;
  for (int i = 0; i < n; ++i) {
    if (aggregate[i] >= 0) continue;
    for (int k = g.offsets[i]; k < g.offsets[i + 1]; ++k)
      if (first_pass[g.neighbors[k]] >= 0) {
        aggregate[i] = first_pass[g.neighbors[k]];
        break;
      }
  }
  for (int i = 0; i < n; ++i) {
    if (aggregate[i] >= 0) continue;
    aggregate[i] = count;
    for (int k = g.offsets[i]; k < g.offsets[i + 1]; ++k)
      if (aggregate[g.neighbors[k]] < 0) aggregate[g.neighbors[k]] = count;
    ++count;
  }
  return count;
}

// A deterministic, zero-mean pseudo-random start vector for the Lanczos iteration.
double start_entry(std::int64_t k) {
  std::uint64_t h = static_cast<std::uint64_t>(k) * 0x9E3779B97F4A7C15ull;
  h ^= h >> 29;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 32;
  return 2.0 * static_cast<double>(h % 1000003) / 1000003.0 - 1.0;
}

}  // namespace

// rho(D^-1 A) by Lanczos on the pencil (A, D) (D: the diagonal blocks), from a fixed start
// vector: the largest Ritz value of `steps` steps plus its residual. The Ritz value alone is a
// lower bound (it converges far faster than power iterations on the clustered top of a cloth
// spectrum: 10 power iterations underestimated a 64x64 sheet's 2.46 as 2.02, and the Chebyshev
// smoother then diverged), and 10 steps left it up to about 6% low on the drape of `weft bench
// contact`: beyond the smoother's 1.1 margin on some solves, where the V-cycle was then not
// positive definite and CG broke down (r . z < 0) short of its tolerance. With the residual
// added the estimate lies at or above the top (docs/multigrid.md, "Thirty-first session").
double SmoothedAggregation::estimate_spectral_radius(const Level& level, int threads, int steps) const {
  const BlockRowsF& a = level.a;
  const int n = a.rows;
  VectorX& v = level.d;
  VectorX& previous = level.rr;
  VectorX& w = level.t;
  VectorX& av = level.res;
  // Sums of term(i) over the rows, fixed order; term may also write row i.
  auto sums = [&](auto&& term) {
    return ordered_sums<1>(n, threads, [&](std::int64_t b, std::int64_t e) {
      std::array<double, 1> s{};
      for (std::int64_t i = b; i < e; ++i) s[0] += term(static_cast<int>(i));
      return s;
    })[0];
  };
  auto d_dot = [&](const Vec3& x, int i) { return x.dot(a.value[level.diagonal[i]].cast<double>() * x); };
  for (Eigen::Index k = 0; k < v.size(); ++k) v[k] = start_entry(k);
  previous.setZero(v.size());
  const double norm = std::sqrt(sums([&](int i) { return d_dot(v.segment<3>(3 * i), i); }));
  if (!(norm > 0.0) || !std::isfinite(norm)) return 1.0;
  v /= norm;
  std::vector<double> alpha, beta;
  double last_beta = 0.0;  // the D-norm of the last step's remainder: the Ritz residuals' scale
  for (int j = 0; j < steps; ++j) {
    level.kernel.multiply(v.data(), av.data(), threads);
    const double aj = sums([&](int i) { return v.segment<3>(3 * i).dot(av.segment<3>(3 * i)); });
    alpha.push_back(aj);
    const double bj = beta.empty() ? 0.0 : beta.back();
    // w = D^-1 A v - alpha v - beta v_previous and its D-norm, one pass.
    const double b_next = std::sqrt(sums([&](int i) {
      const Vec3 wi = level.inverse_diagonal[i] * av.segment<3>(3 * i) - aj * v.segment<3>(3 * i) -
                      bj * previous.segment<3>(3 * i);
      w.segment<3>(3 * i) = wi;
      return d_dot(wi, i);
    }));
    if (!(b_next > 1e-12 * std::abs(aj)) || !std::isfinite(b_next)) break;  // an invariant subspace
    if (j + 1 == steps) {
      last_beta = b_next;
      break;
    }
    beta.push_back(b_next);
    previous.swap(v);
    v = w / b_next;
  }
  const int m = static_cast<int>(alpha.size());
  Eigen::MatrixXd t = Eigen::MatrixXd::Zero(m, m);
  for (int j = 0; j < m; ++j) {
    t(j, j) = alpha[j];
    if (j + 1 < m) t(j, j + 1) = t(j + 1, j) = beta[j];
  }
  // The largest Ritz value theta lies below the top of the spectrum; an eigenvalue lies within
  // its residual |beta_m s_m| of it (s: its eigenvector of T; Parlett, "The Symmetric Eigenvalue
  // Problem", 13.2), so theta plus the residual bounds the top the steps have found from above.
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(t);
  const double theta = eigen.eigenvalues()(m - 1);
  const double rho = theta + last_beta * std::abs(eigen.eigenvectors()(m - 1, m - 1));
  return rho > 0.0 && std::isfinite(rho) ? rho : 1.0;
}

template <class T>
void BlockRowsOf<T>::multiply(const VectorX& x, VectorX& y, int threads, bool accumulate, float* rounded) const {
  if (!accumulate) y.resize(3 * static_cast<Eigen::Index>(rows));
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1)
  for (int i = 0; i < rows; ++i) {
    Vec3 s = Vec3::Zero();
    for (int k = start[i]; k < start[i + 1]; ++k)
      s.noalias() += value[k].template cast<double>() * x.segment<3>(3 * column[k]);
    if (accumulate)
      y.segment<3>(3 * i) += s;
    else
      y.segment<3>(3 * i) = s;
    if (rounded) BcrsMatrix<float>::store_rounded(rounded, i, y[3 * i], y[3 * i + 1], y[3 * i + 2]);
  }
}
template struct BlockRowsOf<float>;
template struct BlockRowsOf<double>;

SmoothedAggregation::SmoothedAggregation(const std::vector<int>& row_start, const std::vector<int>& columns,
                                         const Graph& strength, const MultigridOptions& options, const Graph& kept)
    : options_(options) {
  if (options_.smoother_degree < 1) throw std::invalid_argument("multigrid smoother degree must be at least 1");
  const int rows = static_cast<int>(row_start.size()) - 1;
  if (strength.size() != rows) throw std::invalid_argument("strength graph and pattern differ in size");
  pattern_blocks_ = static_cast<int>(columns.size());
  levels_.emplace_back();
  {
    BlockRowsF& a = levels_[0].a;
    a.rows = a.cols = rows;
    a.start = row_start;
    a.column = columns;
    if (options_.lumped_fine_operator) lump_pattern(strength, kept);
    a.value.assign(a.column.size(), Mat3f::Zero());
  }
  Graph g = strength;
  for (int l = 0;; ++l) {
    Level& level = levels_[l];
    const int n = level.a.rows;
    level.diagonal.assign(n, -1);
    for (int i = 0; i < n; ++i)
      for (int k = level.a.start[i]; k < level.a.start[i + 1]; ++k)
        if (level.a.column[k] == i) level.diagonal[i] = k;
    if (std::find(level.diagonal.begin(), level.diagonal.end(), -1) != level.diagonal.end())
      throw std::invalid_argument("multigrid: a row of the pattern has no diagonal block");
    level.transpose.assign(level.a.column.size(), -1);
    for (int i = 0; i < n; ++i)
      for (int k = level.a.start[i]; k < level.a.start[i + 1]; ++k) {
        const int j = level.a.column[k];
        const auto first = level.a.column.begin() + level.a.start[j], last = level.a.column.begin() + level.a.start[j + 1];
        const auto found = std::lower_bound(first, last, i);
        if (found == last || *found != i) throw std::invalid_argument("multigrid: the pattern is not symmetric");
        level.transpose[k] = static_cast<int>(found - level.a.column.begin());
      }
    level.kernel.set_pattern(level.a.start, level.a.column);
    if (l == 0 && options_.filtered_smoothing) mark_weak_blocks(level, g);
    level.inverse_diagonal.assign(n, Mat3::Identity());
    level.near_null.assign(n, Mat3::Identity());
    for (VectorX* v : {&level.res, &level.d, &level.t, &level.rr}) v->setZero(3 * n);
    if (l > 0) {  // the finest level cycles on the caller's vectors
      level.x.setZero(3 * n);
      level.f.setZero(3 * n);
    }
    if (n <= options_.coarse_rows || l + 1 >= options_.max_levels || !coarsen_structure(l, g)) {
      if (n > kMaxCoarsestRows)
        throw std::invalid_argument("multigrid: coarsening stalled at " + std::to_string(n) + " rows");
      break;
    }
    // The next level's strength graph: its whole pattern (theta = 0).
    const BlockRowsF& c = levels_[l + 1].a;
    Graph next;
    next.offsets.assign(1, 0);
    for (int i = 0; i < c.rows; ++i) {
      for (int k = c.start[i]; k < c.start[i + 1]; ++k)
        if (c.column[k] != i) next.neighbors.push_back(c.column[k]);
      next.offsets.push_back(static_cast<int>(next.neighbors.size()));
    }
    g = std::move(next);
  }
}

void SmoothedAggregation::lump_pattern(const Graph& strength, const Graph& kept) {
  const bool any_kept = !kept.offsets.empty();
  if (any_kept && kept.size() != levels_[0].a.rows) throw std::invalid_argument("kept graph and pattern differ in size");
  BlockRowsF& a = levels_[0].a;
  std::vector<int> start(1, 0), column;
  column.reserve(a.column.size());
  fine_source_.clear();
  weak_start_.assign(1, 0);
  weak_blocks_.clear();
  for (int i = 0; i < a.rows; ++i) {
    for (int k = a.start[i]; k < a.start[i + 1]; ++k) {
      const int j = a.column[k];
      if (j == i || strength.has_edge(i, j) || (any_kept && kept.has_edge(i, j))) {
        column.push_back(j);
        fine_source_.push_back(k);
      } else {
        weak_blocks_.push_back(k);
      }
    }
    start.push_back(static_cast<int>(column.size()));
    weak_start_.push_back(static_cast<int>(weak_blocks_.size()));
  }
  if (weak_blocks_.empty()) {  // nothing to lump: level 0 is the pattern itself
    fine_source_.clear();
    weak_start_.clear();
    return;
  }
  a.start = std::move(start);
  a.column = std::move(column);
  lumped_diagonal_.assign(a.rows, Mat3::Zero());
}

void SmoothedAggregation::mark_weak_blocks(Level& level, const Graph& strength) {
  const BlockRowsF& a = level.a;
  level.weak.assign(a.column.size(), 0);
  bool any = false;
  for (int i = 0; i < a.rows; ++i) {
    for (int k = a.start[i]; k < a.start[i + 1]; ++k) {
      const int j = a.column[k];
      level.weak[k] = j != i && !strength.has_edge(i, j);
      any = any || level.weak[k];
    }
  }
  if (!any) level.weak.clear();
}

bool SmoothedAggregation::coarsen_structure(int l, const Graph& strength) {
  std::vector<int> aggregate;
  const int n = levels_[l].a.rows;
  const int nc = standard_aggregation(strength, aggregate);
  if (nc >= n) return false;  // nothing to gain
  Level next;
  {
    Level& level = levels_[l];
    level.aggregate = std::move(aggregate);
    level.member_start.assign(nc + 1, 0);
    for (int i = 0; i < n; ++i) ++level.member_start[level.aggregate[i] + 1];
    for (int J = 0; J < nc; ++J) level.member_start[J + 1] += level.member_start[J];
    level.members.resize(n);
    std::vector<int> fill(level.member_start.begin(), level.member_start.end() - 1);
    for (int i = 0; i < n; ++i) level.members[fill[level.aggregate[i]]++] = i;
    level.tentative.assign(n, Mat3::Zero());
    level.kept.assign(nc, Mat3::Identity());
    const BlockRowsF& a = level.a;
    // P: row i reaches the aggregates of i's matrix neighbours (one Jacobi step of T), its
    // strong ones where the level smooths with a filtered operator.
    build_pattern(level.p, n, nc, [&](int i, auto&& add) {
      for (int k = a.start[i]; k < a.start[i + 1]; ++k)
        if (level.weak.empty() || !level.weak[k]) add(level.aggregate[a.column[k]]);
    });
    build_pattern(level.ap, n, nc, [&](int i, auto&& add) {
      for (int k = a.start[i]; k < a.start[i + 1]; ++k) {
        const int j = a.column[k];
        for (int b = level.p.start[j]; b < level.p.start[j + 1]; ++b) add(level.p.column[b]);
      }
    });
    // R = P^T, rows filled in fine-row order.
    BlockRowsF& r = level.r;
    r.rows = nc;
    r.cols = n;
    r.start.assign(nc + 1, 0);
    for (int c : level.p.column) ++r.start[c + 1];
    for (int J = 0; J < nc; ++J) r.start[J + 1] += r.start[J];
    r.column.resize(level.p.column.size());
    r.value.assign(level.p.column.size(), Mat3f::Zero());
    level.r_source.resize(level.p.column.size());
    std::vector<int> rfill(r.start.begin(), r.start.end() - 1);
    for (int i = 0; i < n; ++i)
      for (int k = level.p.start[i]; k < level.p.start[i + 1]; ++k) {
        const int slot = rfill[level.p.column[k]]++;
        r.column[slot] = i;
        level.r_source[slot] = k;
      }
    build_pattern(next.a, nc, nc, [&](int I, auto&& add) {
      for (int k = r.start[I]; k < r.start[I + 1]; ++k) {
        const int i = r.column[k];
        for (int b = level.ap.start[i]; b < level.ap.start[i + 1]; ++b) add(level.ap.column[b]);
      }
    });
  }
  levels_.push_back(std::move(next));
  return true;
}

std::vector<int> SmoothedAggregation::level_rows() const {
  std::vector<int> rows;
  for (const Level& l : levels_) rows.push_back(l.a.rows);
  return rows;
}

double SmoothedAggregation::operator_complexity() const {
  double total = 0.0;
  for (const Level& l : levels_) total += static_cast<double>(l.a.column.size());
  return total / static_cast<double>(levels_[0].a.column.size());
}

void SmoothedAggregation::update_blocks(const std::vector<Mat3>& fine_blocks, const ConstraintFilter& filter,
                                        int threads) {
  if (fine_blocks.size() != static_cast<size_t>(pattern_blocks_)) throw std::invalid_argument("multigrid: wrong block count");
  copy_fine_values([&fine_blocks](int k) -> Mat3f { return fine_blocks[k].cast<float>(); }, threads);
  update_values(filter, threads);
}

void SmoothedAggregation::update_values(const ConstraintFilter& filter, int threads, bool keep_bounds) {
  update_fine_values(filter, threads);
  keep_bounds = keep_bounds && bounds_estimated_;
  for (int l = 0; l + 1 < levels(); ++l) {
    update_level_values(l, threads, keep_bounds);
    finish_level(l + 1, threads);
  }
  const BlockRowsF& last = levels_.back().a;
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(3 * last.rows, 3 * last.rows);
  for (int i = 0; i < last.rows; ++i)
    for (int k = last.start[i]; k < last.start[i + 1]; ++k)
      dense.block<3, 3>(3 * i, 3 * last.column[k]) = last.value[k].cast<double>();
  coarse_solver_.compute(dense);
  if (coarse_solver_.info() != Eigen::Success) throw std::runtime_error("multigrid: coarsest matrix not positive definite");
  bounds_estimated_ = true;
}

void SmoothedAggregation::update_fine_values(const ConstraintFilter& filter, int threads) {
  filter_fine_level(filter, threads);
  finish_level(0, threads);
}

void SmoothedAggregation::filter_fine_level(const ConstraintFilter& filter, int threads) {
  Level& fine = levels_[0];
  const int n = fine.a.rows;
  const int th = level_threads(n, threads);
  // The pre-filtered operator S A S + I - S and the filtered near-null space B_i = S_i.
  if (filter.constrained_vertices > 0) {
    std::vector<char> constrained(n);
    for (int i = 0; i < n; ++i) constrained[i] = filter.projection[i] != Mat3::Identity();
#pragma omp parallel for schedule(static) num_threads(th) if (th > 1)
    for (int i = 0; i < n; ++i) {
      for (int k = fine.a.start[i]; k < fine.a.start[i + 1]; ++k) {
        const int j = fine.a.column[k];
        if (!constrained[i] && !constrained[j]) continue;
        // (S_i A_ij) S_j above the diagonal, S_i (A_ij S_j) below: block (j, i) is then the
        // exact transpose of block (i, j) (the fixed pattern's values are symmetric bit for bit).
        const Mat3 a = fine.a.value[k].cast<double>();
        const Mat3& si = filter.projection[i];
        const Mat3& sj = filter.projection[j];
        Mat3 v = j >= i ? Mat3((si * a) * sj) : Mat3(si * (a * sj));
        if (j == i) v = Mat3(0.5 * (v + v.transpose())) + (Mat3::Identity() - si);  // a copy: no aliasing
        fine.a.value[k] = v.cast<float>();
      }
      fine.near_null[i] = filter.projection[i];
    }
  } else {
    std::fill(fine.near_null.begin(), fine.near_null.end(), Mat3::Identity());
  }
  if (lumped_diagonal_.empty()) return;
  // A^L: the dropped blocks' completions on the diagonal, filtered (S_i X S_i; the identity of
  // the constrained directions stays as the filter left it).
  const bool filtered = filter.constrained_vertices > 0;
#pragma omp parallel for schedule(static) num_threads(th) if (th > 1)
  for (int i = 0; i < n; ++i) {
    const Mat3& x = lumped_diagonal_[i];
    Mat3 add = filtered && filter.projection[i] != Mat3::Identity()
                   ? Mat3(filter.projection[i] * x * filter.projection[i])
                   : x;
    add = 0.5 * (add + add.transpose()).eval();  // symmetric bit for bit
    Mat3f& d = fine.a.value[fine.diagonal[i]];
    d = (d.cast<double>() + add).cast<float>();
  }
}

void SmoothedAggregation::finish_level(int l, int threads) {
  Level& level = levels_[l];
  const std::int64_t blocks = static_cast<std::int64_t>(level.a.value.size());
  const int th = level_threads(level.a.rows, threads);
#pragma omp parallel for schedule(static) num_threads(th) if (th > 1)
  for (std::int64_t k = 0; k < blocks; ++k)  // both column-major
    std::copy(level.a.value[k].data(), level.a.value[k].data() + 9, level.kernel.block(static_cast<int>(k)));
  if (l + 1 == levels()) return;  // the coarsest level is solved exactly
#pragma omp parallel for schedule(static) num_threads(th) if (th > 1)
  for (int i = 0; i < level.a.rows; ++i)
    level.inverse_diagonal[i] = level.a.value[level.diagonal[i]].cast<double>().inverse();
}

void SmoothedAggregation::update_level_values(int l, int threads, bool keep_bounds) {
  Level& level = levels_[l];
  Level& next = levels_[l + 1];
  const BlockRowsF& a = level.a;
  const int n = a.rows, nc = next.a.rows;
  const int th = level_threads(n, threads);

  if (!keep_bounds) level.rho = estimate_spectral_radius(level, th, options_.lanczos_steps);
  // Tentative prolongator: T_i = B_i G_J^(-1/2) on the range of G_J; next level's B_J = G_J^(1/2).
  const int thc = level_threads(nc, threads);
#pragma omp parallel for schedule(static) num_threads(thc) if (thc > 1)
  for (int J = 0; J < nc; ++J) {
    Mat3 g = Mat3::Zero();
    for (int m = level.member_start[J]; m < level.member_start[J + 1]; ++m) {
      const Mat3& b = level.near_null[level.members[m]];
      g.noalias() += b.transpose() * b;
    }
    Mat3 inv_sqrt, sqrt_g, kept;
    const bool scalar = g(0, 1) == 0.0 && g(0, 2) == 0.0 && g(1, 2) == 0.0 && g(1, 0) == 0.0 && g(2, 0) == 0.0 &&
                        g(2, 1) == 0.0 && g(0, 0) == g(1, 1) && g(1, 1) == g(2, 2) && g(0, 0) > 0.0;
    if (scalar) {
      const double s = std::sqrt(g(0, 0));
      inv_sqrt = Mat3::Identity() / s;
      sqrt_g = Mat3::Identity() * s;
      kept = Mat3::Identity();
    } else {
      Eigen::SelfAdjointEigenSolver<Mat3> eig(g);
      const Vec3 lambda = eig.eigenvalues();
      const double cut = 1e-10 * std::max(lambda.maxCoeff(), 0.0);
      Vec3 is = Vec3::Zero(), sq = Vec3::Zero(), on = Vec3::Zero();
      for (int k = 0; k < 3; ++k)
        if (lambda[k] > cut && lambda[k] > 0.0) {
          is[k] = 1.0 / std::sqrt(lambda[k]);
          sq[k] = std::sqrt(lambda[k]);
          on[k] = 1.0;
        }
      const Mat3& v = eig.eigenvectors();
      inv_sqrt = v * is.asDiagonal() * v.transpose();
      sqrt_g = v * sq.asDiagonal() * v.transpose();
      kept = v * on.asDiagonal() * v.transpose();
    }
    for (int m = level.member_start[J]; m < level.member_start[J + 1]; ++m) {
      const int i = level.members[m];
      level.tentative[i] = level.near_null[i] * inv_sqrt;
    }
    next.near_null[J] = sqrt_g;
    level.kept[J] = kept;
  }

  // Smoothed prolongator P = (I - omega D^-1 A) T, or with the filtered A^F and its lumped
  // diagonal D^F (a diagonal that lumping left singular keeps A's own).
  const double omega = 4.0 / (3.0 * level.rho);
  BlockRowsF& p = level.p;
  const bool filtered = !level.weak.empty();
  if (filtered) {
    level.smoothing_inverse.resize(n);
#pragma omp parallel for schedule(static) num_threads(th) if (th > 1)
    for (int i = 0; i < n; ++i) {
      Mat3 lumped = a.value[level.diagonal[i]].cast<double>();
      for (int k = a.start[i]; k < a.start[i + 1]; ++k)
        if (level.weak[k]) lumped += a.value[k].cast<double>();
      Mat3 inverse;
      bool invertible = false;
      double determinant = 0.0;
      lumped.computeInverseAndDetWithCheck(inverse, determinant, invertible);
      level.smoothing_inverse[i] = invertible && determinant > 0.0 && inverse.allFinite() ? inverse
                                                                                        : level.inverse_diagonal[i];
    }
  }
  const std::vector<Mat3>& smoothing_inverse = filtered ? level.smoothing_inverse : level.inverse_diagonal;
#pragma omp parallel num_threads(th) if (th > 1)
  {
    std::vector<int> where(nc, -1);
    std::vector<Mat3> row;  // row i of P in double, rounded once when stored
#pragma omp for schedule(static)
    for (int i = 0; i < n; ++i) {
      const int begin = p.start[i], count = p.start[i + 1] - begin;
      row.assign(count, Mat3::Zero());
      for (int k = 0; k < count; ++k) where[p.column[begin + k]] = k;
      for (int k = a.start[i]; k < a.start[i + 1]; ++k) {
        const int j = a.column[k];
        if (filtered && level.weak[k]) {
          // A^F: the weak block moves onto the diagonal (T_j's aggregate may be outside P's row).
          row[where[level.aggregate[i]]].noalias() += a.value[k].cast<double>() * level.tentative[i];
          continue;
        }
        row[where[level.aggregate[j]]].noalias() += a.value[k].cast<double>() * level.tentative[j];
      }
      const Mat3 scale = -omega * smoothing_inverse[i];
      for (Mat3& block : row) block = (scale * block).eval();
      row[where[level.aggregate[i]]] += level.tentative[i];
      for (int k = 0; k < count; ++k) p.value[begin + k] = row[k].cast<float>();
    }
  }
  BlockRowsF& r = level.r;
  const int thr = level_threads(static_cast<int>(r.value.size()) / 8, threads);
#pragma omp parallel for schedule(static) num_threads(thr) if (thr > 1)
  for (std::int64_t k = 0; k < static_cast<std::int64_t>(r.value.size()); ++k)
    r.value[k] = p.value[level.r_source[k]].transpose();

  // Galerkin operator A_c = P^T (A P) + (I - Q). The restriction's product has the coarse
  // level's rows but the fine level's work (each coarse row sums its aggregate's rows of A P):
  // it gets the fine level's threads.
  multiply_values(a, p, level.ap, th);
  multiply_values(r, level.ap, next.a, th);
  for (int J = 0; J < nc; ++J) {
    Mat3f& d = next.a.value[next.diagonal[J]];
    d = (d.cast<double>() + Mat3::Identity() - level.kept[J]).cast<float>();
  }
  symmetrize(next.a, next.transpose, thc);
}

}  // namespace weft
