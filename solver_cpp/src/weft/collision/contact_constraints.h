// Cloth/body contacts as constraints of the filtered solve (Baraff & Witkin 1998; the
// pre-filtered PCG of Tamstorf et al. 2015, pcg.h), so the solve itself returns velocities that
// respect resting contact and CCD is only the last guard.
//
// Before the solve, every free cloth vertex within two thicknesses of a collidable body face
// (the closest) gets its normal velocity relative to the face prescribed when it approaches
// faster than a target, or when the last solve held it with a pushing impulse (resting cloth is
// pressed by forces the velocity before the solve does not show): at or inside the thickness
// the target is a push back out of kRepulsionRate of the missing separation per step, beyond it
// the speed that ends the step at the thickness. After the solve
// the residual gives each constraint's normal impulse; a constraint that pulled the cloth
// towards the body (negative impulse: the cloth wants to leave) is released for the next step,
// so cloth lifts off freely instead of alternating between held and free. Coulomb friction
// uses that impulse as the normal impulse, after the solve while the vertex slides; a held
// vertex that friction stopped sticks in the next solve (static friction as a full constraint,
// Baraff & Witkin 1998), until its tangential impulse leaves the cone or the normal one pulls.
// Friction after the solve acts on the vertex alone while its neighbours, solved without it,
// move on; two rules keep it from dragging cloth that a fast body carries:
//  - a vertex contact's first step is an impact: its normal impulse also stops the vertex's
//    approach, and that share does not bound its friction, nor does a stop in that step make
//    it stick;
//  - a vertex sticks only when the slide friction stopped was shorter than its thickness over
//    the step: sticking is a rest state, and a vertex stopped from sliding faster (cloth over
//    a limb moving at metres per second) would be carried rigidly by the body for a whole step
//    before the friction cone can let it go.
// A sheet swept by a 3 cm limb at 3 m/s reached edges 3.3x their rest length without them
// (1.5x with them; docs/collisions.md, twenty-fourth session).
// These decisions carry over frame boundaries (resting cloth rests on); a cache keeps them.
// The collision system uses them only while the state is clean: while GIA or a pinch is at
// work, the impulses take over (collision_system.cpp).
//
// Cloth edges get contacts too where a body edge is sharp enough to catch one between its ends
// (sharp_edges.h: a coarse sheet on a thin limb, a strap over a box corner). Such an edge, with
// no vertex contact at either end, gets its closest sharp body edge within the band, and both
// ends are prescribed the normal speed the rule above gives its contact point: a straight edge
// whose ends move alike along the normal moves so at every point. Without them the solve pulls
// a hooked edge into the body every step and CCD pushes it back (a sheet on a 3 cm limb spent
// 98% of its step in CCD and stretched single edges 27x).
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "weft/collision/collision_step.h"
#include "weft/collision/contact_detection.h"
#include "weft/collision/sharp_edges.h"
#include "weft/linear_system/pcg.h"

