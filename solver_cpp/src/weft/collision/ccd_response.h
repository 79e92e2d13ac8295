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
// A contact's time is found to this fraction of the step (CcdOptions::hit_time_resolution):
// a certain contact in a box this short is reported at the box's start, a lower bound of its
// time. Narrowing it further to CCD's tolerance cost hundreds of boxes per contact (on
// `weft bench contact`'s dress, 96% of the boxes went to hits) for an impulse that hardly changes.
constexpr double kCcdHitTimeResolution = 1.0 / 16.0;

class CcdResponse {
 public:
  explicit CcdResponse(int threads = 1) : threads_(threads) {}
  void set_threads(int threads) { threads_ = threads; }
  // CCD over step.pairs (in parallel); with apply, impulses are applied to the hits in pair
  // order, each re-tested with the velocities of the moment if an earlier impulse of the pass
  // moved one of its points. A hit that its impulse at the reported time would not change (it
  // separates there, yet turns into contact later) gets its impulse where the features cross;
  // failing that its points are marked changed, so the next pass tests it again. Incremental: only pairs with a
  // cloth vertex whose velocity changed since the last pass (step.changed; the others keep
  // their trajectories, so their earlier "no hit" stands). Without apply (detection only, the
  // impact zones' re-detection) a pair that starts within the minimum separation and never
  // crosses is not a hit. Hit pair indices go to `hits`. Returns the number of hits.
  int pass(CollisionStep& step, const ContactProperties& props, bool apply, std::vector<int>* hits, bool incremental,
           CollisionTelemetry& frame) const;

 private:
  int threads_;
};

}  // namespace weft
