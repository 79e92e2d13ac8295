// Exact geometric predicates, shared by the intersection analysis (GIA) and collisions.
//
// orient3d(a, b, c, d) is the determinant of the 4x4 matrix with rows [p, 1], which equals
// det[a - d; b - d; c - d]: positive when d lies below the plane of a, b, c seen with a, b, c
// counter-clockwise from above (the usual right-handed convention). The sign is exact: a
// floating-point filter with a static error bound decides almost every call, and the rest are
// evaluated exactly with floating-point expansions (error-free sums and products).
//
// Degenerate (exactly zero) determinants are resolved by Simulation of Simplicity
// (Edelsbrunner & Muecke 1990): every point carries an integer key and is perturbed by
// infinitesimals eps^(2^(3k+c)) (k its key rank, c the coordinate), so the perturbed
// determinant is a polynomial in eps whose first non-zero coefficient (a minor of the
// unperturbed matrix, evaluated exactly) gives the sign. With distinct keys the result is never
// zero and is consistent across all predicates that share points: it is the exact answer for one
// fixed, infinitesimally perturbed configuration.
#pragma once

#include <cstdint>

#include "weft/common/types.h"

namespace weft {

// A point (three doubles, not owned) and its global key for the symbolic perturbation.
struct KeyedPoint {
  const double* p;
  std::int64_t key;
};

// Approximate value of orient3d (floating point, no guarantee on the sign).
double orient3d_approx(const double* a, const double* b, const double* c, const double* d);

// Exact sign of orient3d: +1, -1 or 0.
int orient3d_exact_sign(const double* a, const double* b, const double* c, const double* d);

// Sign of orient3d under the symbolic perturbation: +1 or -1. Keys must be pairwise distinct.
int orient3d_sos(const KeyedPoint& a, const KeyedPoint& b, const KeyedPoint& c, const KeyedPoint& d);

// Whether the segment pq crosses the triangle abc in the perturbed configuration: p and q are
// strictly on opposite sides of the plane of abc and the line pq passes strictly inside the
// three edge-orientation tests. Keys must be pairwise distinct.
bool segment_crosses_triangle(const KeyedPoint& p, const KeyedPoint& q, const KeyedPoint& a, const KeyedPoint& b,
                              const KeyedPoint& c);

// Exact sign of det[a - d; b - d; c - d] (same convention as orient3d_exact_sign); 0 when the
// four points are coplanar. No perturbation: callers handle the degenerate case.
int orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

// Exact sign of det[a - c; b - c] for 2D points: positive when a, b, c turn counter-clockwise.
int orient2d(double ax, double ay, double bx, double by, double cx, double cy);

}  // namespace weft