namespace weft {

class ContactConstraints {
 public:
  // step.body_start/body_end must hold the step's body positions; x, v the solve's state.
  // aside: per cloth vertex, 1 where no constraint may act (cloth a part pinch squeezes or a
  // body holds coloured inside it: collision_system.cpp); null: none.
  void constrain(const Positions& x, const Positions& v, double h, const CollisionStep& step,
                 ContactDetection& detection, const ContactProperties& props, ConstraintFilter& filter,
                 CollisionTelemetry& frame, const std::vector<char>* aside = nullptr);
  // After the solve, residual = b - A dv of the solved system: each contact's normal impulse;
  // contacts that pulled are released for the next step. Returns how many pulled.
  int impulses(const VectorX& residual);
  // After the solve: Coulomb friction of this step's contacts on step.v, except those the solve
  // held as sticking; marks the held contacts friction stopped (they stick in the next solve).
  // Each vertex's velocity change from it is listed in friction_changes() (kinetic friction
  // only: a sticking vertex is held by the solve), in contact order.
  void friction(CollisionStep& step, const ContactProperties& props);
  struct FrictionChange {
    int vertex;
    Vec3 change;   // of its velocity
    double slide;  // how far it slid along the body over the step before friction, m
  };
  const std::vector<FrictionChange>& friction_changes() const { return friction_changes_; }
  // Per cloth vertex (vertex_count entries): the outward normal of the body face this step's
  // constraint held it against, zero for a vertex without one. The strain limit moves such a
  // vertex along the body, not into it (strain_limit.h).
  void contact_normals(int vertex_count, std::vector<Vec3>& normals) const;
  bool any_stuck() const { return std::find(stuck_.begin(), stuck_.end(), 1) != stuck_.end(); }
  // After friction: a vertex marked sticking whose velocity changed from before to after (the
  // strain limit moved it) does not stick in the next solve.
  void unstick_changed(const Positions& before, const Positions& after) {
    for (size_t i = 0; i < stuck_.size(); ++i)
      if (stuck_[i] && before.row(static_cast<Eigen::Index>(i)) != after.row(static_cast<Eigen::Index>(i))) stuck_[i] = 0;
  }
  void clear() {
    contacts_.clear();
    looked_ = false;
  }
  // Drops what the last steps decided (held, released, sticking): while contacts are set aside.
  void forget() {
    std::fill(held_.begin(), held_.end(), 0);
    std::fill(released_.begin(), released_.end(), 0);
    std::fill(stuck_.begin(), stuck_.end(), 0);
  }
  // What the last step decided, per cloth vertex: kHeld (constrained with a pushing impulse: the
  // next step keeps its contact), kStuck (held, and friction stopped it on the body: the next
  // solve prescribes all its velocity), kReleased (its constraint pulled: free for the next
  // step) or 0; empty before the first step. It carries over frame boundaries, so a cache
  // keeps it with the state and a resumed run restores it (set_flags).
  static constexpr std::uint8_t kHeld = 1, kReleased = 2, kStuck = 3;
  std::vector<std::uint8_t> flags() const;
  // Throws std::invalid_argument unless flags is empty (nothing decided) or has vertex_count
  // entries, each 0, kHeld, kReleased or kStuck.
  void set_flags(const std::vector<std::uint8_t>& flags, int vertex_count);
  bool empty() const { return contacts_.empty(); }
  // Per body, after this step's constrain() (null before it, or when it did not run): its
  // edges sharp for the cloth (sharp_edges.h). Every free cloth vertex within the band of a
  // body had its nearest face looked at and, where it approached, its normal speed set by the
  // solve, and a cloth edge between two vertices kept off sags at most half a separation
  // towards an edge that is not sharp (that is what "not sharp" means) unless that edge pushes
  // into the cloth faster than the linearized contacts follow (SharpEdges::advancing): the
  // proximity list needs edge/edge pairs with the sharp and the pushing edges only; on a draped
  // sheet edge pairs are most of the list (ContactDetection::collect; CCD still tests every pair).
  const std::vector<SharpEdges>* sharp_edges() const { return looked_ ? &sharp_ : nullptr; }
  // Per cloth vertex, after this step's constrain() (null otherwise): 1 where the vertex is free
  // and no collidable body face was within its separation (ContactProperties::body_separation)
  // at the step's start. The search looked at every face within it, so such a vertex has no
  // vertex/face proximity pair that the response would act on, and the proximity list skips it.
  const std::vector<char>* clear_vertices() const { return looked_ ? &clear_ : nullptr; }

 private:
  struct Contact {
    int vertex;
    int body;
    Vec3 normal;
    Vec3 body_velocity;
    double delta_vn;      // normal velocity change the constraint prescribed
    double impulse = 0.0;  // normal impulse the constraint applied (after the solve), >= 0
    bool stuck = false;    // static friction: all three directions prescribed (sticks to the body)
    bool slides = false;   // stuck, but its tangential impulse left the friction cone
    Vec3 stuck_dv = Vec3::Zero();  // the velocity change prescribed when stuck
    double friction = 0.0;         // the vertex's Coulomb coefficient
    // New this step (not held by the last): the momentum that stops its approach, m max(0, -vn)
    // with vn the normal velocity relative to the body before the solve; 0 for a held contact.
    bool fresh = false;
    double impact = 0.0;
  };
  // A cloth edge's closest sharp body edge within the band.
  struct EdgeNear {
    int a, b;   // the cloth edge's vertices
    double s;   // its contact point (1 - s) a + s b
    double distance;
    int body;
    Vec3 normal, body_velocity;
  };
  // The closest sharp body edge of every cloth edge both of whose ends are open_end.
  std::vector<EdgeNear> edge_contacts(const Positions& x, double h, const CollisionStep& step,
                                      const ContactDetection& detection, const ContactProperties& props,
                                      const std::vector<char>& open_end);

  std::vector<Contact> contacts_;
  std::vector<FrictionChange> friction_changes_;  // the last friction()'s
  std::vector<char> released_;  // per cloth vertex: its constraint pulled last step, free this step
  std::vector<char> held_;      // per cloth vertex: constrained last step with a pushing impulse
  std::vector<char> stuck_;     // per cloth vertex: held, and static friction stopped it last step
  std::vector<SharpEdges> sharp_;  // per body
  std::vector<char> clear_;        // per cloth vertex: clear_vertices()
  bool looked_ = false;            // constrain() ran since the last clear()
  // Searches a vertex can skip (constrain()): per (cloth vertex, colliding body) how much
  // farther than the search could accept every face of the body lay at the last call, less the
  // vertex's and the body's motion since (-inf: unknown); and the last call's positions, which
  // that motion is measured from. A cache: the contacts found are the same without it.
  std::vector<double> far_margin_;
  Positions last_x_;
  std::vector<Positions> last_body_x_;
  double thinnest_ = 0.0, thickest_ = 0.0;  // cloth vertex thicknesses, for the sharp edges
};

}  // namespace weft
