// The implicit step's linear system, selectable at run time:
//   fast       fixed force elements, fixed-pattern RCM-ordered BCRS (float32 or float64 values)
//              gathered lock-free, transient elements, parallel pre-filtered PCG (block Jacobi);
//   reference  per-element assembly into an Eigen sparse matrix (double, row locks), Eigen's
//              ConjugateGradient on the explicitly pre-filtered system.
// Both solve (M + h D + h^2 K) dv = h (f - h K v) with the pins of a ConstraintFilter exact.
// This header is the interface only; make_linear_system.h picks an implementation.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "weft/forces/forces.h"
#include "weft/linear_system/pcg.h"
#include "weft/linear_system/transient.h"

namespace weft {

enum class LinearSystemKind { kFast, kReference };
enum class MatrixPrecision { kFloat32, kFloat64 };
// CG preconditioner of the fast path (the reference path always uses Eigen's Jacobi):
// kAuto picks smoothed-aggregation multigrid from kMultigridAutoVertices vertices on.
enum class Preconditioner { kAuto, kBlockJacobi, kMultigrid };
constexpr int kMultigridAutoVertices = 1000;  // measured: docs/multigrid.md
// Below that size kAuto starts each frame with block Jacobi and goes on with multigrid, for
// the rest of the frame, from a solve that needs more iterations than this (a stiff or
// constrained small piece: a sleeve pinned round a swinging limb took 150 per substep where
// multigrid takes 11). Measured: docs/multigrid.md, "auto".
constexpr int kAutoBlockJacobiIterations = 60;

struct LinearSystemOptions {
  LinearSystemKind kind = LinearSystemKind::kFast;
  MatrixPrecision precision = MatrixPrecision::kFloat32;
  int threads = 1;
  PcgSettings pcg;
  Preconditioner preconditioner = Preconditioner::kAuto;
};

// What the path built; for reports and benchmarks.
struct LinearSystemInfo {
  std::string path;                     // "fast" or "reference"
  std::string precision;                // "float32" or "float64"
  long long force_elements = 0;         // elements the path computes
  long long per_force_elements = 0;     // one element per force, for comparison
  int bandwidth_natural = 0;            // block bandwidth in the input vertex order
  int bandwidth = 0;                    // block bandwidth as solved (after RCM for fast)
  bool narrow_columns = false;          // 16-bit column offsets in use (fast)
  long long blocks = 0;                 // 3x3 blocks of the fixed pattern
  long long transient_blocks = 0;       // outside the fixed pattern, last step
  double bytes_per_multiply = 0.0;      // SpMV memory traffic (fast)
  std::string preconditioner = "block_jacobi";  // in use: "block_jacobi" or "multigrid"
  std::vector<int> multigrid_rows;      // 3x3 rows per level, finest first (multigrid)
  double multigrid_operator_complexity = 0.0;  // blocks of all levels / blocks of the finest
  double multigrid_structure_seconds = 0.0;    // aggregation and patterns, once
  double multigrid_setup_seconds = 0.0;        // values of the hierarchy, summed over solves
  long long multigrid_refreshes = 0;           // solves that recomputed them (the rest reused them)
  long long solves = 0;                        // solves so far
};

class LinearSystemPath {
 public:
  virtual ~LinearSystemPath() = default;
  // Forces, Jacobians and the system for state (x, v) at `time`, step h.
  virtual void build(const Positions& x, const Positions& v, double time, double h) = 0;
  // dv: warm start on entry, solution on exit.
  virtual PcgStats solve(const ConstraintFilter& filter, VectorX& dv) = 0;
  // y = A^-1 rhs for the last solved system's matrix, in the free directions of the last
  // solve's filter (its constrained directions of y stay zero; `rhs` and y in the original
  // order), from y = 0, at most pcg.max_iterations CG iterations with the preconditioner the
  // last solve used as it stands (no refresh). What an impulse applied to a few vertices does
  // to the whole cloth in one implicit step: friction spread through it (contact_constraints.h).
  virtual PcgStats solve_response(const VectorX& rhs, VectorX& y, const PcgSettings& pcg) = 0;
  // r = b - A dv for the last built system (original vertex order, unfiltered): at a vertex
  // whose direction n a constraint prescribed, -n . r_i is the impulse the constraint had to add
  // (positive when it pushed along n).
  virtual void residual(const VectorX& dv, VectorX& r) const = 0;
  // A new frame begins: whatever the path carries from solve to solve (the multigrid
  // hierarchy's values) is recomputed at the next solve, so a frame's result never depends on
  // the frames before the one a run was resumed from.
  virtual void start_frame() {}
  // Transient elements of the coming build() (cleared by the caller); null when unsupported.
  virtual TransientElements* transient() { return nullptr; }
  // Threads of the coming builds and solves (at least 1). Every result is the same for any
  // count, so a run may change it between frames.
  virtual void set_threads(int threads) = 0;
  virtual LinearSystemInfo info() const = 0;
};

}  // namespace weft
