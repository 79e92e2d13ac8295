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
// displacement of their end points. Displacements are measured in the world or in the frame of
// the boundary's mean displacement, whichever is smaller: distances within the patch are the
// same in every frame, and a patch carried along (a walking character's dress, a falling
// sheet) hardly moves in its own.
//
// The patches are the nodes of the cloth's AABB tree (leaf i is face i). Their topology (is the
// node's face set connected across shared edges, which edges bound it, which faces it holds)
// depends only on the tree and is computed when the tree is built; the cones and the boundary
// test run every time the broad phase does. Cones are built lazily, top-down: the cull needs
// the cone of a node only when no ancestor was culled, and a node's cone is taken directly from
// its faces' unit control normals (axis: their sum, read off prefix sums in leaf order; narrow
// when every control lies within 60 degrees of it), so the nodes below a culled one cost
// nothing and no trigonometry runs. Self-pairs inside a culled node are not generated
// (AabbTree::self_pairs).
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
  // x to x_end. Returns the number of culled nodes (telemetry). The faces' control normals are
  // computed on `threads` threads, with the same result for any count.
  int update(const AabbTree& tree, const Faces& faces, const Positions& x, const Positions& x_end, double margin,
             int threads = 1);
  // update() again after only the end positions of some vertices changed: x and margin as in
  // the last update (or update_changed), x_end differing from that update's only at vertices of
  // the faces with face_changed[f] != 0. Recomputes those faces' controls and the tests of their
  // tree nodes and ancestors and reuses the other nodes' results: the same culled() as a full
  // update(). Falls back to one when the margin differs or there was no update before.
  int update_changed(const AabbTree& tree, const Faces& faces, const Positions& x, const Positions& x_end,
                     double margin, const std::vector<char>& face_changed, int threads = 1);
  // Per tree node: 1 when its self-pairs can be skipped (after update()).
  const std::vector<char>& culled() const { return culled_; }
  // Boundary segments above which a node is not tested (its children are): bounds the quadratic test.
  static constexpr int kMaxBoundaryEdges = 768;

 private:
  // Unit control normals of face f over the step (static: its normal), into controls_.
  void face_controls(const Faces& faces, int f, const Positions& x, const Positions& x_end);
  // Leaf-order prefix sums of the faces' control sums (after any change of controls_).
  void sum_controls();
  // Node n's cone axis when every control of its faces lies within kMaxHalfAngle of it (the
  // axis of a narrow cone), else false (a wide cone: not culled).
  bool narrow_cone(int n, Vec3& axis) const;
  bool boundary_clear(int node, const Vec3& axis, const Positions& x, const Positions& x_end, double margin) const;

  std::vector<char> connected_;                         // per node
  std::vector<std::vector<std::array<int, 2>>> boundary_;  // per node: edges used by one of its faces
  // The top-down pass from test_: the first passing node on each path is culled.
  int cull_from_root(const AabbTree& tree, const Positions& x, const Positions& x_end, double margin, int threads);

  std::vector<int> leaf_order_;                         // faces in tree order: each node's are contiguous
  std::vector<int> first_, last_;                       // per node: its faces are leaf_order_[first_, last_)
  int controls_per_face_ = 1;                           // last update: 1 static (the normal), 3 over a step (n0, m, n1)
  std::vector<Vec3> controls_;                          // per face, controls_per_face_ unit vectors
  std::vector<char> no_cone_;                           // per face: degenerate, no normal
  std::vector<Vec3> control_sum_;                       // prefix sums in leaf order (size faces + 1)
  std::vector<int> no_cone_count_;                      // prefix counts of no_cone_ in leaf order
  std::vector<char> culled_;                            // per node, per update
  std::vector<signed char> test_;                       // per node: last test's result, -1 not run
  std::vector<int> frontier_, next_frontier_;           // cull_from_root(): the nodes of one depth
  std::vector<int> parent_, leaf_node_;                 // per node its parent (-1: root); per face its leaf
  double last_margin_ = -1.0;                           // margin of the last update (-1: none yet)
};

}  // namespace weft
