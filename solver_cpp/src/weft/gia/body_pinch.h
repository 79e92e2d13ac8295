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
//
// Parts of one articulated character overlap at their joints by construction: their
// intersection is no pinch. A pair of parts is tracked instead by where the two surfaces, each
// outside the other, face each other closer than the cloth can lie between them (part_gap.h):
// that near region is the pair's region, with the same states.
#pragma once

#include <vector>

#include "weft/geometry/aabb_tree.h"
#include "weft/common/types.h"
#include "weft/gia/part_gap.h"

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
  bool parts = false;                 // parts of one character: tracked by their facing gap
  double gap = 0.0;                   // parts: the gap the cloth needs between them
  // Parts: the one the cloth may pass into while they close on it (the smaller, by volume,
  // decided when first tested; -1 before): CCD stays on against the other, so the cloth
  // squeezed between an arm and the torso stays outside the torso and the arm passes through
  // it. Bodies that are not parts: -1, CCD off against both.
  int yields = -1;
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

// Whether `body` gives way to the cloth in pair p's region: CCD against it is off there.
inline bool gives_way(const BodyPairPinch& p, int body) {
  return (p.a == body || p.b == body) && (!p.parts || p.yields == body);
}

// What a tracker follows.
struct PinchTracking {
  // Per body id, the articulated character it is a part of (empty, or -1: none).
  std::vector<int> group;
  // Pairs of bodies that are not parts of one character, by their intersection.
  bool body_pairs = true;
  // > 0: pairs of parts of one character, by their facing gap: part_gap plus both parts'
  // offsets (body_offset, per body id; empty: none). The collision stage passes two cloth
  // thicknesses (cloth held a thickness off each surface).
  double part_gap = 0.0;
  std::vector<double> body_offset;
};

// Per pair of the given bodies: the state over each step. The end-of-step result is stored and
// becomes the next step's start when the bodies start where they ended (the usual case, also
// across frames); otherwise (first step, keyframes that jump) the start is tested too. The
// answer is a function of the positions only, so a resumed run gets the same states.
class BodyPinchTracker {
 public:
  // bodies: ids (into the vectors passed to update) of the bodies taking part.
  BodyPinchTracker(std::vector<int> bodies, int threads, const PinchTracking& tracking = {});

  // start/end: every body's positions (indexed by body id) at the step's start and end; faces
  // likewise. Returns the number of non-free pairs.
  int update(const std::vector<const Positions*>& start, const std::vector<const Positions*>& end,
             const std::vector<const Faces*>& faces);

  const std::vector<BodyPairPinch>& pairs() const { return pairs_; }
  int active_pairs() const;
  void set_threads(int threads) { threads_ = threads; }

  // Per cloth face: 1 when its box overlaps the region (grown by `margin`) of a non-free pair
  // in which body `body` gives way (gives_way), else 0. Boxes are the broad phase's swept cloth boxes. only: per pair,
  // the pairs to look at (null: all).
  void mark_faces(int body, const std::vector<Aabb>& cloth_boxes, double margin, std::vector<char>& out,
                  const std::vector<char>* only = nullptr) const;
  // Per cloth vertex: 1 when it lies in the region (grown by `margin`) of a non-free pair in
  // which body `body` gives way. GIA recovery leaves these alone: pushed out of one body they would go into the
  // other, so they wait until the pair opens.
  void mark_vertices(int body, const Positions& x, double margin, std::vector<char>& out,
                     const std::vector<char>* only = nullptr) const;

 private:
  // The wanted pairs' states at configuration x into out (per pair; the rest left empty).
  // Part pairs fit their parts' surfaces (start or end) there.
  void evaluate(const std::vector<const Positions*>& x, const std::vector<const Faces*>& faces,
                std::vector<PartSurface>& surfaces, const std::vector<char>& wanted,
                std::vector<BodyIntersection>& out);

  std::vector<int> bodies_;
  int threads_;
  double half_gap_ = 0.0;            // half the largest part pair's gap: the surfaces' box growth
  std::vector<Positions> last_end_;  // per body id: positions at the end of the last update
  std::vector<BodyPairPinch> pairs_;
  std::vector<PartSurface> start_surfaces_, end_surfaces_;  // per body id (part pairs)
};

}  // namespace weft
