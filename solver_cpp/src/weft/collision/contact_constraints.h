// Cloth/body contacts as constraints of the filtered solve (CollisionSettings::
// contact_constraints): before the solve, every free cloth vertex within the thickness of a
// collidable body face and not moving away from it gets its normal velocity relative to the
// body prescribed (to a small push back out), a constraint of the pre-filtered solve (pcg.h).
// Friction for these contacts is applied after the solve, with the constraint's velocity
// change as the normal impulse.
#pragma once

#include <vector>

#include "weft/collision/collision_step.h"
#include "weft/collision/contact_detection.h"
#include "weft/linear_system/pcg.h"

namespace weft {

class ContactConstraints {
 public:
  // step.body_start/body_end must hold the step's body positions; x, v the solve's state.
  void constrain(const Positions& x, const Positions& v, double h, const CollisionStep& step,
                 ContactDetection& detection, const ContactProperties& props, ConstraintFilter& filter,
                 CollisionTelemetry& frame);
  // After the solve: Coulomb friction of this step's contacts on step.v.
  void friction(CollisionStep& step, const ContactProperties& props) const;
  void clear() { contacts_.clear(); }

 private:
  struct Contact {
    int vertex;
    int body;
    Vec3 normal;
    Vec3 body_velocity;
    double delta_vn;  // normal velocity change the constraint prescribed
  };
  std::vector<Contact> contacts_;
};

}  // namespace weft
