// The fail-safe of the collision stage (Provot 1995; Harmon et al. 2008): cloth vertices of
// pairs still colliding after the CCD passes are merged into zones that move rigidly, then the
// pairs are re-detected, until collision-free. Zones only grow, so this always ends.
#pragma once

#include <functional>
#include <vector>

#include "weft/collision/collision_step.h"

namespace weft {

class ImpactZones {
 public:
  // Passes in a row without fewer colliding pairs than the fewest so far after which the rest
  // of the budget is not spent (impact_zones.cpp).
  static constexpr int kStallPasses = 10;
  // A zone's affine field stretches its cloth by at most this fraction in one step: the step's
  // map I + h G has no singular value above 1 + kMaxZoneStretch (impact_zones.cpp).
  static constexpr double kMaxZoneStretch = 0.1;
  // hits: indices into step.pairs of the colliding pairs; after each pass of zone velocities
  // `redetect` refills it (detection and CCD against the new velocities). At most `iterations`
  // passes, fewer once kStallPasses passes in a row found no fewer hits; the hits left count as
  // unresolved. Returns the number of zones of the last pass.
  int resolve(CollisionStep& step, const ContactProperties& props, std::vector<int>& hits, int iterations,
              const std::function<void(std::vector<int>&)>& redetect, CollisionTelemetry& frame) const;
};

}  // namespace weft
