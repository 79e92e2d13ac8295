// Measurements for `weft bench solver`: a STREAM-triad bandwidth taken in the same process,
// the fast path's SpMV timed on its last built matrix, and the same solve done with Eigen's
// ConjugateGradient in double (the library a user would otherwise pick).
#pragma once

#include "weft/linear_system/linear_system_path.h"

namespace weft {

// Best-of-repeats a[i] = b[i] + s c[i] over doubles, counted as 24 bytes per element (STREAM's
// convention); bytes per second.
double stream_triad_bandwidth(long long elements, int repeats, int threads);

struct SpmvTiming {
  double seconds = 0.0;  // median of repeats, one multiply
  double bytes = 0.0;    // LinearSystemInfo::bytes_per_multiply
};
SpmvTiming time_spmv(LinearSystemPath& path, int repeats, int threads);

struct SolveComparison {
  double fast_seconds = 0.0, fast_residual = 0.0;
  int fast_iterations = 0;
  double eigen_seconds = 0.0, eigen_residual = 0.0;  // CG only (forming S A S + I - S excluded)
  int eigen_iterations = 0;
};
// Solves the fast path's last built system from zero with its PCG to `tolerance`, then the same
// system (values as stored, in double, original vertex order) with Eigen's CG to the residual
// the fast solve reached.
SolveComparison compare_with_eigen_cg(LinearSystemPath& path, const ConstraintFilter& filter, double tolerance,
                                      int max_iterations, int threads);

}  // namespace weft
