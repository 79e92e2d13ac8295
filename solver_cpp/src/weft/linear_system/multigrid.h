// Smoothed-aggregation algebraic multigrid (Tamstorf, Jones & McCormick, "Smoothed Aggregation
// Multigrid for Cloth Simulation", SIGGRAPH Asia 2015) as the preconditioner of the pre-filtered
// PCG (pcg.h), for the 3x3-block system of the fast linear system.
//
// The hierarchy sees the filtered operator  A0 = S A S + I - S  (S: per-vertex projection onto
// the unconstrained directions). Per level l, with B_i the near-null-space block of node i (3x3:
// the three rigid translations; on the finest level B_i = S_i, i.e. filtered):
//   aggregates    greedy standard aggregation on a strength graph, nodes in row (RCM) order
//                 (fine level: the triangle edges; coarse levels: the coarse matrix pattern);
//   tentative     T_iJ = B_i G_J^(-1/2) for i in aggregate J, G_J = sum B_i^T B_i (a symmetric
//                 orthonormalisation, the QR of classic SA; directions with G_J = 0, e.g. an
//                 aggregate of pinned vertices, are dropped: Q_J = projection onto range(G_J));
//   prolongator   P = (I - omega D^-1 A) T, omega = 4 / (3 rho), rho >~ rho(D^-1 A) by a few
//                 Lanczos steps, the largest Ritz value plus its residual (D: the 3x3 diagonal
//                 blocks); on the finest level A and D are the filtered A^F and its lumped
//                 diagonal (MultigridOptions::filtered_smoothing);
//   coarse        A_c = P^T A P + (I - Q): the same pre-filtered form one level down, so every
//                 level is SPD; B_c,J = G_J^(1/2).
// The finest level's A is not the system's matrix but its lumped form A^L (MultigridOptions::
// lumped_fine_operator): the blocks outside the strength graph (a hinge's coupling of its two
// wing vertices) dropped and completed on the two rows' diagonals so that A^L - A >= 0 and A^L
// acts on a flat hinge's translations and smooth bending as A does. A^L stays SPD and has about
// half of A's blocks: the cycle's products on the finest level, the bulk of its cost, stream
// half the bytes. Stiff wings (the `kept` graph: FastLinearSystem's stiff_wing_pairs) stay.
// Level operators are stored in float32 (values rounded once, symmetric bit for bit; setup
// arithmetic in double, the cycle's products by the BCRS float32 kernel); prolongators in double. Coarsest level: dense Cholesky (Eigen LLT). Cycle: V(1,1) with Chebyshev smoothing of
// D^-1 A on [upper / 30, upper], upper = 1.1 rho, the same polynomial before and after the
// coarse correction, so the cycle is a symmetric positive-definite operator and CG stays valid.
//
// Structure (aggregates, patterns of P, A P, P^T, A_c) is built once from the fixed block
// pattern; values (filter, rho, T, P, A_c, Cholesky) are recomputed by update(), or only the
// finest level's operator by update_fine() (the owner decides when: fast_linear_system.cpp).
// Only the fixed pattern enters the hierarchy: transient blocks outside it (contact springs) are left to CG's own product,
// which keeps the preconditioner SPD (a spring minus its off-diagonal blocks is still PSD).
// Every row is computed by one thread in a fixed order and every dot product is an ordered sum
// (ordered_sum.h): bitwise identical for any thread count.
#pragma once

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "weft/common/types.h"
#include "weft/linear_system/bcrs.h"
#include "weft/linear_system/pcg.h"
#include "weft/linear_system/rcm.h"

