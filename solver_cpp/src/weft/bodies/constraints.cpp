#include "weft/bodies/constraints.h"

#include <limits>

namespace weft {

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
