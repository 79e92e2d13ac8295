// The convex edges of a body sharp enough that a cloth edge can touch them while both of its
// ends stay clear of the body (a coarse sheet hooked on a thin limb, a strap over a box
// corner): the only body edges cloth/body edge contacts need to look at.
//
// A cloth edge of length L whose ends rest a separation s above the two faces of a convex body
// edge with exterior angle theta sags towards that edge by up to (L / 2) sin(theta / 2); where
// that stays below half the separation, the vertex contacts at its ends keep it clear. So an
// edge is sharp when L_max |n0 - n1| / 4 > s_min / 2 (|n0 - n1| = 2 sin(theta / 2) for the unit
// normals of its faces), with L_max the longest cloth edge and s_min the smallest separation.
// An edge with one face (a border) counts as a knife edge, |n0 - n1| = 2; a concave (valley)
// edge is never sharp; an edge of more than two faces is judged by its first two. A smooth body
// finely tessellated against its cloth has none, and costs nothing more.
#pragma once

#include <array>
#include <vector>

#include "weft/common/types.h"
#include "weft/geometry/aabb_tree.h"

namespace weft {

class SharpEdges {
 public:
  // Edge topology of a body's faces (fixed for the body's life).
  explicit SharpEdges(const Faces& faces);
  // The sharp edges at body positions x, and a tree over their boxes. Returns their count. The
  // faces' normals and the edges' sharpness are recomputed only when x differs from the last
  // call's (a body at rest), the boxes and the tree only when x or the sharp edges do.
  int update(const Faces& faces, const Positions& x, double longest_cloth_edge, double smallest_separation);
  bool empty() const { return sharp_.empty(); }
  int size() const { return static_cast<int>(sharp_.size()); }  // sharp edges (the tree's leaves)
  const AabbTree& tree() const { return tree_; }
  // Leaf k of the tree: the k-th sharp edge's vertices, and its sharpness |n0 - n1| (2 on a border).
  const std::array<int, 2>& edge(int leaf) const { return edges_[sharp_[leaf]]; }
  const std::array<int, 2>& faces(int leaf) const { return faces_[sharp_[leaf]]; }  // [1] = -1: a border
  double sharpness(int leaf) const { return sharpness_[leaf]; }
  double sharpest() const { return sharpest_; }
  // Whether an edge of this sharpness can catch a cloth edge of this length kept `separation` off.
  static bool sharp_for(double sharpness, double cloth_edge_length, double separation) {
    return cloth_edge_length * sharpness > 2.0 * separation;
  }
  // The edges that are not sharp and one of whose ends advances along the edge's outward
  // normal (its faces' unit normals summed) by more than `least` between update's positions
  // and `end`, appended to out. The sag bound above
  // assumes cloth ends held at their separation by vertex contacts linearized at the step's
  // start; a body edge advancing by more than half a separation in one step (a fast limb
  // through a sheet) does not leave them there, and can reach a cloth edge between them
  // (ContactDetection's point-by-point proximity pairs). None when start and end are the same
  // positions and `least` is not negative.
  void advancing(const Positions& start, const Positions& end, double least,
                 std::vector<std::array<int, 2>>& out) const;
  double separation() const { return separation_; }  // update's smallest separation
  // Whether a cloth edge from cloth_a to cloth_b cuts the body's corner at sharp edge `leaf`
  // (with its ends kept off, a cloth edge does not reach a blunt one), at update's positions:
  // its point cloth_point nearest to that edge's point on_edge lies below the planes of both of
  // the edge's faces, and each end above at least one of them, so that it goes in through one
  // face and out through the other. A contact along those nearest points would hold such a
  // cloth edge on the wrong side; its way out is the opposite one. A cloth edge with an end
  // inside the wedge (through the body, or across a limb thinner than it) does not cut the
  // corner; nor is a border cut.
  bool corner_cut(int leaf, const Vec3& on_edge, const Vec3& cloth_a, const Vec3& cloth_b,
                  const Vec3& cloth_point) const;

 private:
  std::vector<std::array<int, 2>> edges_;   // vertices, lower first
  std::vector<std::array<int, 2>> faces_;   // the edge's faces; [1] = -1 on a border
  std::vector<int> far_;                    // the second face's corner off the edge (-1 on a border)
  Positions normals_at_;                    // the positions the next three are of
  std::vector<Vec3> normals_;               // unit face normals
  std::vector<double> edge_sharpness_;      // per edge, |n0 - n1| (2 on a border)
  std::vector<char> convex_;                // per edge, convex or a border
  std::vector<Aabb> boxes_;                 // per update: per sharp edge
  std::vector<int> sharp_;                  // per update: sharp edge ids, increasing
  std::vector<double> sharpness_;           // per update: per sharp edge
  double sharpest_ = 0.0;
  double separation_ = 0.0;                 // per update: the smallest separation
  std::vector<char> is_sharp_;              // per update: per edge
  AabbTree tree_;
};

}  // namespace weft
