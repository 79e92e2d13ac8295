// The collision stage of a step (Bridson, Fedkiw & Anderson 2002, with the fail-safe of
// Provot 1995 / Harmon et al. 2008): after the velocity solve, with x the start-of-step
// positions and v the new velocities (so the step moves x to x + h v), the CollisionSystem
// runs its parts over one CollisionStep (collision/collision_step.h):
//   0. GIA (when on and due): cloth coloured inside closed bodies and pushed out
//      (gia/gia_body_driver.h), body/body pinch states (gia/pinch_driver.h), cloth/cloth
//      untangling (gia/cloth_untangling.h);
//   1. contact detection (collision/contact_detection.h): refit the AABB trees, collect
//      triangle pairs cloth/body and cloth/cloth, expand them into feature pairs, each once;
//   2. proximity (collision/proximity_response.h): repulsion impulses with friction;
//   3. CCD (collision/ccd_response.h): iterated inelastic impulses until no pair collides or
//      the iteration budget is spent;
//   4. rigid impact zones (collision/impact_zones.h) for what is left, re-detected until
//      collision-free.
// Kinematic bodies and pinned vertices have infinite mass.
#pragma once

#include <functional>
#include <memory>
#include <utility>
#include <vector>

#include "weft/bodies/bodies.h"
#include "weft/collision/ccd_response.h"
#include "weft/collision/collision_step.h"
#include "weft/collision/collision_types.h"
#include "weft/collision/contact_constraints.h"
#include "weft/collision/strain_limit.h"
#include "weft/collision/contact_detection.h"
#include "weft/gia/body_pinch.h"
#include "weft/gia/cloth_untangling.h"
#include "weft/linear_system/pcg.h"

namespace weft {

// Kinetic friction goes through the cloth's response (spread_friction_with) only from contacts
// that slid less than this many thicknesses along their body over the step.
constexpr double kSpreadSlide = 3.0;

class GiaBodyDriver;
class PinchDriver;

class CollisionSystem {
 public:
  CollisionSystem(const Faces& cloth_faces, const Positions& x, const std::vector<double>& vertex_mass,
                  const std::vector<int>& pinned_vertices, const std::vector<KinematicBody>& bodies,
                  CollisionSettings settings, int threads,
                  const std::vector<std::array<double, 3>>& face_rest_lengths = {});
  ~CollisionSystem();

  // Threads of the coming steps (at least 1); the results are the same for any count.
  void set_threads(int threads);

  // Released pins get their mass back: they take impulses like any cloth vertex.
  void release_pins(const std::vector<int>& vertices, const std::vector<double>& vertex_mass);

  // Adjusts v so that x + h v is collision-free. Bodies move from alpha0 to alpha1 of the frame.
  void respond(const Positions& x, Positions& v, double h, const std::vector<KinematicBody>& bodies, double alpha0,
               double alpha1);

  // Before the solve: cloth/body contacts as constraints of the filtered solve
  // (collision/contact_constraints.h); friction for them is applied in respond().
  void constrain_contacts(const Positions& x, const Positions& v, double h, const std::vector<KinematicBody>& bodies,
                          double alpha0, double alpha1, ConstraintFilter& filter);
  // After the solve: whether it had contact constraints, and their impulses from the solved
  // system's residual b - A dv (a contact that pulled is released for the next step).
  bool has_contact_constraints() const { return !constraints_.empty(); }
  void contact_impulses(const VectorX& residual) { frame_.released_contacts += constraints_.impulses(residual); }

  // Exact count of intersecting triangle pairs at x (cloth/body for collidable bodies, cloth/cloth
  // among self-colliding faces), over the broad phase's trees with self-culling (refits them).
  // cloth_cloth: where given, receives the cloth/cloth part of the count.
  int count_intersections(const Positions& x, const std::vector<KinematicBody>& bodies, int* cloth_cloth = nullptr);

