#include "weft/geometry/exact_predicates.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <vector>

namespace weft {
namespace {

// Error-free transformation: s + e == a + b exactly (Knuth's two-sum).
inline void two_sum(double a, double b, double& s, double& e) {
  s = a + b;
  const double bv = s - a;
  const double av = s - bv;
  e = (a - av) + (b - bv);
}

// An exact sum kept as a non-overlapping expansion with components of increasing magnitude
// and no zeros (Shewchuk's grow-expansion with zero elimination). Capacity covers the largest
// sum formed here: 24 permutation terms of at most 4 components each.
class ExactSum {
 public:
  void add(double b) {
    double q = b;
    int m = 0;
    for (int i = 0; i < n_; ++i) {
      double s, h;
      two_sum(q, c_[i], s, h);
      if (h != 0.0) c_[m++] = h;
      q = s;
    }
    if (q != 0.0) c_[m++] = q;
    n_ = m;
  }
  // Adds x*y*z exactly: x*y = p + e by FMA, then each part times z likewise.
  void add_product(double x, double y, double z) {
    const double p = x * y, e = std::fma(x, y, -p);
    const double p1 = p * z, e1 = std::fma(p, z, -p1);
    const double p2 = e * z, e2 = std::fma(e, z, -p2);
    add(p1);
    add(e1);
    add(p2);
    add(e2);
  }
  // The largest component carries the sign of the whole sum.
  int sign() const { return n_ == 0 ? 0 : (c_[n_ - 1] > 0.0 ? 1 : -1); }

