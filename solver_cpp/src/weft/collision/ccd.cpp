#include "weft/collision/ccd.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <queue>
#include <vector>

namespace weft {

// Floating-point error of one evaluation of F at a corner (t, u, v), t, u, v in [0, 1].
// Let M be the largest |coordinate k| among the 8 input points and u = 2^-53 the unit round-off.
// Displacements d = fl(x1 - x0) are computed once (|d| <= 2M, error <= 2uM). Interpolation
// x(t) = fl(x0 + fl(t d)) has error <= 2uM + 2uM + 1.01uM < 6uM and |x(t)| <= 1.01M. A
// difference of two interpolated points errs by < 12uM + 2.02uM = 14.1uM; scaling it by
// u or v in [0, 1] adds < 2.1uM. Vertex-triangle F = ((p - a) - u(b - a)) - v(c - a): three such
// differences (< 14.1, 16.2, 16.2 uM) and two subtractions of terms below 6.1M (< 12.2uM):
// < 59uM. Edge-edge F = (a0 + u(a1 - a0)) - (b0 + v(b1 - b0)): two interpolated points (6uM
// each), two scaled differences (16.2uM each) and three additions of terms below 6.1M
// (< 18.3uM): < 63uM. We use 128uM, twice the derived bound, plus 32 * 2^-1074 per coordinate
// for results that underflow (gradual underflow errs by at most half a subnormal ulp per
// operation).
Vec3 ccd_error_bound(const std::array<Vec3, 4>& start, const std::array<Vec3, 4>& end) {
  Vec3 m = Vec3::Zero();
  for (int i = 0; i < 4; ++i) m = m.cwiseMax(start[i].cwiseAbs()).cwiseMax(end[i].cwiseAbs());
  constexpr double kUnitRoundoff = std::numeric_limits<double>::epsilon() * 0.5;
  constexpr double kUnderflow = 32.0 * std::numeric_limits<double>::denorm_min();
  return (128.0 * kUnitRoundoff) * m + Vec3::Constant(kUnderflow);
}

bool stays_apart(const std::array<Vec3, 4>& start, const std::array<Vec3, 4>& end, bool edge_edge, double gap) {
  // Two linearly moving edge vectors whose cross product is n(t), and d(t), from a point of the
  // first feature's plane or line to the other feature.
  //   vertex-triangle (p, a, b, c): n = (b - a) x (c - a), d = p - a;
  //   edge-edge (a0, a1, b0, b1):   n = (a1 - a0) x (b1 - b0), d = b0 - a0.
  Vec3 e0, e1, g0, g1, d0, d1;
  if (edge_edge) {
    e0 = start[1] - start[0], e1 = end[1] - end[0];
    g0 = start[3] - start[2], g1 = end[3] - end[2];
    d0 = start[2] - start[0], d1 = end[2] - end[0];
  } else {
    e0 = start[2] - start[1], e1 = end[2] - end[1];
    g0 = start[3] - start[1], g1 = end[3] - end[1];
    d0 = start[0] - start[1], d1 = end[0] - end[1];
  }
  if (!(e0.allFinite() && e1.allFinite() && g0.allFinite() && g1.allFinite() && d0.allFinite() && d1.allFinite()))
    return false;
  // Bernstein coefficients of the quadratic n and of the cubic f = n . d on t in [0, 1].
  const Vec3 n0 = e0.cross(g0), n1 = 0.5 * (e0.cross(g1) + e1.cross(g0)), n2 = e1.cross(g1);
  const double c0 = n0.dot(d0), c1 = (2.0 * n1.dot(d0) + n0.dot(d1)) / 3.0,
               c2 = (n2.dot(d0) + 2.0 * n1.dot(d1)) / 3.0, c3 = n2.dot(d1);
  const double n_max = std::sqrt(std::max({n0.squaredNorm(), n1.squaredNorm(), n2.squaredNorm()}));
  Vec3 lo = start[0], hi = start[0];
  for (int i = 0; i < 4; ++i) {
    lo = lo.cwiseMin(start[i]).cwiseMin(end[i]);
    hi = hi.cwiseMax(start[i]).cwiseMax(end[i]);
  }
  const double extent = (hi - lo).maxCoeff();
  // Rounding of the differences and products is far below 1e-7 of the extent (plus the error
  // bound of the coordinates' own magnitude), so the slack keeps the filter sound.
  const double threshold = (gap + 1e-7 * extent + 4.0 * ccd_error_bound(start, end).maxCoeff()) * n_max;
  if (!(threshold > 0.0) || !std::isfinite(threshold)) return false;
  const double c_lo = std::min({c0, c1, c2, c3}), c_hi = std::max({c0, c1, c2, c3});
  return c_lo > threshold || c_hi < -threshold;
}

namespace {

struct Box {
  double t0, t1, u0, u1, v0, v1;
  int depth;
};
// Earliest start first; among boxes with the same start, the deepest first (depth-first along
// a contact curve instead of breadth-first across it).
struct LaterFirst {
  bool operator()(const Box& a, const Box& b) const {
    if (a.t0 != b.t0) return a.t0 > b.t0;
    return a.depth < b.depth;
  }
};

// F at the 8 corners of a box, corner c = (t bit 4, u bit 2, v bit 1). The points are
// interpolated once per time and the differences formed once per (t, u), with the operations
// and their order of the single-corner formula the error bound in ccd_error_bound assumes:
//   vertex-triangle ((x0 - x1) - u (x2 - x1)) - v (x3 - x1),
//   edge-edge       (x0 + u (x1 - x0)) - (x2 + v (x3 - x2)).
template <bool kEdgeEdge>
inline void corner_values(const std::array<Vec3, 4>& s, const std::array<Vec3, 4>& d, const double (&t)[2],
                          const double (&u)[2], const double (&v)[2], std::array<Vec3, 8>& f) {
  for (int i = 0; i < 2; ++i) {
    const Vec3 x0 = s[0] + t[i] * d[0], x1 = s[1] + t[i] * d[1], x2 = s[2] + t[i] * d[2], x3 = s[3] + t[i] * d[3];
    if constexpr (kEdgeEdge) {
      const Vec3 e0 = x1 - x0, e1 = x3 - x2;
      const Vec3 q[2] = {x2 + v[0] * e1, x2 + v[1] * e1};
      for (int j = 0; j < 2; ++j) {
        const Vec3 p = x0 + u[j] * e0;
        f[4 * i + 2 * j] = p - q[0];
        f[4 * i + 2 * j + 1] = p - q[1];
      }
    } else {
      const Vec3 a = x0 - x1, b = x2 - x1, c = x3 - x1;
      const Vec3 vc[2] = {v[0] * c, v[1] * c};
      for (int j = 0; j < 2; ++j) {
        const Vec3 p = a - u[j] * b;
        f[4 * i + 2 * j] = p - vc[0];
        f[4 * i + 2 * j + 1] = p - vc[1];
      }
    }
  }
}

// Whether some corner of the box is a true contact: F there within `bound` in every coordinate
// (for vertex-triangle only corners inside the triangle, u + v <= 1; the box bounds are dyadic
// fractions of at most 40 bits, so the sum is exact).
template <bool kEdgeEdge>
inline bool certain_contact_corner(const std::array<Vec3, 8>& f, const Box& box, const Vec3& bound) {
  if (!(bound.minCoeff() > 0.0)) return false;
  for (int c = 0; c < 8; ++c) {
    if (!kEdgeEdge && ((c & 2) ? box.u1 : box.u0) + ((c & 1) ? box.v1 : box.v0) > 1.0) continue;
    if ((f[c].cwiseAbs() - bound).maxCoeff() <= 0.0) return true;
  }
  return false;
}

constexpr double kMinimumWidth = 0x1p-40;  // boxes are not split below this in any parameter

template <bool kEdgeEdge>
CcdResult run_ccd(const std::array<Vec3, 4>& start, const std::array<Vec3, 4>& end, const CcdOptions& options) {
  CcdResult result;
  for (int i = 0; i < 4; ++i) {
    if (!start[i].allFinite() || !end[i].allFinite()) {
      result.hit = true;  // nothing can be said: conservatively a hit at the start
      result.toi = 0.0;
      return result;
    }
  }
  std::array<Vec3, 4> d;
  for (int i = 0; i < 4; ++i) {
    d[i] = end[i] - start[i];
    if (!d[i].allFinite()) {  // finite ends whose difference overflows: as for non-finite input
      result.hit = true;
      result.toi = 0.0;
      return result;
    }
  }
  const Vec3 err = ccd_error_bound(start, end);
  // The tolerance is relative to the query's own extent (the box around its 8 points), not to
  // its distance from the origin: far from the origin only the rounding bound grows.
  Vec3 lo = start[0], hi = start[0];
  for (int i = 0; i < 4; ++i) {
    lo = lo.cwiseMin(start[i]).cwiseMin(end[i]);
    hi = hi.cwiseMax(start[i]).cwiseMax(end[i]);
  }
  const double extent = std::max((hi - lo).maxCoeff(), 1e-300);
  const double tolerance =
      std::max({options.relative_tolerance * extent, options.absolute_tolerance, 4.0 * err.maxCoeff()});
  const Vec3 widen = err + Vec3::Constant(std::max(options.minimum_separation, 0.0));
  const double t_max = std::clamp(options.t_max, 0.0, 1.0);
  // |F_k| at or below this (per coordinate) is certainly within the minimum separation.
  const Vec3 contact_bound = Vec3::Constant(std::max(options.minimum_separation, 0.0)) - err;

  std::priority_queue<Box, std::vector<Box>, LaterFirst> queue;
  queue.push({0.0, t_max, 0.0, 1.0, 0.0, 1.0, 0});
  std::array<Vec3, 8> f;
  while (!queue.empty()) {
    const Box box = queue.top();
    queue.pop();
    if (!kEdgeEdge && box.u0 + box.v0 > 1.0) continue;  // entirely outside the triangle
    ++result.boxes;
    const double ts[2] = {box.t0, box.t1}, us[2] = {box.u0, box.u1}, vs[2] = {box.v0, box.v1};
    corner_values<kEdgeEdge>(start, d, ts, us, vs, f);
    Vec3 lo = f[0], hi = f[0];
    for (int c = 1; c < 8; ++c) {
      lo = lo.cwiseMin(f[c]);
      hi = hi.cwiseMax(f[c]);
    }
    if ((lo - widen).maxCoeff() > 0.0 || (hi + widen).minCoeff() < 0.0) continue;  // zero excluded
    const double t_width = box.t1 - box.t0, u_width = box.u1 - box.u0, v_width = box.v1 - box.v0;
    if (t_width <= options.hit_time_resolution && certain_contact_corner<kEdgeEdge>(f, box, contact_bound)) {
      result.hit = true;
      result.toi = box.t0;
      return result;
    }
    const bool tiny = t_width <= kMinimumWidth && u_width <= kMinimumWidth && v_width <= kMinimumWidth;
    if ((hi - lo).maxCoeff() <= tolerance || tiny || result.boxes >= options.max_boxes) {
      result.hit = true;
      result.toi = box.t0;  // every box still queued starts at or after this time
      result.budget_exhausted = !tiny && (hi - lo).maxCoeff() > tolerance;
      return result;
    }
    // Split the parameter along which F changes most (from the corner differences).
    double spread[3] = {0.0, 0.0, 0.0};
    for (int c = 0; c < 8; ++c) {
      if (!(c & 4)) spread[0] = std::max(spread[0], (f[c | 4] - f[c]).cwiseAbs().maxCoeff());
      if (!(c & 2)) spread[1] = std::max(spread[1], (f[c | 2] - f[c]).cwiseAbs().maxCoeff());
      if (!(c & 1)) spread[2] = std::max(spread[2], (f[c | 1] - f[c]).cwiseAbs().maxCoeff());
    }
    if (t_width <= kMinimumWidth) spread[0] = -1.0;
    if (u_width <= kMinimumWidth) spread[1] = -1.0;
    if (v_width <= kMinimumWidth) spread[2] = -1.0;
    const int axis = static_cast<int>(std::max_element(spread, spread + 3) - spread);
    Box a = box, b = box;
    a.depth = b.depth = box.depth + 1;
    if (axis == 0) {
      const double m = 0.5 * (box.t0 + box.t1);
      a.t1 = m;
      b.t0 = m;
    } else if (axis == 1) {
      const double m = 0.5 * (box.u0 + box.u1);
      a.u1 = m;
      b.u0 = m;
    } else {
      const double m = 0.5 * (box.v0 + box.v1);
      a.v1 = m;
      b.v0 = m;
    }
    queue.push(a);
    queue.push(b);
  }
  return result;
}

}  // namespace

CcdResult vertex_triangle_ccd(const std::array<Vec3, 4>& start, const std::array<Vec3, 4>& end,
                              const CcdOptions& options) {
  return run_ccd<false>(start, end, options);
}

CcdResult edge_edge_ccd(const std::array<Vec3, 4>& start, const std::array<Vec3, 4>& end, const CcdOptions& options) {
  return run_ccd<true>(start, end, options);
}

}  // namespace weft
