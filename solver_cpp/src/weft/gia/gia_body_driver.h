// GIA of the cloth against closed bodies in the collision stage (docs/intersection-analysis.md):
// at the start of a step, colour the cloth vertices inside each closed collidable body and the
// body faces in intersection with the cloth (the one-way membrane the contact detection asks
// about: contact_filter.h), then push contour vertices out through a face in intersection
// (recovery). Cloth gripped by a body/body pinch (pinch_driver.h) moves with the body instead.
#pragma once

#include <vector>

#include "weft/bodies/bodies.h"
#include "weft/collision/collision_step.h"
#include "weft/collision/contact_detection.h"
#include "weft/gia/gia_topology.h"

namespace weft {

class PinchDriver;

class GiaBodyDriver {
 public:
  GiaBodyDriver(const ContactDetection& detection, int vertex_count);

  // Colours against every closed collidable body at the step's start, or only against those
  // `only` marks (the caller knows the cloth cannot be in the others: each answers as analysed
  // with nothing found);
  // returns whether the cloth is in intersection with one (paths or vertices inside).
  bool colour(const CollisionStep& step, int threads, CollisionTelemetry& frame,
              const std::vector<char>* only = nullptr);
  // Recovery pushes (and pinch grips) on step.v: contour vertices inside a body, and cloth
  // edges that cut a body's corner (with step.sharp_edges).
  void recover(CollisionStep& step, const ContactProperties& props, PinchDriver* pinch, CollisionTelemetry& frame);
  void clear();

  // Membrane queries (see ContactFilter).
  bool coloured(int p, int body) const {
    return p >= 0 && !bodies_[body].inside.empty() && bodies_[body].inside[p];
  }
  int body_face_colour(int f, int body) const {
    return !bodies_[body].face_coloured.empty() ? bodies_[body].face_coloured[f] : 0;
  }
  bool cloth_face_contour(int f, int body) const {
    return !bodies_[body].cloth_face_contour.empty() && bodies_[body].cloth_face_contour[f];
  }
  bool contour_corner(int p, int body) const {
    return !bodies_[body].contour_corner.empty() && bodies_[body].contour_corner[p];
  }
  // Some cloth vertex coloured inside `body`, a body face coloured or pierced, or a cloth face on
  // the contour: the analysis found `body` in intersection with the cloth.
  bool intersects(int body) const;
  // Nothing coloured against `body`: the three queries above give their defaults.
  bool clean(int body) const {
    const Body& b = bodies_[body];
    return b.inside.empty() && b.face_coloured.empty() && b.cloth_face_contour.empty();
  }

 private:
  struct Body {
    GiaTopology topology;            // of the body's mesh (fixed), built once
    AabbTree tree;                   // over its faces: built at the first colouring, refitted after
    std::vector<Aabb> boxes;
    bool closed = false;             // collidable and watertight: analysed
    std::vector<char> inside;        // per cloth vertex: inside the body (coloured)
    // per body face: 3 all vertices in the body's coloured region (in intersection with the
    // cloth), 2 some vertex in it, 1 none but pierced by the cloth, 0 free
    std::vector<char> face_coloured;
    std::vector<char> cloth_face_contour;  // per cloth face: it and the body pierce each other
    std::vector<char> contour_corner;      // per cloth vertex: a corner of such a face
    void clear() {
      contour_corner.clear();
      inside.clear();
      face_coloured.clear();
      cloth_face_contour.clear();
    }
  };
  const ContactDetection& detection_;
  int vertex_count_;
  std::vector<Body> bodies_;
  GiaTopology cloth_topology_;  // of collide_faces_, built once
  AabbTree cloth_tree_;         // over collide_faces_: built at the first colouring, refitted after
  std::vector<Aabb> cloth_boxes_;
  // Boxes of `faces` at x into `boxes`, and the tree over them: built when empty, else refitted
  // (the topology is fixed; the contact detection's trees live the same way).
  static void fit_tree(AabbTree& tree, std::vector<Aabb>& boxes, const Positions& x, const Faces& faces);
  // recover()'s pushes of cloth edges cutting a corner of `body` (edges: its SharpEdges);
  // returns the vertices pushed.
  int push_corner_cuts(CollisionStep& step, const ContactProperties& props, PinchDriver* pinch, int body,
                       const SharpEdges& edges);
  std::vector<std::vector<int>> cloth_neighbours_;  // contour test
  std::vector<char> vertex_collide_;                // on some body-colliding face
  Faces collide_faces_;                             // the cloth faces that collide with bodies
  std::vector<int> collide_face_ids_;               // their ids among all cloth faces
};

}  // namespace weft
