// Where two parts of one articulated character close on cloth (body_pinch.h). The parts
// overlap at their joints by construction, so their intersection is no pinch; but where their
// surfaces, each outside the other, face each other closer than the cloth can lie between them
// (an upper arm along the torso, the inside of a bent elbow), cloth there is caught between
// two surfaces that close on it, as between two bodies that intersect: a pinch.
//
// A pair of parts faces within a gap where a feature pair (a vertex of one against a triangle
// of the other, or an edge of each) of two triangles whose outward normals face each other
// (the angle between them above kFacingAngle) is nearer than the gap, each closest point lying
// in front of the other part's triangle. The region is the box of those closest points.
#pragma once

#include <vector>

#include "weft/common/types.h"
#include "weft/geometry/aabb_tree.h"

namespace weft {

// A part's surface at one configuration: outward face normals (closed parts: flipped when the
// signed volume is negative, decided at the first fit) and a tree of face boxes grown by half
// the largest gap asked for, so that two faces within the gap have overlapping boxes.
class PartSurface {
 public:
  void fit(const Positions& x, const Faces& faces, double half_gap);
  const AabbTree& tree() const { return tree_; }
  const Vec3& normal(int f) const { return normals_[f]; }
  // Enclosed volume at the first fit (closed parts; 0 for open ones).
  double volume() const { return volume_; }

 private:
  AabbTree tree_;
  std::vector<Aabb> boxes_;
  std::vector<Vec3> normals_;
  std::vector<double> margin_;
  int orientation_ = 0;  // +1 outward as wound, -1 flipped, 0 not decided yet
  double volume_ = 0.0;
};

// Outward normals facing each other: their angle above 150 degrees (a wedge narrower than 30
// degrees between the surfaces). A wider crease holds cloth at its thickness from both sides a
// little farther from its apex, so it pinches nothing.
constexpr double kFacingCosine = -0.8660254037844386;

// The box of the closest points of the feature pairs by which parts a and b (their surfaces
// fitted at xa and xb with a half gap of at least gap / 2) face each other within `gap`;
// empty (lo > hi) when none.
Aabb facing_gap_region(const PartSurface& a, const Positions& xa, const Faces& fa, const PartSurface& b,
                       const Positions& xb, const Faces& fb, double gap);

}  // namespace weft