namespace weft {

using Mat3f = Eigen::Matrix3f;

// Block compressed rows of 3x3 blocks (values of type T), absolute sorted columns.
template <class T>
struct BlockRowsOf {
  using Block = Eigen::Matrix<T, 3, 3>;
  int rows = 0, cols = 0;
  std::vector<int> start{0};
  std::vector<int> column;
  std::vector<Block> value;
  // y = M x (y += M x with accumulate) in double; rows split over threads, each row summed in
  // column order. With `rounded`, y is also written there rounded to float32, 4 lanes per row
  // (BcrsMatrix::store_rounded), for a product that follows.
  void multiply(const VectorX& x, VectorX& y, int threads, bool accumulate = false, float* rounded = nullptr) const;
};
using BlockRows = BlockRowsOf<double>;    // A P (setup only)
using BlockRowsF = BlockRowsOf<float>;    // level operators, prolongators, restrictions

struct MultigridOptions {
  int coarse_rows = 64;         // stop coarsening at or below this many 3x3 rows
  int max_levels = 10;
  int smoother_degree = 2;      // Chebyshev degree of the pre- and of the post-smoothing
  int lanczos_steps = 10;       // for rho(D^-1 A) per level and solve
  double upper_factor = 1.1;    // Chebyshev upper bound = upper_factor * rho
  double lower_ratio = 1.0 / 30.0;  // Chebyshev lower bound = lower_ratio * upper bound
  // The finest level's prolongator is smoothed with the filtered operator A^F: the blocks
  // outside the strength graph (a hinge's couplings across an edge) dropped and added to their
  // row's diagonal block, so A^F keeps A's row sums (its action on rigid translations). P's
  // rows then reach only the aggregates of a row's strong neighbours (Vanek, Mandel & Brezina
  // 1996; pyamg's filtered smoothing): a sparser P, A P and coarse operator, a cheaper setup
  // and cycle. false: P smoothed with A itself.
  bool filtered_smoothing = true;
  // The finest level's operator drops the blocks outside the strength graph (bending's coupling
  // W of a hinge's two wing vertices i, j, which share no triangle edge) and completes each
  // dropped pair on the two diagonals so that the change is positive semi-definite:
  // A^L = A + sum over pairs of [[X, -W], [-W^T, Y]] with W = s u v^T + R (u, v unit: W's
  // dominant column and row directions, R the rest), X = |s| u u^T + |R| I, Y = |s| v v^T + |R| I
  // (|R| Frobenius): the pair term is |s| (u; -sign(s) v)(u; -sign(s) v)^T plus a term that
  // |R| bounds, both >= 0. So A^L >= A and A^L is SPD wherever A is. A hinge's wing block is
  // rank one (bending and its damping act along one gradient), so R vanishes up to rounding,
  // and on a flat hinge u = sign(s) v (both wings move along the normal): A^L acts on
  // translations and on smooth bending as A does, where the plain bound |W| I on both diagonals
  // stiffened exactly those modes (twice the iterations on a fine, light sheet). Filtered
  // (S_i X S_i): the same bound for S A S. The cycle (smoothing, residuals) and the coarse
  // levels see A^L, CG multiplies with A: the preconditioner stays SPD and CG exact, with the
  // finest level's products over about half the blocks (a regular sheet: 7 of 13 per row). With
  // it filtered_smoothing has nothing left to filter on the finest level.
  bool lumped_fine_operator = true;
};

// Adds to `completion` row i's share of the positive semi-definite completion of a dropped
// off-diagonal block W = A_ij (lumped_fine_operator): |s| u u^T + |R| I, u W's dominant column
// direction, v its dominant row direction, s = u^T W v, |R| = |W - s u v^T| (Frobenius:
// sqrt(|W|^2 - s^2), R being orthogonal to u v^T). Row j, computing the same from A_ji = W^T,
// adds |s| v v^T + |R| I: its column norms are row i's row norms, summed in the same order, so
// both rows pick the same directions (ties go to the first). Scalar code: it runs for every
// dropped block at every solve.
inline void add_diagonal_completion(const Mat3f& block, Mat3& completion) {
  double w[3][3], column_squares[3] = {0.0, 0.0, 0.0}, row_squares[3] = {0.0, 0.0, 0.0};
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      w[a][b] = block(a, b);
      const double square = w[a][b] * w[a][b];
      column_squares[b] += square;
      row_squares[a] += square;
    }
  int column = 0, row = 0;
  for (int k = 1; k < 3; ++k) {
    if (column_squares[k] > column_squares[column]) column = k;
    if (row_squares[k] > row_squares[row]) row = k;
  }
  if (column_squares[column] == 0.0 || row_squares[row] == 0.0) return;
  const double column_scale = 1.0 / std::sqrt(column_squares[column]), row_scale = 1.0 / std::sqrt(row_squares[row]);
  double u[3], v[3];
  for (int k = 0; k < 3; ++k) {
    u[k] = w[k][column] * column_scale;
    v[k] = w[row][k] * row_scale;
  }
  double s = 0.0;
  for (int a = 0; a < 3; ++a) s += u[a] * (w[a][0] * v[0] + w[a][1] * v[1] + w[a][2] * v[2]);
  const double frobenius_squared = column_squares[0] + column_squares[1] + column_squares[2];
  const double rest = std::sqrt(std::max(0.0, frobenius_squared - s * s));
  const double weight = std::abs(s);
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) completion(a, b) += weight * u[a] * u[b];
    completion(a, a) += rest;
  }
}

