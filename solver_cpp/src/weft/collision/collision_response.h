// The collision stage of a step (Bridson, Fedkiw & Anderson 2002, with the fail-safe of
// Provot 1995 / Harmon et al. 2008): after the velocity solve, with x the start-of-step
// positions and v the new velocities (so the step moves x to x + h v),
//   1. broad phase: refit the AABB trees (swept boxes widened by the thickness), collect
//      triangle pairs cloth/body and cloth/cloth, and expand them into vertex-triangle and
//      edge-edge feature pairs, each pair once (representative triangles);
//   2. proximity: pairs closer than the thickness at the start get repulsion impulses towards
//      a separation of one thickness, with Coulomb friction;
//   3. CCD: pairs that touch during the step (conservative CCD, ccd.h) get inelastic impulses
//      that leave them a small separation at the end; repeated until no pair collides or the
//      iteration budget is spent;
//   4. rigid impact zones: remaining colliding vertices are merged into zones that move
//      rigidly (translation preserving the zone's momentum, or the velocity of a kinematic
//      body or pinned vertex they touch), re-detected until collision-free. Zones only grow,
//      so this always ends.
// Kinematic bodies and pinned vertices have infinite mass.
#pragma once

#include <memory>
#include <vector>

#include "weft/bodies/bodies.h"
#include "weft/gia/body_pinch.h"
#include "weft/geometry/aabb_tree.h"
#include "weft/gia/cloth_untangling.h"
#include "weft/linear_system/pcg.h"
#include "weft/geometry/closest_points.h"

namespace weft {

struct CollisionSettings {
  bool enabled = false;                 // master switch: no collision stage at all when false
  bool ccd = true;                      // continuous detection and the fail-safe
  std::vector<char> face_collide;       // per cloth face: collides with bodies (empty: all)
  std::vector<char> face_self_collide;  // per cloth face: cloth/cloth (empty: none)
  std::vector<char> body_collide;       // per body (empty: all)
  VectorX face_thickness;               // per cloth face, m (empty: 0.002)
  VectorX face_friction;                // per cloth face (empty: 0.3)
  int ccd_iterations = 8;               // impulse passes before impact zones
  int zone_iterations = 100;            // impact-zone passes (each grows or merges zones)
  bool count_intersections = true;      // exact intersection count at every frame end
  // Cloth/body contacts also as prescribed normal velocities in the filtered solve. Off by
  // default: the simple release rule (a vertex leaving faster than its push-out is not
  // constrained) made resting contact jitter in the box drop (docs/collisions.md).
  bool contact_constraints = false;
  // Global intersection analysis (docs/intersection-analysis.md): against closed bodies and,
  // with self-collision, cloth/cloth untangling (cloth_untangling.h). 0 off, 1 on, -1 on when
  // some cloth vertex starts inside a closed collidable body or the self-colliding cloth
  // starts self-intersecting.
  int gia = 0;
  // Body/body pinch states (body_pinch.h) when GIA is on and two or more bodies collide: CCD off
  // for cloth where two bodies intersect each other. Off only to compare (tests, diagnosis).
  bool body_pinch = true;
};

struct CollisionTelemetry {
  double broad_phase_seconds = 0.0;
  double proximity_seconds = 0.0;
  double ccd_seconds = 0.0;
  double response_seconds = 0.0;
  double intersection_seconds = 0.0;  // counting at frame end
  int proximity_pairs = 0;
  int ccd_candidates = 0;  // feature pairs given to CCD
  int ccd_hits = 0;
  int impact_zones = 0;
  int iterations = 0;  // CCD impulse passes plus impact-zone passes
  int unresolved = 0;  // colliding pairs left when the zone budget ran out
  int intersections = -1;  // triangle pairs intersecting at frame end (-1: not counted)
  double gia_seconds = 0.0;     // cloth/body inside classification and recovery pushes
  int gia_coloured_vertices = 0;  // cloth vertices inside a closed body, most over the substeps
  int gia_pushed_vertices = 0;    // contour vertices pushed out, summed over substeps
  int gia_paths = 0;              // cloth/body intersection paths at a substep start, most over the frame
  int gia_body_coloured_faces = 0;  // body faces in intersection with the cloth, most over the frame
  int gia_pinched_body_pairs = 0;  // body pairs not free over a substep (body_pinch.h), most over the substeps
  int gia_gripped_vertices = 0;    // cloth vertices moved with a body in a pinch, summed over substeps (not a column)
  int gia_self_coloured_vertices = 0;  // cloth/cloth GIA: coloured vertices, most over the substeps
  int gia_self_paths = 0;              // cloth/cloth GIA: intersection paths, most over the substeps
  double total_seconds() const {
    return broad_phase_seconds + proximity_seconds + ccd_seconds + response_seconds + intersection_seconds;
  }
  void add(const CollisionTelemetry& o);
};

// A feature pair: point indices >= 0 are cloth vertices, < 0 are body vertices -(1 + k) of
// body `body`. Vertex-triangle: (p, a, b, c); edge-edge: (a0, a1, b0, b1).
struct FeaturePair {
  std::array<int, 4> point;
  int body = -1;
  bool edge_edge = false;
  bool ccd = true;  // false: cloth in a body/body pinch region against one of the pair's bodies
};

class CollisionSystem {
 public:
  CollisionSystem(const Faces& cloth_faces, const Positions& x, const std::vector<double>& vertex_mass,
                  const std::vector<int>& pinned_vertices, const std::vector<KinematicBody>& bodies,
                  CollisionSettings settings, int threads);

