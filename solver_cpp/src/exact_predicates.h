// Exact orientation predicates: a floating-point filter with a rigorous error bound, and an
// exact fallback in floating-point expansion arithmetic (Shewchuk 1997: two-sum, two-product,
// expansion sums and scaling). The sign returned is the sign of the exact determinant of the
// double inputs.
#pragma once

#include "types.h"

namespace weft {

// Sign of det[a - d; b - d; c - d]: positive when d lies below the plane of a, b, c (a, b, c
// counter-clockwise seen from above), zero when the four points are coplanar.
int orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

// Sign of det[a - c; b - c] for 2D points (x, y): positive when a, b, c turn counter-clockwise.
int orient2d(double ax, double ay, double bx, double by, double cx, double cy);

}  // namespace weft
