// The fast linear system (issue 4, after the seed): see linear_system_path.h for the contract.
//
// Start-up: fixed force elements (force_elements.h), the vertex graph of their couplings, a
// Reverse Cuthill-McKee order of it, the fixed block pattern in that order and, for every
// global block and every rhs row, the list of element slots that contribute to it.
// Per step: (1) elements computed in parallel into their own storage, (2) transient elements
// reduced per row (transient.h), (3) a lock-free parallel pass over block rows gathers the
// element slots in their fixed list order (double accumulation, one rounding to Scalar) and
// merges transient entries that overlap the pattern; the rest become the transient part.
// Solve: the filter, rhs and warm start are permuted into RCM order and the pre-filtered PCG
// (pcg.h) runs with the BCRS SpMV (bcrs.h), preconditioned by block Jacobi or by smoothed-
// aggregation multigrid (multigrid.h; structure built at the first solve, the finest level's
// values every solve, the rest when due: multigrid_refresh_due).
#pragma once

#include <Eigen/SparseCore>

#include "weft/linear_system/bcrs.h"
#include "weft/forces/force_elements.h"
#include "weft/linear_system/linear_system_path.h"
#include "weft/linear_system/multigrid.h"
#include "weft/linear_system/rcm.h"

namespace weft {

constexpr int kParallelSolveRows = 2048;  // smaller systems solve on one thread (barriers: weft/__init__.py)
constexpr int kMultigridMaxAge = 7;  // solves that may reuse the hierarchy's values (fast_linear_system.cpp)
// A hinge whose wing coupling h^2 k_bend w_e |g_2| |g_3| (rest geometry, nominal step) exceeds
// this many times the lighter wing vertex's mass keeps the coupling on multigrid's finest level
// instead of lumping it (MultigridOptions::lumped_fine_operator; fast_linear_system.cpp).
constexpr double kLumpedWingRatio = 16.0;

// The wing pairs (row numbering: new_of_old) of the hinges above kLumpedWingRatio for step h.
std::vector<std::pair<int, int>> stiff_wing_pairs(const ClothMesh& mesh, const ClothMaterials& materials,
                                                  const std::vector<int>& new_of_old, double h);

template <class Scalar>
class FastLinearSystem final : public LinearSystemPath {
 public:
  FastLinearSystem(const ClothMesh& mesh, const ForceModel& model, const LinearSystemOptions& options,
                   int pinned_vertices);

  void build(const Positions& x, const Positions& v, double time, double h) override;
  PcgStats solve(const ConstraintFilter& filter, VectorX& dv) override;
  PcgStats solve_response(const VectorX& rhs, VectorX& y, const PcgSettings& pcg) override;
  void residual(const VectorX& dv, VectorX& r) const override;
  TransientElements* transient() override { return &transient_; }
  void start_frame() override {
    multigrid_stale_ = true;
    auto_switched_ = false;
  }
  void set_threads(int threads) override { options_.threads = threads; }
  LinearSystemInfo info() const override;

  const BcrsMatrix<Scalar>& matrix() const { return matrix_; }
  const std::vector<int>& order() const { return order_; }          // order[row] = vertex
  const std::vector<int>& new_of_old() const { return new_of_old_; }
  const VectorX& rhs() const { return rhs_; }                        // in row order
  const std::vector<Mat3>& diagonal_blocks() const { return diagonal_; }
  // The last built system in the original vertex order, values as stored, in double.
  Eigen::SparseMatrix<double, Eigen::RowMajor> to_sparse_original() const;
  VectorX rhs_original() const;
  // Solves the last built system from `dv` (original order) with pcg settings `pcg`.
  PcgStats solve_with(const ConstraintFilter& filter, VectorX& dv, const PcgSettings& pcg);
  PcgStats solve_with(const ConstraintFilter& filter, VectorX& dv, const PcgSettings& pcg, Preconditioner preconditioner);
  bool uses_multigrid(Preconditioner preconditioner) const;
  const SmoothedAggregation* multigrid() const { return multigrid_.get(); }

 private:
  // Builds the hierarchy's structure (first call) and, when due (multigrid_refresh_due), its
  // values for the permuted filter; false when multigrid cannot be used (block Jacobi then).
  // Times into the multigrid_*_seconds_.
  bool prepare_multigrid(int threads);
  bool multigrid_refresh_due() const;

  const ClothMesh& mesh_;
  const ForceModel& model_;
  LinearSystemOptions options_;
  ForceElementLayout layout_;
  ForceElementStorage<Scalar> storage_;
  std::vector<int> order_, new_of_old_;
  int bandwidth_natural_ = 0;
  BcrsMatrix<Scalar> matrix_;
  std::vector<int> diagonal_index_;                // block index of each row's diagonal
  std::vector<int> block_source_start_;            // per fixed block: range into block_source_
  std::vector<std::uint32_t> block_source_;        // (element slot << 1) | transposed
  std::vector<int> rhs_source_start_;              // per row: range into rhs_source_
  std::vector<std::uint32_t> rhs_source_;          // element * 4 + local vertex
  std::vector<double> row_mass_;
  TransientElements transient_;
  TransientRows transient_rows_;
  VectorX rhs_;
  std::vector<Mat3> diagonal_;
  ConstraintFilter permuted_filter_;
  VectorX permuted_dv_;
  ConstraintFilter response_filter_;  // permuted_filter_ with nothing prescribed (solve_response)
  VectorX response_rhs_, response_y_;
  std::unique_ptr<SmoothedAggregation> multigrid_;
  double multigrid_structure_seconds_ = 0.0, multigrid_setup_seconds_ = 0.0, multigrid_last_setup_seconds_ = 0.0;
  long long solves_ = 0;
  // Reuse of the hierarchy's values from solve to solve (multigrid_refresh_due).
  bool multigrid_stale_ = true;       // a new frame, a new step size or a failed solve
  bool multigrid_refreshed_ = false;  // the last prepare_multigrid recomputed the values
  bool multigrid_all_fresh_ = false;  // ... and the smoothers' bounds too
  int multigrid_age_ = 0;             // solves since the values were computed
  int multigrid_fresh_iterations_ = 0, multigrid_last_iterations_ = 0;
  long long multigrid_refreshes_ = 0;
  int refreshed_constrained_ = 0;              // the filter of the last refresh: constrained vertices
  std::vector<Mat3> refreshed_projection_;     // and, when there were any, their projections
  double last_h_ = 0.0;
  double first_h_ = 0.0;  // step of the first build: the nominal step (stiff_wing_pairs)
  bool last_multigrid_ = false;
  bool multigrid_unusable_ = false;  // the pattern gave no hierarchy: block Jacobi
  // kAuto below kMultigridAutoVertices: a block-Jacobi solve that needed more than
  // kAutoBlockJacobiIterations went on with multigrid, and so do the frame's later solves.
  bool auto_switched_ = false;
};

}  // namespace weft
