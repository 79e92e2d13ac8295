// Where a frame's substeps start in adaptive substepping: how many halvings deep.
//
// A substep that leaves pairs unresolved or tears an edge is redone as two halves
// (Simulation::substep). What made it fail - a limb sweeping through the cloth, a fold
// collapsing - usually lasts beyond it, and the next full substep then fails the same way:
// its abandoned attempt costs a solve and a collision stage for nothing. So a substep that
// needed a halving makes the next one start one level deeper, and one that ran at its level
// without a halving lets the next start one level higher again: the step size follows the
// trouble within a frame, one level per substep. The deepest start is the deepest level
// (max_halvings): a piece there cannot be halved and is taken as it ends, which is also what
// becomes of the halves of a piece one level up that failed, so starting there gives the same
// pieces without that piece's attempt thrown away first. (Until the thirty-seventh session the
// deepest start kept a halving in reserve, and a trouble that needed the deepest pieces threw
// away an attempt one level up for every two of them.)
#pragma once

#include <algorithm>

namespace weft {

class SubstepLevel {
 public:
  // `floor`: the fewest halvings any substep of the frame starts at (0: whole), known before the
  // frame from how fast its bodies move (CollisionSystem::motion_halvings); at most the deepest
  // start.
  explicit SubstepLevel(int max_halvings, int floor = 0)
      : deepest_start_(std::max(0, max_halvings)), floor_(std::clamp(floor, 0, deepest_start_)), start_(floor_) {}
  // Halvings the next substep starts at: it is taken as 2^start() pieces.
  int start() const { return start_; }
  // The substep just taken: `deepest` is the deepest halving one of its pieces needed
  // (start() when none was halved).
  void finished(int deepest) {
    start_ = deepest > start_ ? std::min(start_ + 1, deepest_start_) : std::max(start_ - 1, floor_);
  }

 private:
  int deepest_start_;
  int floor_;
  int start_;
};

}  // namespace weft
