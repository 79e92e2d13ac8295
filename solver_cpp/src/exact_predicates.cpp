#include "exact_predicates.h"

#include <cmath>
#include <vector>

namespace weft {

namespace {

using Expansion = std::vector<double>;  // non-overlapping, increasing magnitude, zero-free

inline void two_sum(double a, double b, double& x, double& y) {
  x = a + b;
  const double bv = x - a, av = x - bv;
  y = (a - av) + (b - bv);
}

inline void two_product(double a, double b, double& x, double& y) {
  x = a * b;
  y = std::fma(a, b, -x);  // exact low part
}

Expansion from_difference(double a, double b) {
  double x, y;
  two_sum(a, -b, x, y);
  Expansion e;
  if (y != 0.0) e.push_back(y);
  if (x != 0.0) e.push_back(x);
  return e;
}

// e + b (Shewchuk's grow-expansion with zero elimination).
Expansion grow(const Expansion& e, double b) {
  Expansion h;
  double q = b;
  for (double ei : e) {
    double sum, err;
    two_sum(q, ei, sum, err);
    q = sum;
    if (err != 0.0) h.push_back(err);
  }
  if (q != 0.0) h.push_back(q);
  return h;
}

Expansion sum(const Expansion& e, const Expansion& f) {
  Expansion h = e;
  for (double fi : f) h = grow(h, fi);
  return h;
}

// e * b (Shewchuk's scale-expansion with zero elimination).
Expansion scale(const Expansion& e, double b) {
  Expansion h;
  if (e.empty() || b == 0.0) return h;
  double q, hh;
  two_product(e[0], b, q, hh);
  if (hh != 0.0) h.push_back(hh);
  for (size_t i = 1; i < e.size(); ++i) {
    double p1, p0, s, t;
    two_product(e[i], b, p1, p0);
    two_sum(q, p0, s, hh);
    if (hh != 0.0) h.push_back(hh);
    two_sum(p1, s, q, t);  // |p1| >= |s| not guaranteed after zero elimination: use two_sum
    if (t != 0.0) h.push_back(t);
  }
  if (q != 0.0) h.push_back(q);
  return h;
}

Expansion product(const Expansion& e, const Expansion& f) {
  Expansion h;
  for (double fi : f) h = sum(h, scale(e, fi));
  return h;
}

Expansion negate(Expansion e) {
  for (double& x : e) x = -x;
  return e;
}

int sign_of(const Expansion& e) {
  // The largest component (last) carries the sign of a non-overlapping expansion.
  if (e.empty()) return 0;
  return e.back() > 0.0 ? 1 : (e.back() < 0.0 ? -1 : 0);
}

int orient3d_exact(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  Expansion ad[3], bd[3], cd[3];
  for (int k = 0; k < 3; ++k) {
    ad[k] = from_difference(a[k], d[k]);
    bd[k] = from_difference(b[k], d[k]);
    cd[k] = from_difference(c[k], d[k]);
  }
  // det = ad . (bd x cd)
  const Expansion m0 = sum(product(bd[1], cd[2]), negate(product(bd[2], cd[1])));
  const Expansion m1 = sum(product(bd[2], cd[0]), negate(product(bd[0], cd[2])));
  const Expansion m2 = sum(product(bd[0], cd[1]), negate(product(bd[1], cd[0])));
  const Expansion det = sum(sum(product(ad[0], m0), product(ad[1], m1)), product(ad[2], m2));
  return sign_of(det);
}

}  // namespace

int orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  const Vec3 ad = a - d, bd = b - d, cd = c - d;
  const double m0 = bd[1] * cd[2] - bd[2] * cd[1];
  const double m1 = bd[2] * cd[0] - bd[0] * cd[2];
  const double m2 = bd[0] * cd[1] - bd[1] * cd[0];
  const double det = ad[0] * m0 + ad[1] * m1 + ad[2] * m2;
  const double permanent = std::abs(ad[0]) * (std::abs(bd[1] * cd[2]) + std::abs(bd[2] * cd[1])) +
                           std::abs(ad[1]) * (std::abs(bd[2] * cd[0]) + std::abs(bd[0] * cd[2])) +
                           std::abs(ad[2]) * (std::abs(bd[0] * cd[1]) + std::abs(bd[1] * cd[0]));
  // Shewchuk's o3derrboundA is (7 + 56u) u with u = 2^-53; 1e-15 exceeds it. Below 1e-280 the
  // bound could be spoilt by underflow, so those go to the exact path as well.
  const double bound = 1e-15 * permanent;
  if (std::isfinite(det) && permanent > 1e-280 && std::abs(det) > bound) return det > 0.0 ? 1 : -1;
  return orient3d_exact(a, b, c, d);
}

int orient2d(double ax, double ay, double bx, double by, double cx, double cy) {
  const Expansion acx = from_difference(ax, cx), acy = from_difference(ay, cy);
  const Expansion bcx = from_difference(bx, cx), bcy = from_difference(by, cy);
  return sign_of(sum(product(acx, bcy), negate(product(acy, bcx))));
}

}  // namespace weft