  // Adjusts v so that x + h v is collision-free. Bodies move from alpha0 to alpha1 of the frame.
  void respond(const Positions& x, Positions& v, double h, const std::vector<KinematicBody>& bodies, double alpha0,
               double alpha1);

  // Before the solve: every free cloth vertex within the thickness of a collidable body face
  // and not moving away from it gets its normal velocity relative to the body prescribed
  // (to a small push back out), a constraint of the pre-filtered solve (pcg.h). Friction for
  // these contacts is applied after the solve with the constraint's velocity change as the
  // normal impulse.
  void constrain_contacts(const Positions& x, const Positions& v, double h, const std::vector<KinematicBody>& bodies,
                          double alpha0, double alpha1, ConstraintFilter& filter);

  // Exact count of intersecting triangle pairs (cloth/body for collidable bodies at the end of
  // the frame, cloth/cloth among self-colliding faces).
  int count_intersections(const Positions& x, const std::vector<KinematicBody>& bodies) const;

  void begin_frame() { frame_ = {}; }
  CollisionTelemetry end_frame(const Positions& x, const std::vector<KinematicBody>& bodies);
  const CollisionSettings& settings() const { return settings_; }
  bool self_collision() const { return any_self_; }
  bool gia() const { return gia_; }
  const BodyPinchTracker* pinch() const { return pinch_.get(); }

 private:
  struct BodyState {
    bool collide = true;
    Faces faces;
    FeatureOwnership own;
    AabbTree tree;
    std::vector<Aabb> boxes;
    Positions start, end;
    bool closed = false;        // watertight: GIA classifies cloth vertices inside it
    // GIA of the cloth against this body at the step's start (empty when not run):
    std::vector<char> inside;         // per cloth vertex: inside the body (coloured)
    // per body face: 3 all vertices in the body's coloured region (in intersection with the
    // cloth), 2 some vertex in it, 1 none but pierced by the cloth, 0 free
    std::vector<char> face_coloured;
    std::vector<char> cloth_face_contour;  // per cloth face: it and the body pierce each other
    void clear_gia() {
      inside.clear();
      face_coloured.clear();
      cloth_face_contour.clear();
    }
  };
  // GIA at the start of a step: colour cloth vertices inside closed bodies (their feature
  // pairs with that body are skipped: a one-way membrane) and push contour vertices out.
  // Returns whether the cloth is in intersection with some closed body (paths or vertices inside).
  bool gia_colour(const Positions& x);
  void gia_clear();
  void gia_recover();
  // Body/body pinch states for this step (body_pinch.h) and the cloth faces in a non-free
  // pair's region, per body: their pairs with that body get no CCD.
  void pinch_update();
  void pinch_grip(int p, const BodyState& state);
  bool pinched_vertex(int p, int body) const {
    return !pinch_held_.empty() && !pinch_held_[body].empty() && pinch_held_[body][p];
  }
  // Cloth/cloth GIA at the start of a step: analyse, then pull crossing edges back through.
  void gia_untangle();
  bool coloured(int p, int body) const {
    return p >= 0 && gia_ && !bodies_[body].inside.empty() && bodies_[body].inside[p];
  }
  // GIA body-side colouring of body face `f` (see BodyState::face_coloured; 0 when GIA is off).
  int body_face_colour(int f, int body) const {
    return gia_ && !bodies_[body].face_coloured.empty() ? bodies_[body].face_coloured[f] : 0;
  }
  bool cloth_face_contour(int f, int body) const {
    return gia_ && !bodies_[body].cloth_face_contour.empty() && bodies_[body].cloth_face_contour[f];
  }
  Vec3 start_of(int p, int body) const;
  Vec3 end_of(int p, int body) const;
  Vec3 velocity_of(int p, int body) const;
  double inverse_mass_of(int p) const { return p >= 0 ? inverse_mass_[p] : 0.0; }
  double pair_thickness(const FeaturePair& pair) const;
  double pair_friction(const FeaturePair& pair) const;

