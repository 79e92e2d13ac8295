// Cloth/cloth untangling in the step (Baraff, Witkin & Kass 2003, "Untangling Cloth"; issue 6):
// at the start of a step's collision stage, the self-colliding cloth faces (all pieces, which
// share one mesh, so this covers cloth/cloth between pieces too) are analysed with
// analyse_self_intersections. A per-path, per-component colouring marks the regions in
// intersection; the collision stage then
//   - skips cloth/cloth triangle pairs across an intersection (a one-way membrane, see
//     skip_triangle_pair), so coloured regions may pass back while cloth away from the
//     intersection still cannot enter;
//   - pulls each crossing edge back through the triangle it crosses (pull): the edge's
//     coloured endpoint gets a velocity, relative to the triangle, that takes it across the
//     triangle's plane to its uncoloured endpoint's side (plus the thickness) within the step;
//   - pushes interlocked edge pairs apart (an edge through a face around another edge, which
//     goes through a face around the first: an intersection that splits nothing, so the
//     colouring cannot mark it), each edge towards the side its own ends are on.
// Nothing here depends on the thread count: the analysis is deterministic, the pull is serial
// in hit order. See docs/intersection-analysis.md, "In the step: cloth/cloth untangling".
#pragma once

#include <algorithm>
#include <array>
#include <vector>

#include "weft/gia/intersection_analysis.h"
#include "weft/common/types.h"

namespace weft {

// One crossing to undo: edge (coloured, free) crosses cloth face `face`.
struct UntangleHit {
  int coloured = -1;  // the edge's endpoint in intersection
  int free = -1;      // its other endpoint (not coloured)
  int face = -1;      // cloth face id (index into the full cloth face list)
};

// Two edges through each other (an "X" between two layers, or a hem folded tightly onto the
// cloth above it): edge `a` crosses a cloth face around edge `b` (`b_faces`: the one or two it
// crosses), and `b` crosses a face around `a`. Their intersection path has no coloured side:
// it closes around no vertex, or ends on the boundary or at a shared vertex without splitting
// anything, so the colouring has nothing to mark and no endpoint to pull.
struct Interlock {
  std::array<int, 2> a = {-1, -1}, b = {-1, -1};  // the edges' vertices
  std::array<int, 2> b_faces = {-1, -1};          // cloth faces around b that a crosses (-1: none)
  std::array<int, 2> a_around = {-1, -1}, b_around = {-1, -1};  // cloth faces around each edge
};

class ClothUntangling {
 public:
  ClothUntangling() = default;
  // face_self: per cloth face, whether it takes part (cloth/cloth collisions); empty: none.
  ClothUntangling(const Faces& cloth_faces, const std::vector<char>& face_self, int vertex_count);

  // Analyses the self-colliding faces at positions x: colours, tangled flags and hits. Returns
  // the analysis' C++ time in seconds.
  double analyse(const Positions& x, int threads);

  // Velocity corrections for every hit, serially in hit order (each relative to the velocities
  // left by the ones before): the coloured endpoint gets a velocity change along the crossed
  // triangle's normal so that its velocity relative to the crossing point on the triangle
  // carries it to the free endpoint's side of the plane, thickness beyond, within h. A pair
  // already moving that fast is left alone. The recoil (opposite momentum) is spread over the
  // free, unpinned vertices of the triangle's connected component by mass, after all hits, so
  // momentum is conserved and no single triangle is kicked through its neighbours. Returns the
  // number of hits corrected. Then each interlocked pair of edges gets equal and opposite
  // impulses at its closest points along the normal of b's faces, so that a's crossing point
  // ends the step on the side of b's surface that a's own ends are on, the thickness beyond
  // b's (and b on the other side); those corrected are counted too.
  int pull(const Positions& x, Positions& v, double h, const std::vector<double>& inverse_mass,
           const std::vector<double>& vertex_thickness) const;

  bool any() const { return !hits_.empty() || coloured_count_ > 0; }
  // Interlocked edge pairs to push apart (Interlock): the analysis is due again next step.
  bool interlocked() const { return !interlocks_.empty(); }
  // Forget the last analysis (a step that skips it: nothing tangled, nothing skipped or pulled).
  void clear() {
    hits_.clear();
    interlocks_.clear();
    std::fill(interlock_face_.begin(), interlock_face_.end(), 0);
    coloured_count_ = 0;
    path_count_ = 0;
  }
  // Membrane flags: a vertex is tangled when coloured or on a contour face (a face crossed by a
  // path); a face when one of its vertices is tangled.
  bool tangled_vertex(int v) const { return any() && tangled_vertex_[v]; }
  bool tangled_face(int f) const { return any() && tangled_face_[f]; }
  bool coloured(int v) const { return any() && colour_[v]; }
  // One-way membrane for cloth/cloth pairs: a triangle pair is skipped (all its feature pairs)
  // when both faces are tangled and lie in different tangled patches (connected components of
  // the tangled faces): the two sides of an intersection, e.g. a flap's tip and the layer it
  // went through. Pairs within one patch (a coloured region against itself) and pairs with an
  // untangled face are kept, so clean cloth still cannot enter, nor a region fold into itself.
  // The faces around an interlocked pair of edges are skipped against each other too (only
  // those: the layers around them stay apart), so the edges may pass back.
  bool skip_triangle_pair(int a, int b) const {
    if (any() && tangled_face_[a] && tangled_face_[b] && patch_[cloth_faces_(a, 0)] != patch_[cloth_faces_(b, 0)])
      return true;
    return interlocked() && interlock_face_[a] && interlock_face_[b] && interlock_pair(a, b);
  }

  const std::vector<UntangleHit>& hits() const { return hits_; }
  const std::vector<Interlock>& interlocks() const { return interlocks_; }
  const std::vector<char>& colour() const { return colour_; }
  const std::vector<int>& patch() const { return patch_; }
  int coloured_count() const { return coloured_count_; }
  int path_count() const { return path_count_; }

 private:
  Faces faces_;                 // the self-colliding faces only
  std::vector<int> face_id_;    // row of faces_ -> cloth face id
  Faces cloth_faces_;
  int vertex_count_ = 0;
  // Topology of faces_ (the analysis numbers edges the same way), and connected component of
  // each vertex (cloth pieces are components of the one mesh).
  GiaTopology topo_;
  std::vector<int> component_;
  std::vector<char> colour_, tangled_vertex_, tangled_face_;
  std::vector<int> patch_;  // tangled patch of each vertex of a tangled face (its lowest vertex id), else -1
  void colour(const GiaResult& r, const Positions& x);
  void find_interlocks(const GiaResult& r);
  bool interlock_pair(int a, int b) const;
  int push_interlocks(const Positions& x, Positions& v, double h, const std::vector<double>& inverse_mass,
                      const std::vector<double>& vertex_thickness) const;
  std::vector<UntangleHit> hits_;
  std::vector<Interlock> interlocks_;
  std::vector<char> interlock_face_;  // per cloth face: around an interlocked edge
  int coloured_count_ = 0, path_count_ = 0;
};

}  // namespace weft
