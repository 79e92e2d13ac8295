// Kinematic (animated) bodies: triangle meshes whose vertex positions are given per frame and
// interpolated linearly within a frame for each substep.
#pragma once

#include <string>

#include "weft/common/types.h"

namespace weft {

class KinematicBody {
 public:
  KinematicBody(Faces faces, Positions initial_positions);

  // Positions at the start and the end of the current frame.
  void set_keyframes(const Positions& frame_start, const Positions& frame_end);
  // alpha in [0, 1] across the current frame.
  void positions_at(double alpha, Positions& out) const;

  int vertex_count() const { return static_cast<int>(frame_start_.rows()); }
  const Faces& faces() const { return faces_; }
  const Positions& frame_start() const { return frame_start_; }
  const Positions& frame_end() const { return frame_end_; }

 private:
  Faces faces_;
  Positions frame_start_, frame_end_;
};

// Orthonormal frame of a body triangle: columns (edge direction, normal, bitangent).
Mat3 triangle_frame(const Vec3& a, const Vec3& b, const Vec3& c);

}  // namespace weft