  // Colliding pairs left unresolved so far this frame; a retried step's are taken back.
  int unresolved() const { return frame_.unresolved; }
  void rewind_unresolved(int count) { frame_.unresolved = count; }
  // Impact-zone passes allowed per step (0: the settings' budget).
  void limit_zone_passes(int passes) { zone_pass_limit_ = passes; }
  // A test of the step's end positions after each CCD pass (null: none): once it says so, the
  // step's response stops there and abandoned() is true until the next respond(). The
  // integrator passes its halving test (a torn edge), so an attempt it will redo as halves
  // spends no more passes or impact zones on a result it throws away.
  void abandon_when(std::function<bool(const Positions&)> test) { abandon_test_ = std::move(test); }
  bool abandoned() const { return abandoned_; }
  // The cloth's response to impulses in one implicit step (null: none): response(impulse,
  // velocity_change), both 3 entries per cloth vertex, velocity_change zero along what the
  // step's solve held (Simulation: LinearSystemPath::solve_response). Where kinetic friction
  // applied to single held vertices lengthens an edge beyond the strain limit's allowed length,
  // respond() passes its impulses through it instead, so the held vertices' neighbours come
  // along: friction acts on the cloth, not on the vertex alone; only for contacts sliding less
  // than kSpreadSlide thicknesses over the step (docs/collisions.md, thirty-fifth session).
  void spread_friction_with(std::function<void(const VectorX&, VectorX&)> response) {
    friction_response_ = std::move(response);
  }
  void begin_frame() { frame_ = {}; }
  // The contact constraints' per-vertex decisions of the last step (ContactConstraints::flags):
  // part of the state a resumed run restores.
  std::vector<std::uint8_t> contact_flags() const { return constraints_.flags(); }
  void set_contact_flags(const std::vector<std::uint8_t>& flags, int vertex_count) {
    constraints_.set_flags(flags, vertex_count);
  }
  // What the next step's analysis is due to do, as the last step (or frame end) left it:
  // {gia_due_, self_due_, gia_all_bodies_, contacts_aside_, then gia_watch_ per body}, each 0
  // or 1. Part of the state a resumed run restores: a new system starts with the analysis due
  // on every body (a shot's first step), which a run resumed from a clean frame would not
  // repeat bit for bit. Pinch tracking (body_pinch.h) is not in it.
  std::vector<std::uint8_t> analysis_flags() const;
  // Throws std::invalid_argument unless flags is empty (keep the new system's) or has 4 + body
  // count entries, each 0 or 1.
  void set_analysis_flags(const std::vector<std::uint8_t>& flags);
  void check_analysis_flags(const std::vector<std::uint8_t>& flags) const;
  CollisionTelemetry end_frame(const Positions& x, const std::vector<KinematicBody>& bodies);
  // At a frame's start (the bodies' keyframes set): the halvings, at most max_halvings, after
  // which no collidable closed body moves relative to the cloth within its reach by more than
  // its thickness in one piece of a substep (bodies/body_motion.h). From the frame's state
  // only (x, v, keyframes): a resumed run decides the same.
  int motion_halvings(const Positions& x, const Positions& v, const std::vector<KinematicBody>& bodies, int substeps,
                      double frame_duration, int max_halvings) const;
  const CollisionSettings& settings() const { return settings_; }
  bool self_collision() const { return detection_.any_self(); }
  std::pair<double, double> cloth_tree_quality(const Positions& x) const { return detection_.cloth_tree_quality(x); }
  bool gia() const { return gia_; }
  // Whether the next step may start in intersection or in an engaged pinch (GIA is due).
  bool recovering() const { return gia_due_; }
  const BodyPinchTracker* pinch() const;

