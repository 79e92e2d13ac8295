#include "weft/bodies/constraints.h"

#include <limits>

namespace weft {

Vec3 closest_point_barycentric(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  // Ericson, Real-Time Collision Detection, 5.1.5 (Voronoi regions of the triangle).
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return {1, 0, 0};
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return {0, 1, 0};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    const double v = d1 / (d1 - d3);
    return {1 - v, v, 0};
  }
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return {0, 0, 1};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    const double w = d2 / (d2 - d6);
    return {1 - w, 0, w};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {0, 1 - w, w};
  }
  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  return {1 - v - w, v, w};
}

BodyPin attach_to_body(int vertex, const Vec3& x, int body_index, const Faces& faces, const Positions& positions) {
  BodyPin best{vertex, body_index, -1, Vec3::Zero(), Vec3::Zero()};
  double best_distance = std::numeric_limits<double>::infinity();
  for (int f = 0; f < faces.rows(); ++f) {
    const Vec3 a = row3(positions, faces(f, 0)), b = row3(positions, faces(f, 1)), c = row3(positions, faces(f, 2));
    const Vec3 bary = closest_point_barycentric(x, a, b, c);
    const double d = (bary[0] * a + bary[1] * b + bary[2] * c - x).squaredNorm();
    if (d < best_distance) {
      best_distance = d;
      best.face = f;
      best.barycentric = bary;
    }
  }
  if (best.face < 0) throw std::invalid_argument("cannot attach a pin to a body without faces");
  const auto face = faces.row(best.face);
  const Vec3 a = row3(positions, face[0]), b = row3(positions, face[1]), c = row3(positions, face[2]);
  const Vec3 anchor = best.barycentric[0] * a + best.barycentric[1] * b + best.barycentric[2] * c;
  best.local_offset = triangle_frame(a, b, c).transpose() * (x - anchor);
  return best;
}

Vec3 body_pin_target(const BodyPin& pin, const Faces& faces, const Positions& body_positions) {
  const auto face = faces.row(pin.face);
  const Vec3 a = row3(body_positions, face[0]), b = row3(body_positions, face[1]), c = row3(body_positions, face[2]);
  const Vec3 anchor = pin.barycentric[0] * a + pin.barycentric[1] * b + pin.barycentric[2] * c;
  return anchor + triangle_frame(a, b, c) * pin.local_offset;
}

}  // namespace weft
