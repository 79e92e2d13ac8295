// The frame in which the CCD broad phase sweeps a body's boxes and the cloth's against it
// (ContactDetection::collect). Cloth riding on a moving body (a walking character's dress)
// moves with it: swept in world space, both sides' boxes are as long as the step's motion and
// overlap far more than their relative motion can bring together (on a character walking at
// 1.2 m/s, seven times the candidates of the same character standing). Seen from a frame that
// moves with a constant velocity, a point moving linearly from s to e moves from s to
// e - shift, and the distance between two points at every instant is the same as in the world,
// so boxes swept in that frame still find every pair that can come within the gap: any shift is
// correct, a good one keeps the boxes small.
#pragma once

#include <vector>

#include "weft/common/types.h"
#include "weft/geometry/aabb_tree.h"

namespace weft {

class SweepFrame {
 public:
  // The shift for one body over a step: per axis, the median displacement of the body's
  // vertices and of the cloth vertices that start within `reach` (the body's swept bounds grown
  // by the cloth's margin). Along an axis the median minimizes the summed extents of the
  // points' swept boxes, so it is the body's own motion where it carries the cloth with it and
  // stays near zero where the cloth around it rests. Zero when no component exceeds `least`
  // (then the world frame's boxes are nearly as small and the traversal is the plain one).
  // The same for any thread count (serial).
  Vec3 shift(const Positions& body_start, const Positions& body_end, const Aabb& reach, const Positions& x,
             const Positions& x_end, double least);
  // The shift for the cloth's pairs with itself: per axis, the median displacement of its
  // vertices (a whole garment carried along by its character sweeps no box at all), zero
  // likewise.
  Vec3 shift(const Positions& x, const Positions& x_end, double least);

 private:
  // Per axis, the median of the displacements of the body's vertices (none: null) and of the
  // cloth vertices in near_; zero as above.
  Vec3 median(const Positions* body_start, const Positions* body_end, const Positions& x, const Positions& x_end,
              double least);

  std::vector<int> near_;          // cloth vertices in reach
  std::vector<double> displaced_;  // one axis's displacements
};

}  // namespace weft
