// Pins: cloth vertices held at a fixed point, or attached to a point on an animated body and
// following it (barycentric point of the closest body triangle plus an offset in that
// triangle's local frame). Each substep they become prescribed velocity changes in the
// pre-filtered solve.
#pragma once

#include "weft/bodies/bodies.h"
#include "weft/geometry/closest_points.h"
#include "weft/linear_system/pcg.h"

namespace weft {

// A pin held at a point in space, or moved along a prescribed path: over each frame its target
// goes linearly from start to end (equal for a pin that stays put).
struct FixedPin {
  int vertex;
  Vec3 start, end;
  Vec3 target(double alpha) const { return start + alpha * (end - start); }
};

struct BodyPin {
  int vertex;
  int body;
  int face;
  Vec3 barycentric;
  Vec3 local_offset;  // in triangle_frame() coordinates
};

struct PinSet {
  std::vector<FixedPin> fixed;
  std::vector<BodyPin> attached;
};

// Attach a vertex at position x to the closest point of a body (positions as given).
BodyPin attach_to_body(int vertex, const Vec3& x, int body_index, const Faces& faces, const Positions& positions);

Vec3 body_pin_target(const BodyPin& pin, const Faces& faces, const Positions& body_positions);

}  // namespace weft
