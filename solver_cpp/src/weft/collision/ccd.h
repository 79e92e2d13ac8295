// Conservative continuous collision detection (CCD) for linearly moving points, in the style
// of Tight Inclusion (Wang, Ferguson, Schneider & Panozzo 2021).
//
// Vertex-triangle: F(t, u, v) = p(t) - a(t) - u (b(t) - a(t)) - v (c(t) - a(t)),
// edge-edge:       F(t, u, v) = a0(t) + u (a1(t) - a0(t)) - b0(t) - v (b1(t) - b0(t)),
// with every point moving linearly, x(t) = x0 + t (x1 - x0), t in [0, 1]. The two primitives
// touch at time t iff F(t, u, v) = 0 for some (u, v) in the triangle (u, v >= 0, u + v <= 1) or
// the unit square. F is affine in each of t, u and v separately (multi-affine), so over a box
// of (t, u, v) every coordinate of F lies between the smallest and the largest value at the
// box's 8 corners. A box whose corner values, widened by a rigorous floating-point error bound
// and the minimum separation, exclude zero in some coordinate cannot contain a root and is
// dropped; the others are bisected, earliest time first. A box is reported as a hit when its
// values span less than the tolerance, or when the work budget is spent: the answer errs only
// towards "hit" (no false negatives), and the reported time is a lower bound of the true time
// of impact.
#pragma once

#include "weft/common/types.h"

namespace weft {

struct CcdOptions {
  // Minimum separation: also report pairs that come within this distance (infinity norm of
  // the gap vector, which is at most the Euclidean distance), metres.
  double minimum_separation = 0.0;
  // A box whose co-domain is narrower than this in every coordinate is accepted as a hit.
  // Relative to the query's extent (largest side of the box around the 8 input points, at
  // least 1e-300), so it does not grow with the distance from the origin; the absolute
  // tolerance is never below four times the floating-point error bound.
  double relative_tolerance = 1e-6;
  // Absolute floor of the same tolerance, metres (e.g. a fraction of the minimum separation).
  double absolute_tolerance = 0.0;
  // A box no longer than this in time that has a corner certainly within the minimum separation
  // (every coordinate of F there, plus its rounding bound, at most the separation; for
  // vertex-triangle a corner inside the triangle) is reported as a hit at once: a true contact,
  // with the box's start as the time of impact, which stays a lower bound because boxes are
  // examined earliest start first. 0: only the tolerance decides (the tightest time of impact).
  // The time of impact is then known to this fraction of the step instead of to the tolerance,
  // and a contact costs tens of boxes instead of hundreds.
  double hit_time_resolution = 0.0;
  // Boxes examined before giving up and (conservatively) reporting a hit.
  int max_boxes = 20000;
  // Only look for contacts with t in [0, t_max].
  double t_max = 1.0;
};

struct CcdResult {
  bool hit = false;
  double toi = 1.0;       // lower bound of the earliest contact time when hit
  int boxes = 0;          // boxes examined
  bool budget_exhausted = false;
};

// start/end: positions of (p, a, b, c) at t = 0 and t = 1.
CcdResult vertex_triangle_ccd(const std::array<Vec3, 4>& start, const std::array<Vec3, 4>& end,
                              const CcdOptions& options = {});
// start/end: positions of (a0, a1, b0, b1) at t = 0 and t = 1.
CcdResult edge_edge_ccd(const std::array<Vec3, 4>& start, const std::array<Vec3, 4>& end,
                        const CcdOptions& options = {});

// A cheap sound filter run before the queries above (a deforming non-penetration filter in the
// style of Tang, Manocha, Otaduy & Tong 2010): true when the pair provably stays more than `gap`
// apart (Euclidean) over the whole step. The distance of the point to the triangle's plane
// (vertex-triangle) or between the edges' lines (edge-edge), each a lower bound of the features'
// distance, is |f(t)| / |n(t)| with n the quadratic normal (cross product of two linearly moving
// edge vectors) and f = n . d a cubic; when all four Bernstein coefficients of f exceed gap times
// the largest Bernstein coefficient norm of n (a bound of |n(t)| on [0, 1]), or all are below its
// negative, that distance stays above gap. The threshold carries a slack for rounding (relative
// to the query's extent plus ccd_error_bound), so it errs only towards "not apart". Input order
// as in vertex_triangle_ccd / edge_edge_ccd.
bool stays_apart(const std::array<Vec3, 4>& start, const std::array<Vec3, 4>& end, bool edge_edge, double gap);

// The per-coordinate bound on the floating-point error of one evaluation of F (both queries):
// 128 u max|x_k| over the 8 points (u = 2^-53) plus an underflow allowance; see ccd.cpp.
Vec3 ccd_error_bound(const std::array<Vec3, 4>& start, const std::array<Vec3, 4>& end);

}  // namespace weft
