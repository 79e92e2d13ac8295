// Reference assembly of the linearized backward-Euler system
//   A = M + h D + h^2 K,   b = h (f - h K v)
// where K = -dF/dx and D = -dF/dv (both symmetric positive semi-definite after projection).
// Per-element blocks are added into a fixed Eigen sparse pattern (double precision). This is
// the straightforward path; the fast fixed-pattern float32 BCRS path is separate.
#pragma once

#include <Eigen/SparseCore>

#include "forces.h"

namespace weft {

using SparseMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor, int>;

class ReferenceAssembler {
 public:
  explicit ReferenceAssembler(const ClothMesh& mesh);

  // Fills matrix, rhs and the 3x3 diagonal blocks (for block-Jacobi preconditioning).
  void assemble(const ElementBuffers& elements, const std::vector<double>& vertex_mass, const Positions& v,
                double h);

  const SparseMatrix& matrix() const { return matrix_; }
  const VectorX& rhs() const { return rhs_; }
  const std::vector<Mat3>& diagonal_blocks() const { return diagonal_blocks_; }

 private:
  const ClothMesh& mesh_;
  SparseMatrix matrix_;
  VectorX rhs_;
  std::vector<Mat3> diagonal_blocks_;
};

// For verification: the global force and Jacobians dF/dx and dF/dv from element buffers.
struct GlobalJacobians {
  VectorX force;
  SparseMatrix force_dx;
  SparseMatrix force_dv;
};
GlobalJacobians assemble_jacobians(const ClothMesh& mesh, const ElementBuffers& elements);

}  // namespace weft