class SmoothedAggregation {
 public:
  // Fine pattern in row order (row_start, sorted absolute columns with the diagonal) and the
  // strength graph of the finest level (same numbering). `kept`: couplings outside the strength
  // graph that lumped_fine_operator must not drop (stiff bending; empty: none).
  SmoothedAggregation(const std::vector<int>& row_start, const std::vector<int>& columns, const Graph& strength,
                      const MultigridOptions& options = {}, const Graph& kept = {});
  template <class Scalar>
  static SmoothedAggregation from_pattern(const BcrsMatrix<Scalar>& a, const Graph& strength,
                                          const MultigridOptions& options = {}, const Graph& kept = {});

  // Values of every level for the fixed part of `a` filtered by `filter` (row order).
  // keep_bounds: the smoothers' spectral radii of the last update() stay (no Lanczos), for a
  // matrix of the same step size a substep later.
  template <class Scalar>
  void update(const BcrsMatrix<Scalar>& a, const ConstraintFilter& filter, int threads, bool keep_bounds = false);
  // Only the finest level's operator (and smoother diagonal) for a new `a` and `filter`; the
  // coarse levels, prolongators and smoother bounds stay those of the last update().
  template <class Scalar>
  void update_fine(const BcrsMatrix<Scalar>& a, const ConstraintFilter& filter, int threads);
  // Same as update, from the unfiltered fine blocks (in the given pattern's block order) - tests.
  void update_blocks(const std::vector<Mat3>& fine_blocks, const ConstraintFilter& filter, int threads);
  // z = B r: one V(1,1) cycle from zero. The caller filters r and z (pcg.h).
  void apply(const VectorX& r, VectorX& z, int threads) const;

  int levels() const { return static_cast<int>(levels_.size()); }
  // Blocks of the pattern the hierarchy was built for (the system's matrix) and of the finest
  // level's operator (fewer when lumped_fine_operator dropped the weak ones).
  int pattern_blocks() const { return pattern_blocks_; }
  int fine_blocks() const { return static_cast<int>(levels_[0].a.value.size()); }
  std::vector<int> level_rows() const;
  double operator_complexity() const;  // blocks of all levels / blocks of the finest
  // Blocks of level l's prolongator (l below the coarsest).
  int prolongator_blocks(int l) const { return static_cast<int>(levels_[l].p.value.size()); }
  const BlockRowsF& level_matrix(int l) const { return levels_[l].a; }
  double spectral_radius(int l) const { return levels_[l].rho; }

 private:
  struct Level {
    BlockRowsF a;                      // operator: values per update(), float32 (half the bytes)
    BcrsMatrix<float> kernel;          // the same values for the cycle's products (bcrs.h SSE kernel)
    std::vector<int> diagonal;         // block index of each row's diagonal
    std::vector<char> weak;            // per block, outside the strength graph (finest level; empty: none)
    std::vector<Mat3> smoothing_inverse;  // (lumped diagonal of A^F)^-1 per row, where weak is not empty
    std::vector<int> transpose;        // block index of (column, row) for each block
    std::vector<Mat3> inverse_diagonal;
    std::vector<Mat3> near_null;       // B_i
    std::vector<int> aggregate;        // node -> coarse node (not on the coarsest level)
    std::vector<int> member_start, members;  // aggregates' nodes, in order
    BlockRowsF p, r;                   // prolongator and restriction P^T (float32: R = P^T exactly)
    BlockRows ap;                      // A P (double, setup only)
    std::vector<int> r_source;         // r.value[k] = p.value[r_source[k]]^T
    std::vector<Mat3> tentative;       // T_i (row i's block of T, column aggregate[i])
    std::vector<Mat3> kept;            // Q_J of the coarse nodes (range of G_J)
    double rho = 1.0;
    mutable VectorX x, f, res, d, t, rr;  // V-cycle work vectors (x, f: coarse levels only; the
                                          // finest level's are the caller's)
    mutable std::array<std::vector<float>, 2> rounded;  // smooth(): float32 copies, 4 lanes per row
  };
  // Levels below this many rows run on one thread (the parallel regions cost more than the
  // rows). 256, not 2048: a 4k-vertex garment's first coarse level (about 500 rows, a quarter of
  // the fine level's blocks) ran serially while the other thread waited, and split it took 8%
  // off the solve (`python -m bench.contact`, drape and dress, module against module).
  static constexpr int kParallelLevelRows = 256;
  static int level_threads(int rows, int threads) { return rows >= kParallelLevelRows ? threads : 1; }
  bool coarsen_structure(int l, const Graph& strength);
  // Level::weak from the strength graph (cleared when every block is strong).
  static void mark_weak_blocks(Level& level, const Graph& strength);
  // lumped_fine_operator: level 0's pattern becomes the given one's strong and kept blocks.
  void lump_pattern(const Graph& strength, const Graph& kept);
  void update_values(const ConstraintFilter& filter, int threads, bool keep_bounds = false);  // level 0's blocks copied
  void update_fine_values(const ConstraintFilter& filter, int threads);
  void filter_fine_level(const ConstraintFilter& filter, int threads);  // S A S + I - S in place, B_i = S_i
  // Level 0's values from the pattern's blocks (block(k): block k of the pattern as a Mat3f;
  // lumped_diagonal_ from the dropped ones).
  template <class BlockOf>
  void copy_fine_values(BlockOf&& block, int threads);
  template <class Scalar>
  void copy_fine_blocks(const BcrsMatrix<Scalar>& a, int threads);
  void update_level_values(int l, int threads, bool keep_bounds);
  void finish_level(int l, int threads);  // copies level l's operator values into its kernel
  double estimate_spectral_radius(const Level& level, int threads, int steps) const;
  // Chebyshev smoothing of x for f (x = 0 first when zero_start). Returns x rounded to float32
  // for BcrsMatrix::multiply_rows_rounded when round_result (in one of level.rounded), else nullptr.
  // x_rounded: x already rounded (level.rounded[1]), or nullptr; not read from a zero start.
  const float* smooth(const Level& level, const VectorX& f, VectorX& x, bool zero_start, const float* x_rounded,
                      bool round_result, int threads) const;
  // x = V-cycle of level l applied to f (the fine level's f and x are the caller's vectors).
  void cycle(int l, const VectorX& f, VectorX& x, int threads) const;