 private:
  class Filter;
  void body_positions(const std::vector<KinematicBody>& bodies, double alpha0, double alpha1);
  // Detection and CCD against the current velocities (the impact zones' re-detection).
  void redetect(std::vector<int>& hits);
  // aside_ after the step that just ended: the corners of the cloth faces in a pinch region or
  // with a vertex GIA coloured inside a body, and of every face around a face piercing a body, a
  // face tangled with other cloth or a cloth vertex of a pair left unresolved (given).
  void mark_aside(const std::vector<int>& unresolved_vertices);

  CollisionSettings settings_;
  int threads_;
  ContactProperties props_;
  ContactDetection detection_;
  bool gia_ = false;
  // GIA runs in a step only when the state may be in intersection: at the first step, after a
  // step whose analysis found something, whose collision stage left pairs unresolved or ran
  // without CCD for some pairs (a pinch), or after a frame whose exact count was not zero. A
  // step that starts intersection-free and ends with every pair resolved by CCD cannot create
  // an intersection, so the next analysis would find nothing.
  bool gia_due_ = true;
  // Of a due analysis, the cloth/cloth part (the costlier one on a garment): only after a step
  // whose untangling found something or that left cloth/cloth pairs unresolved (or ran without
  // CCD), and after an exact count that found cloth/cloth intersections; at the first step.
  bool self_due_ = true;
  // Of a due analysis (and of the pinch driver's faces-through test), the bodies the cloth may
  // have entered: all of them at the first step, after a step that left pairs unresolved, ran
  // without CCD or left a cloth/cloth tangle, and after a frame whose exact count was not zero;
  // otherwise (a step whose only exceptions were pinch regions and GIA's membranes) the bodies
  // CCD did not guard in it: those whose pinch region held cloth faces (no CCD there) or that
  // its analysis found in intersection (membranes open) - gia_watch_ - and, for the analysis,
  // those whose pinch region holds cloth now. Every other body's pairs all went through CCD
  // and were resolved, so the cloth cannot be in it; it answers as analysed with nothing found.
  bool gia_all_bodies_ = true;
  std::vector<char> gia_watch_, gia_only_;
  std::vector<char> body_closed_;  // per body: a closed surface (has a thickness for motion_halvings)
  std::unique_ptr<GiaBodyDriver> gia_bodies_;  // with GIA on
  std::unique_ptr<PinchDriver> pinch_;         // with GIA on and two or more collidable bodies
  ClothUntangling untangle_;                   // cloth/cloth GIA (with GIA on and self-collision)
  std::unique_ptr<Filter> filter_;
  CcdResponse ccd_;
  bool contacts_aside_ = false;  // contact constraints left to the impulses (constrain_contacts)
  // contacts_aside_ within a frame, for the cloth near what set it only (local_aside, with CCD
  // on, no body/body pinch engaged): mark_aside's faces. Their corners are set aside (aside_);
  // the rest of the cloth keeps its constraints. False after a frame that ended in
  // intersection: all set aside.
  bool aside_local_ = false;
  std::vector<char> aside_;
  Positions velocity_before_limit_;  // scratch: v before the strain limit, while a vertex sticks
  int zone_pass_limit_ = 0;
  std::function<bool(const Positions&)> abandon_test_;
  bool abandoned_ = false;
  StrainLimit strain_limit_;  // with settings_.max_strain and the cloth's rest lengths
  std::vector<Vec3> contact_normals_;  // respond(): per cloth vertex, its contact's normal (strain_limit_)
  std::function<void(const VectorX&, VectorX&)> friction_response_;  // spread_friction_with
  // Kinetic friction's velocity changes through friction_response_ where, applied to the held
  // vertices alone, they lengthened an edge beyond its allowed length (respond()).
  void spread_friction(const Positions& x, Positions& v, double h);
  std::vector<Vec3> friction_end_change_;  // spread_friction scratch: per cloth vertex
  std::vector<const ContactConstraints::FrictionChange*> friction_spread_;  // spread_friction scratch
  VectorX friction_impulse_, friction_velocity_;
  ContactConstraints constraints_;
  CollisionStep step_;
  CollisionTelemetry frame_;
};

}  // namespace weft
