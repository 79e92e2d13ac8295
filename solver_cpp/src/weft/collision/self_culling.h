// Self-collision culling by normal cones (Volino & Magnenat-Thalmann 1994; continuous normal
// cones after Tang, Curtis, Yoon & Manocha 2009, "ICCD").
//
// A connected surface patch whose normals all lie in a cone of half-angle below 90 degrees
// around an axis projects one-to-one onto the plane perpendicular to the axis as long as its
// boundary, so projected, does not cross itself; such a patch cannot intersect itself. Over a
// step each triangle's (unnormalised) normal is a quadratic Bezier curve in time,
//   n(t) = (1-t)^2 n0 + 2t(1-t) m + t^2 n1,  m = (e1(0) x e2(1) + e1(1) x e2(0)) / 2,
// so a cone containing n0, m and n1 holds all of the step's normals. The patch cannot come
// within `margin` of itself during the step either, when its projected boundary segments that
// share no vertex stay more than margin apart: their start distance minus the largest projected
// displacement of their end points.
//
// The patches are the nodes of the cloth's AABB tree (leaf i is face i). Their topology (is the
// node's face set connected across shared edges, which edges bound it) depends only on the tree
// and is computed when the tree is built; the cones and the boundary test run every time the
// broad phase does. Self-pairs inside a culled node are not generated (AabbTree::self_pairs).
#pragma once

#include <vector>

#include "weft/geometry/aabb_tree.h"
#include "weft/common/types.h"

namespace weft {

class SelfCollisionCulling {
 public:
  // Node topology for `tree` (built over the boxes of `faces`). Faces with face_self == 0 break
  // connectivity: a node containing one is never culled.
  void rebuild(const AabbTree& tree, const Faces& faces, const std::vector<char>& face_self);
  // Marks the nodes whose patch cannot come within `margin` of itself while moving linearly from
  // x to x_end. Returns the number of culled nodes (telemetry). The cones are computed on
  // `threads` threads, with the same result for any count.
  int update(const AabbTree& tree, const Faces& faces, const Positions& x, const Positions& x_end, double margin,
             int threads = 1);
  // update() again after only the end positions of some vertices changed: x and margin as in
  // the last update (or update_changed), x_end differing from that update's only at vertices of
  // the faces with face_changed[f] != 0. Recomputes the cones and tests of those faces' tree
  // nodes and their ancestors and reuses the other nodes' results: the same culled() as a full
  // update(). Falls back to one when the margin differs or there was no update before.
  int update_changed(const AabbTree& tree, const Faces& faces, const Positions& x, const Positions& x_end,
                     double margin, const std::vector<char>& face_changed, int threads = 1);
  // Per tree node: 1 when its self-pairs can be skipped (after update()).
  const std::vector<char>& culled() const { return culled_; }
  // Boundary segments above which a node is not tested (its children are): bounds the quadratic test.
  static constexpr int kMaxBoundaryEdges = 768;

 private:
  struct Cone {
    Vec3 axis = Vec3::Zero();
    double half_angle = 0.0;  // radians; >= pi/2 means no useful cone
  };
  static Cone merge(const Cone& a, const Cone& b);
  static Cone leaf_cone(const Faces& faces, int leaf, const Positions& x, const Positions& x_end);
  bool boundary_clear(int node, const Vec3& axis, const Positions& x, const Positions& x_end, double margin) const;

  std::vector<char> connected_;                         // per node
  std::vector<std::vector<std::array<int, 2>>> boundary_;  // per node: edges used by one of its faces
  // The top-down pass from cone_ and test_: the first passing node on each path is culled.
  int cull_from_root(const AabbTree& tree, const Positions& x, const Positions& x_end, double margin);

  std::vector<Cone> cone_;                              // per node, per update
  std::vector<char> culled_;                            // per node, per update
  std::vector<signed char> test_;                       // per node: last test's result, -1 not run
  std::vector<int> parent_, leaf_node_;                 // per node its parent (-1: root); per face its leaf
  std::vector<char> dirty_;                             // update_changed(): nodes above a changed face
  double last_margin_ = -1.0;                           // margin of the last update (-1: none yet)
  std::vector<std::vector<int>> by_height_;             // nodes by height above the leaves (leaves: 0)
};

}  // namespace weft
