#include "weft/collision/swept_planes.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace weft {

namespace {

using Triangle = std::array<Vec3, 3>;

Triangle corners(const Faces& faces, int f, const Positions& x) {
  return {row3(x, faces(f, 0)), row3(x, faces(f, 1)), row3(x, faces(f, 2))};
}

// Face a's largest corner displacement over the step: the stored one, or, in a shifted frame,
// measured there.
double motion_of(const SweptPlanes& p, int a, const Faces& fa, const Positions& as, const Positions& ae,
                 const Vec3* shift) {
  if (shift == nullptr) return p.motion[a];
  double m = 0.0;
  for (int k = 0; k < 3; ++k) {
    const int v = fa(a, k);
    const Vec3 d = &ae == &as ? Vec3(-*shift) : Vec3(row3(ae, v) - row3(as, v) - *shift);
    m = std::max(m, d.norm());
  }
  return m;
}

// Signed distances of B's corners (start and end) to A's start plane, lowest and highest per
// corner, and the limit beyond which a point stays more than gap from A over the step: gap plus
// A's largest corner displacement (every point of a linearly moving triangle stays within it of
// its start position), widened by `slack`; infinite when A is degenerate (no plane, nothing is
// beyond). With a shift, B's end positions less the shift and `motion` measured likewise.
void corner_sides(const SweptPlanes& pa, int a, double motion, const Faces& fb, int b, const Positions& bs,
                  const Positions& be, const Vec3* shift, double gap, double slack, std::array<double, 3>& lo,
                  std::array<double, 3>& hi, double& limit) {
  const Vec3& n = pa.normal[a];
  if (n == Vec3::Zero()) {
    limit = std::numeric_limits<double>::infinity();
    lo.fill(0.0);
    hi.fill(0.0);
    return;
  }
  limit = (gap + motion) * (1.0 + slack);
  const Vec3& origin = pa.origin[a];
  const double shifted = shift ? n.dot(*shift) : 0.0;
  for (int k = 0; k < 3; ++k) {
    const int v = fb(b, k);
    const double ds = n.dot(row3(bs, v) - origin);
    const double de = (&be == &bs ? ds : n.dot(row3(be, v) - origin)) - shifted;  // static: the same point
    lo[k] = std::min(ds, de);
    hi[k] = std::max(ds, de);
  }
}

// Whether the corners in `mask` all lie beyond `limit` on one side.
bool beyond(const std::array<double, 3>& lo, const std::array<double, 3>& hi, double limit, int mask) {
  double low = std::numeric_limits<double>::infinity(), high = -low;
  for (int k = 0; k < 3; ++k)
    if (mask & (1 << k)) {
      low = std::min(low, lo[k]);
      high = std::max(high, hi[k]);
    }
  return low > limit || high < -limit;
}

}  // namespace

void SweptPlanes::compute(const Faces& faces, const Positions& start, const Positions& end, int threads) {
  const int count = static_cast<int>(faces.rows());
  normal.resize(count);
  origin.resize(count);
  motion.resize(count);
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1 && count > 4096)
  for (int f = 0; f < count; ++f) compute_face(faces, start, end, f);
}

void SweptPlanes::compute_faces(const Faces& faces, const Positions& start, const Positions& end,
                                const std::vector<int>& list) {
  for (int f : list) compute_face(faces, start, end, f);
}

void SweptPlanes::compute_face(const Faces& faces, const Positions& start, const Positions& end, int f) {
  const Triangle s = corners(faces, f, start), e = corners(faces, f, end);
  Vec3 n = (s[1] - s[0]).cross(s[2] - s[0]);
  const double norm = n.norm();
  normal[f] = norm > 0.0 ? Vec3(n / norm) : Vec3::Zero();
  origin[f] = s[0];
  double m = 0.0;
  for (int k = 0; k < 3; ++k) m = std::max(m, (e[k] - s[k]).norm());
  motion[f] = m;
}

bool PlaneSides::apart(int cloth_mask, int other_mask) const {
  return beyond(cloth_lo, cloth_hi, cloth_limit, cloth_mask) || beyond(other_lo, other_hi, other_limit, other_mask);
}

bool triangles_apart(const SweptPlanes& pa, int a, const Faces& fa, const Positions& as, const Positions& ae,
                     const SweptPlanes& pb, int b, const Faces& fb, const Positions& bs, const Positions& be,
                     double gap, bool exact, PlaneSides& sides, const Vec3* shift) {
  const double slack = exact ? kPlaneSlack : 0.0;
  // CCD's minimum separation is in the infinity norm of the gap vector (ccd.h), which is down to
  // 1/sqrt(3) of the Euclidean distance: for CCD's lists the planes keep out only what stays
  // more than sqrt(3) gaps away.
  if (!exact) gap *= std::sqrt(3.0);
  corner_sides(pa, a, motion_of(pa, a, fa, as, ae, shift), fb, b, bs, be, shift, gap, slack, sides.other_lo,
               sides.other_hi, sides.other_limit);
  if (beyond(sides.other_lo, sides.other_hi, sides.other_limit, 7)) return true;
  corner_sides(pb, b, motion_of(pb, b, fb, bs, be, shift), fa, a, as, ae, shift, gap, slack, sides.cloth_lo,
               sides.cloth_hi, sides.cloth_limit);
  return beyond(sides.cloth_lo, sides.cloth_hi, sides.cloth_limit, 7);
}

}  // namespace weft
