// Reference assembly of the linearized backward-Euler system
//   A = M + h D + h^2 K,   b = h (f - h K v)
// where K = -dF/dx and D = -dF/dv (both symmetric positive semi-definite after projection).
// Per-element blocks are added into a fixed Eigen sparse pattern (double precision), in parallel
// over elements with a lock per block row (so with several threads the summation order, and the
// last bits, vary run to run). This is the straightforward reference path, solved with Eigen's
// ConjugateGradient; the fast fixed-pattern BCRS path is fast_linear_system.h.
#pragma once

#include <Eigen/SparseCore>
#include <omp.h>

#include "weft/forces/forces.h"
#include "weft/linear_system/linear_system_path.h"

namespace weft {

using SparseMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor, int>;

class ReferenceAssembler {
 public:
  explicit ReferenceAssembler(const ClothMesh& mesh);
  ~ReferenceAssembler();
  ReferenceAssembler(const ReferenceAssembler&) = delete;
  ReferenceAssembler& operator=(const ReferenceAssembler&) = delete;

  // Fills matrix, rhs and the 3x3 diagonal blocks (for block-Jacobi preconditioning).
  void assemble(const ElementBuffers& elements, const std::vector<double>& vertex_mass, const Positions& v,
                double h, int threads = 1);

  const SparseMatrix& matrix() const { return matrix_; }
  const VectorX& rhs() const { return rhs_; }
  const std::vector<Mat3>& diagonal_blocks() const { return diagonal_blocks_; }

 private:
  const ClothMesh& mesh_;
  SparseMatrix matrix_;
  VectorX rhs_;
  std::vector<Mat3> diagonal_blocks_;
  std::vector<omp_lock_t> row_locks_;
};

// The pre-filtered system formed explicitly for a solver without filtering (Eigen's CG):
// S A S + I - S and S (b - A z). S is block diagonal, so only the rows and columns of
// constrained vertices change.
void form_prefiltered(const SparseMatrix& a, const VectorX& b, const ConstraintFilter& filter, SparseMatrix& a_out,
                      VectorX& b_out);

// Eigen's ConjugateGradient (Jacobi preconditioner, Lower|Upper so that Eigen's own OpenMP SpMV
// applies) on the pre-filtered system; dv: warm start in, solution out.
PcgStats eigen_cg_prefiltered(const SparseMatrix& a, const VectorX& b, const ConstraintFilter& filter, VectorX& dv,
                              const PcgSettings& settings, int threads, double* cg_seconds = nullptr);

class ReferenceLinearSystem final : public LinearSystemPath {
 public:
  ReferenceLinearSystem(const ClothMesh& mesh, const ForceModel& model, const LinearSystemOptions& options)
      : mesh_(mesh), model_(model), options_(options), assembler_(mesh) {}
  void build(const Positions& x, const Positions& v, double time, double h) override;
  PcgStats solve(const ConstraintFilter& filter, VectorX& dv) override;
  PcgStats solve_response(const VectorX& rhs, VectorX& y, const PcgSettings& pcg) override;
  void residual(const VectorX& dv, VectorX& r) const override { r = assembler_.rhs() - assembler_.matrix() * dv; }
  void set_threads(int threads) override { options_.threads = threads; }
  LinearSystemInfo info() const override;
  const ReferenceAssembler& assembler() const { return assembler_; }

 private:
  const ClothMesh& mesh_;
  const ForceModel& model_;
  LinearSystemOptions options_;
  ReferenceAssembler assembler_;
  ElementBuffers elements_;
  ConstraintFilter response_filter_;  // the last solve's, nothing prescribed (solve_response)
};

// For verification: the global force and Jacobians dF/dx and dF/dv from element buffers.
struct GlobalJacobians {
  VectorX force;
  SparseMatrix force_dx;
  SparseMatrix force_dv;
};
GlobalJacobians assemble_jacobians(const ClothMesh& mesh, const ElementBuffers& elements);

}  // namespace weft
