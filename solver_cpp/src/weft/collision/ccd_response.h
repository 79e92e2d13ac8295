// CCD response (Bridson, Fedkiw & Anderson 2002): feature pairs that touch during the step
// (conservative CCD, ccd.h) get inelastic impulses that leave them a small separation at the
// end; the collision system repeats passes until none collides or its budget is spent.
#pragma once

#include <vector>

#include "weft/collision/collision_step.h"

namespace weft {

// CCD reports pairs that come closer than kCcdSeparationFraction of the thickness
// (collision_step.h), and its impulses aim for this separation at the end of the step.
constexpr double kTargetSeparationFraction = 0.1;

class CcdResponse {
 public:
  explicit CcdResponse(int threads = 1) : threads_(threads) {}
  // CCD over step.pairs (in parallel); with apply, impulses are applied to the hits in pair
  // order, each re-tested with the velocities of the moment. Incremental: only pairs with a
  // cloth vertex whose velocity changed since the last pass (step.changed; the others keep
  // their trajectories, so their earlier "no hit" stands). Hit pair indices go to `hits`.
  // Returns the number of hits.
  int pass(CollisionStep& step, const ContactProperties& props, bool apply, std::vector<int>* hits, bool incremental,
           CollisionTelemetry& frame) const;

 private:
  int threads_;
};

}  // namespace weft