  MultigridOptions options_;
  std::vector<Level> levels_;
  int pattern_blocks_ = 0;
  // With lumped_fine_operator: the pattern's block of each of level 0's blocks, per row the
  // pattern's blocks dropped (weak_start_, weak_blocks_) and the sum of their diagonal
  // completions (lumped_diagonal_, added on the diagonal by filter_fine_level). All empty when
  // nothing is dropped.
  std::vector<int> fine_source_, weak_start_, weak_blocks_;
  std::vector<Mat3> lumped_diagonal_;
  bool bounds_estimated_ = false;  // every level's rho comes from a Lanczos estimate
  Eigen::LLT<Eigen::MatrixXd> coarse_solver_;
};

template <class Scalar>
SmoothedAggregation SmoothedAggregation::from_pattern(const BcrsMatrix<Scalar>& a, const Graph& strength,
                                                      const MultigridOptions& options, const Graph& kept) {
  std::vector<int> start(a.rows() + 1), columns;
  columns.reserve(a.block_count());
  for (int r = 0; r < a.rows(); ++r) {
    for (int k = a.row_begin(r); k < a.row_end(r); ++k) columns.push_back(a.column(k, r));
    start[r + 1] = static_cast<int>(columns.size());
  }
  return SmoothedAggregation(start, columns, strength, options, kept);
}

template <class BlockOf>
void SmoothedAggregation::copy_fine_values(BlockOf&& block, int threads) {
  BlockRowsF& fine = levels_[0].a;
  if (fine_source_.empty()) {
#pragma omp parallel for schedule(static) num_threads(threads)
    for (std::int64_t k = 0; k < static_cast<std::int64_t>(fine.value.size()); ++k)
      fine.value[k] = block(static_cast<int>(k));
    return;
  }
#pragma omp parallel for schedule(static) num_threads(threads)
  for (int i = 0; i < fine.rows; ++i) {
    for (int k = fine.start[i]; k < fine.start[i + 1]; ++k) fine.value[k] = block(fine_source_[k]);
    Mat3 completion = Mat3::Zero();
    for (int m = weak_start_[i]; m < weak_start_[i + 1]; ++m) add_diagonal_completion(block(weak_blocks_[m]), completion);
    lumped_diagonal_[i] = completion;
  }
}

template <class Scalar>
void SmoothedAggregation::copy_fine_blocks(const BcrsMatrix<Scalar>& a, int threads) {
  copy_fine_values(
      [&a](int k) -> Mat3f { return Eigen::Map<const Eigen::Matrix<Scalar, 3, 3>>(a.block(k)).template cast<float>(); },
      threads);
}

template <class Scalar>
void SmoothedAggregation::update(const BcrsMatrix<Scalar>& a, const ConstraintFilter& filter, int threads,
                                 bool keep_bounds) {
  copy_fine_blocks(a, threads);
  update_values(filter, threads, keep_bounds);
}

template <class Scalar>
void SmoothedAggregation::update_fine(const BcrsMatrix<Scalar>& a, const ConstraintFilter& filter, int threads) {
  copy_fine_blocks(a, threads);
  update_fine_values(filter, threads);
}

}  // namespace weft