 private:
  std::array<double, 128> c_{};
  int n_ = 0;
};

struct Permutation {
  std::array<int, 4> col;  // row i takes column col[i]
  int sign;
};

const std::array<Permutation, 24>& permutations() {
  static const std::array<Permutation, 24> table = [] {
    std::array<Permutation, 24> t{};
    std::array<int, 4> p = {0, 1, 2, 3};
    int k = 0;
    do {
      int inversions = 0;
      for (int i = 0; i < 4; ++i)
        for (int j = i + 1; j < 4; ++j) inversions += p[i] > p[j];
      t[k++] = {p, inversions % 2 ? -1 : 1};
    } while (std::next_permutation(p.begin(), p.end()));
    return t;
  }();
  return table;
}

// Perturbation symbols: bit s = 3 * rank + c stands for eps^(2^s) added to coordinate c of the
// point of key rank `rank`. A set of symbols contributes to the determinant only if it uses
// distinct rows and distinct columns; sets are listed by increasing exponent sum (= mask), i.e.
// by decreasing size of their monomial.
const std::vector<std::uint16_t>& perturbation_masks() {
  static const std::vector<std::uint16_t> masks = [] {
    std::vector<std::uint16_t> out;
    for (int mask = 1; mask < (1 << 12); ++mask) {
      int rows = 0, cols = 0;
      bool ok = true;
      for (int s = 0; s < 12 && ok; ++s) {
        if (!(mask >> s & 1)) continue;
        const int r = s / 3, c = s % 3;
        ok = !(rows >> r & 1) && !(cols >> c & 1);
        rows |= 1 << r;
        cols |= 1 << c;
      }
      if (ok) out.push_back(static_cast<std::uint16_t>(mask));
    }
    return out;
  }();
  return masks;
}

// Exact sign of the coefficient of one perturbation monomial: the sum over permutations that
// send each perturbed row to its perturbed column of sign * product of the other entries
// (column 3 is the constant 1). fixed_col[i] = -1 for rows that are not perturbed.
int coefficient_sign(const double* const rows[4], const std::array<int, 4>& fixed_col) {
  // The terms: at most 24 signed products of at most three coordinates.
  std::array<std::array<double, 3>, 24> terms;
  int count = 0;
  double sum = 0.0, permanent = 0.0;
  for (const Permutation& perm : permutations()) {
    bool match = true;
    for (int i = 0; i < 4 && match; ++i) match = fixed_col[i] < 0 || perm.col[i] == fixed_col[i];
    if (!match) continue;
    std::array<double, 3> f = {1.0, 1.0, 1.0};
    int n = 0;
    for (int i = 0; i < 4; ++i)
      if (fixed_col[i] < 0 && perm.col[i] < 3) f[n++] = rows[i][perm.col[i]];
    f[0] *= perm.sign;
    terms[count++] = f;
    const double product = f[0] * f[1] * f[2];
    sum += product;
    permanent += std::fabs(product);
  }
  // Floating-point filter: each product is off by at most 2 eps relative and the sum of 24
  // terms by at most ~26 eps times the permanent; 1e-14 leaves a wide margin. A zero permanent
  // means every term is exactly zero (e.g. a coordinate column of zeros: axis-aligned planes).
  if (permanent == 0.0) return 0;
  if (permanent > 1e-280 && sum > 1.0e-14 * permanent) return 1;
  if (permanent > 1e-280 && -sum > 1.0e-14 * permanent) return -1;
  ExactSum exact;
  for (int k = 0; k < count; ++k) exact.add_product(terms[k][0], terms[k][1], terms[k][2]);
  return exact.sign();
}

}  // namespace

double orient3d_approx(const double* a, const double* b, const double* c, const double* d) {
  const double adx = a[0] - d[0], ady = a[1] - d[1], adz = a[2] - d[2];
  const double bdx = b[0] - d[0], bdy = b[1] - d[1], bdz = b[2] - d[2];
  const double cdx = c[0] - d[0], cdy = c[1] - d[1], cdz = c[2] - d[2];
  return adz * (bdx * cdy - bdy * cdx) + bdz * (cdx * ady - cdy * adx) + cdz * (adx * bdy - ady * bdx);
}

int orient3d_exact_sign(const double* a, const double* b, const double* c, const double* d) {
  const double adx = a[0] - d[0], ady = a[1] - d[1], adz = a[2] - d[2];
  const double bdx = b[0] - d[0], bdy = b[1] - d[1], bdz = b[2] - d[2];
  const double cdx = c[0] - d[0], cdy = c[1] - d[1], cdz = c[2] - d[2];
  const double bc = bdx * cdy - bdy * cdx, ca = cdx * ady - cdy * adx, ab = adx * bdy - ady * bdx;
  const double det = adz * bc + bdz * ca + cdz * ab;
  const double permanent = (std::fabs(bdx * cdy) + std::fabs(bdy * cdx)) * std::fabs(adz) +
                           (std::fabs(cdx * ady) + std::fabs(cdy * adx)) * std::fabs(bdz) +
                           (std::fabs(adx * bdy) + std::fabs(ady * bdx)) * std::fabs(cdz);
  // Shewchuk's bound for this evaluation order is (7 + 56 eps) eps with eps = 2^-53; 1e-15
  // is a little larger (more exact fallbacks, never a wrong sign).
  // Below 1e-280 the bound could be spoilt by underflow: such inputs take the exact path.
  const double bound = 1.0e-15 * permanent;
  if (permanent > 1e-280) {
    if (det > bound) return 1;
    if (-det > bound) return -1;
  }
  // Four points sharing one coordinate exactly (a flat sheet modelled in a coordinate plane)
  // lie in a plane: the determinant is exactly zero, no expansion needed.
  for (int k = 0; k < 3; ++k)
    if (a[k] == d[k] && b[k] == d[k] && c[k] == d[k]) return 0;
  // Nearby points (what a near-degenerate test usually has) give exact differences (Sterbenz):
  // then the six triple products of the differences decide exactly, a quarter of the 4x4
  // expansion's terms. Differences below 1e-80 could lose the products' low parts to
  // underflow: those take the expansion.
  const double* points[3] = {a, b, c};
  double diff[3][3];
  bool exact = true;
  for (int i = 0; i < 3 && exact; ++i)
    for (int k = 0; k < 3 && exact; ++k) {
      double e;
      two_sum(points[i][k], -d[k], diff[i][k], e);
      exact = e == 0.0 && (diff[i][k] == 0.0 || std::fabs(diff[i][k]) >= 1e-80);
    }
  if (exact) {
    const double* u = diff[0];
    const double* v = diff[1];
    const double* w = diff[2];
    ExactSum det_sum;  // the terms of det above: u . (v x w)
    det_sum.add_product(u[2], v[0], w[1]);
    det_sum.add_product(-u[2], v[1], w[0]);
    det_sum.add_product(v[2], w[0], u[1]);
    det_sum.add_product(-v[2], w[1], u[0]);
    det_sum.add_product(w[2], u[0], v[1]);
    det_sum.add_product(-w[2], u[1], v[0]);
    return det_sum.sign();
  }
  const double* rows[4] = {a, b, c, d};
  return coefficient_sign(rows, {-1, -1, -1, -1});
}

int orient3d_sos(const KeyedPoint& a, const KeyedPoint& b, const KeyedPoint& c, const KeyedPoint& d) {
  const int s = orient3d_exact_sign(a.p, b.p, c.p, d.p);
  if (s != 0) return s;
  const KeyedPoint* pts[4] = {&a, &b, &c, &d};
  const double* rows[4] = {a.p, b.p, c.p, d.p};
  // rank_row[r] = the row whose key has rank r.
  std::array<int, 4> rank_row = {0, 1, 2, 3};
  std::sort(rank_row.begin(), rank_row.end(), [&](int i, int j) { return pts[i]->key < pts[j]->key; });
  for (int r = 0; r < 3; ++r)
    if (pts[rank_row[r]]->key == pts[rank_row[r + 1]]->key)
      throw std::invalid_argument("orient3d_sos: points must have distinct keys");
  for (const std::uint16_t mask : perturbation_masks()) {
    std::array<int, 4> fixed_col = {-1, -1, -1, -1};
    for (int bit = 0; bit < 12; ++bit)
      if (mask >> bit & 1) fixed_col[rank_row[bit / 3]] = bit % 3;
    const int sign = coefficient_sign(rows, fixed_col);
    if (sign != 0) return sign;
  }
  return 1;  // unreachable: the last three-symbol monomials have coefficient +-1
}

bool segment_crosses_triangle(const KeyedPoint& p, const KeyedPoint& q, const KeyedPoint& a, const KeyedPoint& b,
                              const KeyedPoint& c) {
  if (orient3d_sos(a, b, c, p) == orient3d_sos(a, b, c, q)) return false;
  const int s = orient3d_sos(p, q, a, b);
  return orient3d_sos(p, q, b, c) == s && orient3d_sos(p, q, c, a) == s;
}

int orient3d(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return orient3d_exact_sign(a.data(), b.data(), c.data(), d.data());
}

int orient2d(double ax, double ay, double bx, double by, double cx, double cy) {
  // Floating-point filter (Shewchuk's orient2dfast with his bound (3 + 16 eps) eps, eps =
  // 2^-53; 1e-15 is larger): a determinant clearly away from zero has the sign it shows.
  const double left = (ax - cx) * (by - cy), right = (ay - cy) * (bx - cx);
  const double det = left - right, sum = std::fabs(left) + std::fabs(right);
  if (sum > 1e-280) {
    if (det > 1e-15 * sum) return 1;
    if (-det > 1e-15 * sum) return -1;
  }
  // det[a - c; b - c] = ax by - ax cy - cx by - ay bx + ay cx + cy bx (the cx cy terms cancel);
  // each product is split exactly by FMA inside ExactSum.
  ExactSum exact;
  exact.add_product(ax, by, 1.0);
  exact.add_product(-ax, cy, 1.0);
  exact.add_product(-cx, by, 1.0);
  exact.add_product(-ay, bx, 1.0);
  exact.add_product(ay, cx, 1.0);
  exact.add_product(cy, bx, 1.0);
  return exact.sign();
}

}  // namespace weft
