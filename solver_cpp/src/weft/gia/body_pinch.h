// Body/body pinch states (issue 6; Eberle 2018): kinematic bodies intersect each other at
// elbows, knees and armpits. Cloth caught between two intersecting bodies cannot be made
// collision-free, so CCD there only jitters or crushes the cloth through. Each pair of
// collidable bodies is tested exactly at the end of every step (global intersection analysis
// without colouring, plus the inside test for closed bodies); the result is kept for the next
// step, so over a step a pair is
//   free (no intersection at start or end), becoming pinched (no, yes), pinched (yes, yes) or
//   becoming unpinched (yes, no).
// For a non-free pair the region where the bodies intersect is kept as a box: the bounding box
// of the intersection volume, whose corners are the intersection curve's points (edge/face
// crossings) and the vertices of each body inside the other (closed bodies), over the step's
// start and end. The collision stage disables CCD between cloth touching that region (grown by
// the cloth thickness) and the pair's two bodies; proximity still acts.
#pragma once

#include <vector>

#include "weft/geometry/aabb_tree.h"
#include "weft/common/types.h"

namespace weft {

enum class PinchState : int { kFree = 0, kBecomingPinched = 1, kPinched = 2, kBecomingUnpinched = 3 };

// Exact body/body intersection at one configuration.
struct BodyIntersection {
  bool intersecting = false;  // surfaces cross, or (closed bodies) one has a vertex inside the other
  int hits = 0;               // edge/face crossings
  int paths = 0;              // intersection curves
  Aabb region;                // box of the intersection volume (empty when not intersecting)
};

// Bounding-box prefilter (boxes that do not overlap: free, no exact test), then the exact test.
BodyIntersection body_intersection(const Positions& xa, const Faces& fa, const Positions& xb, const Faces& fb,
                                   int threads = 0);

struct BodyPairPinch {
  int a = 0, b = 0;                   // body ids, a < b
  bool start = false, end = false;    // intersecting at the step's start / end
  Aabb start_region, end_region;      // where (empty when not intersecting)
  PinchState state() const {
    return start ? (end ? PinchState::kPinched : PinchState::kBecomingUnpinched)
                 : (end ? PinchState::kBecomingPinched : PinchState::kFree);
  }
  // The region over the step: both configurations' boxes together.
  Aabb region() const {
    Aabb r = start_region;
    r.expand(end_region);
    return r;
  }
};

// Per pair of the given bodies: the state over each step. The end-of-step result is stored and
// becomes the next step's start when the bodies start where they ended (the usual case, also
// across frames); otherwise (first step, keyframes that jump) the start is tested too. The
// answer is a function of the positions only, so a resumed run gets the same states.
class BodyPinchTracker {
 public:
  // bodies: ids (into the vectors passed to update) of the bodies taking part. group: per body
  // id, the articulated character it is a part of (empty, or -1: none); parts of one character
  // overlap at their joints by construction, so a pair of parts is never tracked as a pinch.
  BodyPinchTracker(std::vector<int> bodies, int threads, const std::vector<int>& group = {});

  // start/end: every body's positions (indexed by body id) at the step's start and end; faces
  // likewise. Returns the number of non-free pairs.
  int update(const std::vector<const Positions*>& start, const std::vector<const Positions*>& end,
             const std::vector<const Faces*>& faces);

  const std::vector<BodyPairPinch>& pairs() const { return pairs_; }
  int active_pairs() const;

  // Per cloth face: 1 when its box overlaps the region (grown by `margin`) of a non-free pair
  // with body `body`, else 0. Boxes are the broad phase's swept cloth boxes.
  void mark_faces(int body, const std::vector<Aabb>& cloth_boxes, double margin, std::vector<char>& out) const;
  // Per cloth vertex: 1 when it lies in the region (grown by `margin`) of a non-free pair with
  // body `body`. GIA recovery leaves these alone: pushed out of one body they would go into the
  // other, so they wait until the pair opens.
  void mark_vertices(int body, const Positions& x, double margin, std::vector<char>& out) const;

 private:
  std::vector<int> bodies_;
  int threads_;
  std::vector<Positions> last_end_;  // per body id: positions at the end of the last update
  std::vector<BodyPairPinch> pairs_;
};

}  // namespace weft
