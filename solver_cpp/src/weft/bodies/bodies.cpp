#include "weft/bodies/bodies.h"

#include <stdexcept>

namespace weft {

KinematicBody::KinematicBody(Faces faces, Positions initial_positions)
    : faces_(std::move(faces)), frame_start_(initial_positions), frame_end_(std::move(initial_positions)) {
  const int n = vertex_count();
  for (int f = 0; f < faces_.rows(); ++f)
    for (int c = 0; c < 3; ++c)
      if (faces_(f, c) < 0 || faces_(f, c) >= n)
        throw std::invalid_argument("body face " + std::to_string(f) + " references vertex " +
                                    std::to_string(faces_(f, c)) + " of " + std::to_string(n));
}

void KinematicBody::set_keyframes(const Positions& frame_start, const Positions& frame_end) {
  if (frame_start.rows() != vertex_count() || frame_end.rows() != vertex_count())
    throw std::invalid_argument("body keyframes have " + std::to_string(frame_start.rows()) + " and " +
                                std::to_string(frame_end.rows()) + " vertices, expected " +
                                std::to_string(vertex_count()));
  frame_start_ = frame_start;
  frame_end_ = frame_end;
}

void KinematicBody::positions_at(double alpha, Positions& out) const {
  out = (1.0 - alpha) * frame_start_ + alpha * frame_end_;
}

Mat3 triangle_frame(const Vec3& a, const Vec3& b, const Vec3& c) {
  Mat3 frame;
  const Vec3 t = (b - a).normalized();
  const Vec3 n = (b - a).cross(c - a).normalized();
  frame.col(0) = t;
  frame.col(1) = n;
  frame.col(2) = n.cross(t);
  return frame;
}

}  // namespace weft
