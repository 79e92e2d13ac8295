// Body/body pinches in the collision stage (body_pinch.h): per step, the pinch state of every
// pair of collidable bodies, the cloth faces whose pairs with a body get no CCD (in an engaged
// pair's region, or already through the body), the cloth vertices GIA recovery must leave
// alone (held), and the cloth gripped by a body while a pinch squeezes it. A non-free pair of
// bodies is engaged; a non-free pair of parts of one character (their facing gap, part_gap.h)
// only while cloth is in its region: an armpit with no cloth in it changes nothing.
#pragma once

#include <vector>

#include "weft/collision/collision_step.h"
#include "weft/collision/contact_detection.h"
#include "weft/gia/body_pinch.h"

namespace weft {

class PinchDriver {
 public:
  // bodies: ids of the collidable bodies (two or more), ascending, among body_count.
  PinchDriver(std::vector<int> bodies, int body_count, int vertex_count, int threads,
              const PinchTracking& tracking = {});

  // At the step's start (step.x, step.x_end and the bodies' positions set). Refits the
  // detection's cloth tree over the step when a pair is not free or unclean. unclean: the last step may have left cloth in
  // intersection (GIA due); only then, or while a pair is engaged, can a cloth face be through
  // a body, and only then is that looked for.
  // through: the bodies a cloth face may be through (the others' pairs all went through CCD in
  // the last step and were resolved); null: every body.
  void update(CollisionStep& step, ContactDetection& detection, double default_thickness, bool unclean,
              CollisionTelemetry& frame, const std::vector<char>* through = nullptr);
  // Cloth face in a pinch region of `body` (or through it): no CCD against it.
  bool face_in_region(int cloth_face, int body) const {
    return !faces_.empty() && !faces_[body].empty() && faces_[body][cloth_face];
  }
  // No pinch region of `body`: face_in_region is false for every face.
  bool no_region(int body) const { return faces_.empty() || faces_[body].empty(); }
  // Some cloth face is in a pinch region of `body` (or through it) in this step: its pairs with
  // `body` get no CCD. no_region() can be false while none is (a region clear of cloth).
  bool marks_faces(int body) const { return !marked_.empty() && marked_[body]; }
  // Cloth vertex in the region of an engaged pair of bodies (not parts) with `body`.
  bool held(int p, int body) const { return !held_.empty() && !held_[body].empty() && held_[body][p]; }
  // Cloth vertex p in an engaged region of a pair of parts in which `body` gives way: GIA
  // recovery does not push it out of `body` (the part passes over the squeezed cloth).
  bool squeezed(int p, int body) const {
    return !squeezed_.empty() && !squeezed_[body].empty() && squeezed_[body][p];
  }
  // Per cloth vertex: inside `body` and gripped by a pinch (kept by GIA recovery).
  std::vector<char>& gripped(int body) { return gripped_[body]; }
  // Cloth vertex p moves with the closest point of the body (faces, positions at the step's
  // start and end): squeezed into a body by another, it moves with it as friction would hold it.
  void grip(int p, const Faces& faces, const Positions& start, const Positions& end, CollisionStep& step,
            CollisionTelemetry& frame) const;
  const BodyPinchTracker& tracker() const { return tracker_; }
  void set_threads(int threads) { tracker_.set_threads(threads); }
  // Engaged pairs after the last update: the collision stage hands contact to GIA meanwhile.
  int engaged_pairs() const { return engaged_count_; }
  // Of those, the pairs of parts of one character.
  int engaged_part_pairs() const { return engaged_parts_; }

 private:
  BodyPinchTracker tracker_;
  std::vector<char> engaged_;
  int engaged_count_ = 0, engaged_parts_ = 0;
  std::vector<std::vector<char>> faces_;    // per body, per cloth face (empty: none)
  std::vector<char> marked_;                // per body: some face of faces_ set
  std::vector<std::vector<char>> held_;     // per body, per cloth vertex (empty: none)
  std::vector<std::vector<char>> squeezed_;  // per body, per cloth vertex (empty: none)
  std::vector<std::vector<char>> gripped_;  // per body, per cloth vertex
};

}  // namespace weft