  // Broad phase over the current x and x + h v; fills pairs_.
  void collect_pairs();
  // Refit body `body`'s tree (swept over the step, or at its start) and put its overlapping
  // (cloth face, body face) pairs into scratch_pairs_.
  void body_triangle_pairs(int body, bool swept);
  void expand_triangle_pair(int cloth_face, int other_face, int body, std::vector<FeaturePair>& out) const;
  int proximity_pass();
  // CCD over pairs_; with apply, impulses are applied as hits are found (in pair order).
  // Incremental: only pairs with a cloth vertex whose velocity changed since the last pass (the
  // others keep their trajectories, so their earlier "no hit" stands).
  int ccd_pass(bool apply, std::vector<int>* hits, bool incremental);
  void apply_impulse(const FeaturePair& pair, const std::array<double, 4>& w, const Vec3& n, double delta_vn,
                     double friction);
  int impact_zones(std::vector<int>& hits);

  CollisionSettings settings_;
  const Faces cloth_faces_;
  int vertex_count_;
  int threads_;
  std::vector<double> inverse_mass_, vertex_thickness_, vertex_friction_;
  std::vector<char> face_collide_, face_self_;
  bool any_self_ = false, any_body_ = false, gia_ = false;
  std::vector<std::vector<int>> cloth_neighbours_;  // GIA contour test
  std::vector<char> vertex_collide_;                // GIA: on some body-colliding face
  Faces collide_faces_;                             // GIA: the cloth faces that collide with bodies
  std::vector<int> collide_face_ids_;               // their ids among all cloth faces
  ClothUntangling untangle_;  // cloth/cloth GIA (when gia_ and self-collision)
  FeatureOwnership cloth_own_;
  AabbTree cloth_tree_;
  std::vector<Aabb> cloth_boxes_;
  std::vector<double> face_margin_;
  std::vector<BodyState> bodies_;
  std::unique_ptr<BodyPinchTracker> pinch_;     // with GIA on and two or more collidable bodies
  std::vector<std::vector<char>> pinch_faces_;  // per body, per cloth face (empty: none)
  std::vector<std::vector<char>> pinch_held_;   // per body, per cloth vertex: in a pinch region (empty: none)
  std::vector<std::vector<char>> pinch_gripped_;  // per body, per cloth vertex: inside it and gripped by a pinch
  double default_thickness_ = 0.002;
  // GIA runs in a step only when the state may be in intersection: at the first step, after a
  // step whose analysis found something, whose collision stage left pairs unresolved or ran
  // without CCD for some pairs (a pinch), or after a frame whose exact count was not zero. A
  // step that starts intersection-free and ends with every pair resolved by CCD cannot create
  // an intersection, so the next analysis would find nothing.
  bool gia_due_ = true;

  // Per respond() call.
  const Positions* x_ = nullptr;
  Positions* v_ = nullptr;
  Positions x_end_;
  double h_ = 0.0;
  int frame_iteration_ = 0;  // CCD impulse pass within respond()
  std::vector<char> changed_;  // cloth vertices whose velocity changed since the last CCD pass
  struct SolveContact {
    int vertex;
    int body;
    Vec3 normal;
    Vec3 body_velocity;
    double delta_vn;  // normal velocity change the constraint prescribed
  };
  std::vector<SolveContact> solve_contacts_;  // this step's, for friction after the solve
  void body_positions(const std::vector<KinematicBody>& bodies, double alpha0, double alpha1);
  void contact_friction();
  std::vector<FeaturePair> pairs_;
  std::vector<std::pair<int, int>> scratch_pairs_;
  CollisionTelemetry frame_;
};

}  // namespace weft
