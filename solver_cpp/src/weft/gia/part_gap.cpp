#include "weft/gia/part_gap.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

#include "weft/bodies/body_motion.h"
#include "weft/geometry/closest_points.h"

namespace weft {

namespace {

double signed_volume(const Positions& x, const Faces& faces) {
  double six = 0.0;
  for (int f = 0; f < faces.rows(); ++f)
    six += Vec3(row3(x, faces(f, 0))).dot(Vec3(row3(x, faces(f, 1))).cross(Vec3(row3(x, faces(f, 2)))));
  return six / 6.0;
}

std::array<Vec3, 3> corners(const Positions& x, const Faces& faces, int f) {
  return {Vec3(row3(x, faces(f, 0))), Vec3(row3(x, faces(f, 1))), Vec3(row3(x, faces(f, 2)))};
}

// p on one part, q on the other: p lies in front of the other's triangle (normal nq) and q in
// front of p's (normal np), both along the line between them, nearer than the gap.
bool facing(const Vec3& p, const Vec3& q, const Vec3& np, const Vec3& nq, double gap) {
  const Vec3 u = p - q;
  const double d = u.norm();
  const double along = -kFacingCosine * d;
  return d > 0.0 && d < gap && u.dot(nq) >= along && -u.dot(np) >= along;
}

}  // namespace

void PartSurface::fit(const Positions& x, const Faces& faces, double half_gap) {
  if (orientation_ == 0) {
    const double v = closed_surface(faces) ? signed_volume(x, faces) : 0.0;
    orientation_ = v < 0.0 ? -1 : 1;
    volume_ = std::abs(v);
  }
  normals_.resize(faces.rows());
  for (int f = 0; f < faces.rows(); ++f) {
    const auto c = corners(x, faces, f);
    const Vec3 n = (c[1] - c[0]).cross(c[2] - c[0]);
    const double length = n.norm();
    normals_[f] = length > 0.0 ? Vec3(orientation_ * n / length) : Vec3::Zero();
  }
  margin_.assign(faces.rows(), half_gap);
  const bool first = boxes_.size() != static_cast<size_t>(faces.rows()) || tree_.empty();
  triangle_boxes(faces, x, x, margin_, boxes_);
  if (first)
    tree_.build(boxes_);
  else
    tree_.refit(boxes_);
}

Aabb facing_gap_region(const PartSurface& a, const Positions& xa, const Faces& fa, const PartSurface& b,
                       const Positions& xb, const Faces& fb, double gap) {
  Aabb region;
  std::vector<std::pair<int, int>> candidates;
  a.tree().pairs(b.tree(), candidates);
  for (const auto& [i, j] : candidates) {
    const Vec3& na = a.normal(i);
    const Vec3& nb = b.normal(j);
    if (!(na.dot(nb) < kFacingCosine)) continue;
    const auto ta = corners(xa, fa, i), tb = corners(xb, fb, j);
    // Each triangle must reach in front of the other's plane, within the gap of it: surfaces
    // that overlap (a joint) lie behind each other's planes and are rejected here, before the
    // fifteen distance queries.
    auto reaches = [gap](const std::array<Vec3, 3>& t, const Vec3& origin, const Vec3& n) {
      double lo = std::numeric_limits<double>::infinity(), hi = -lo;
      for (const Vec3& c : t) {
        const double d = (c - origin).dot(n);
        lo = std::min(lo, d);
        hi = std::max(hi, d);
      }
      return hi > 0.0 && lo < gap;
    };
    if (!reaches(tb, ta[0], na) || !reaches(ta, tb[0], nb)) continue;
    auto add = [&](const Vec3& p, const Vec3& q) {
      region.expand(p);
      region.expand(q);
    };
    Vec3 bary;
    for (int k = 0; k < 3; ++k) {
      point_triangle_distance(ta[k], tb[0], tb[1], tb[2], bary);
      const Vec3 qb = bary[0] * tb[0] + bary[1] * tb[1] + bary[2] * tb[2];
      if (facing(ta[k], qb, na, nb, gap)) add(ta[k], qb);
      point_triangle_distance(tb[k], ta[0], ta[1], ta[2], bary);
      const Vec3 qa = bary[0] * ta[0] + bary[1] * ta[1] + bary[2] * ta[2];
      if (facing(qa, tb[k], na, nb, gap)) add(qa, tb[k]);
    }
    for (int k = 0; k < 3; ++k)
      for (int l = 0; l < 3; ++l) {
        double s = 0.0, t = 0.0;
        const Vec3 &a0 = ta[k], &a1 = ta[(k + 1) % 3], &b0 = tb[l], &b1 = tb[(l + 1) % 3];
        segment_segment_distance(a0, a1, b0, b1, s, t);
        const Vec3 pa = a0 + s * (a1 - a0), pb = b0 + t * (b1 - b0);
        if (facing(pa, pb, na, nb, gap)) add(pa, pb);
      }
  }
  return region;
}

}  // namespace weft
