// The pre-filtered PCG is a template over the matrix-vector product (see pcg.h) so that the
// reference (Eigen, double) and fast (BCRS, float32) systems share one solver.
#include "weft/linear_system/pcg.h"
