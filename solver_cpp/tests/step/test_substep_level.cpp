#include <gtest/gtest.h>

#include "weft/substep_level.h"

namespace weft {
namespace {

TEST(SubstepLevel, ASubstepThatWasHalvedMakesTheNextStartHalved) {
  SubstepLevel level(2);
  EXPECT_EQ(level.start(), 0);
  level.finished(0);  // ran whole
  EXPECT_EQ(level.start(), 0);
  level.finished(1);  // had to be halved
  EXPECT_EQ(level.start(), 1);
  level.finished(1);  // ran at its level without a halving: the next goes one level up
  EXPECT_EQ(level.start(), 0);
}

TEST(SubstepLevel, OneLevelAtATimeDownToTheDeepestLevel) {
  SubstepLevel level(3);
  level.finished(3);  // needed three halvings: the next starts one level deeper, not three
  EXPECT_EQ(level.start(), 1);
  level.finished(3);
  EXPECT_EQ(level.start(), 2);
  level.finished(3);  // the deepest level: its pieces cannot be halved, and are what a failing
  EXPECT_EQ(level.start(), 3);  // piece one level up would have been halved into
  level.finished(3);  // ran there without a halving (none is possible there): one level up
  EXPECT_EQ(level.start(), 2);
  level.finished(2);
  EXPECT_EQ(level.start(), 1);
  level.finished(1);
  EXPECT_EQ(level.start(), 0);
}

TEST(SubstepLevel, ATroubleThatNeedsTheDeepestPiecesThrowsAwayFewerAttempts) {
  // Every substep of a trouble needs pieces 2 levels deep (the default solver.max_substep_halvings):
  // count the attempts thrown away over eight substeps. A piece that starts shallower than that
  // is an attempt thrown away (and its halves, one level deeper, again, until the deepest).
  SubstepLevel level(2);
  int thrown_away = 0;
  for (int s = 0; s < 8; ++s) {
    const int start = level.start();
    const int pieces = 1 << start;
    for (int depth = start; depth < 2; ++depth) thrown_away += pieces << (depth - start);
    level.finished(2);
  }
  // The first substep throws away its whole attempt and its two halves, the second its two
  // halves; then a substep at the deepest level runs without a halving (none is possible) and
  // the next tries one level up again: 3 + 2 + 0 + 2 + 0 + 2 + 0 + 2 = 11. Starting at most one
  // level deep (the rule before the thirty-seventh session), every substep after the first threw
  // its two halves away: 3 + 7 * 2 = 17.
  EXPECT_EQ(thrown_away, 11);
  EXPECT_EQ(level.start(), 2);
}

TEST(SubstepLevel, WithoutHalvingsEverySubstepStartsWhole) {
  SubstepLevel level(0);
  level.finished(0);
  EXPECT_EQ(level.start(), 0);
  SubstepLevel one(1);  // one halving: a halved substep makes the next start halved
  one.finished(1);
  EXPECT_EQ(one.start(), 1);
  one.finished(1);
  EXPECT_EQ(one.start(), 0);
}

TEST(SubstepLevel, AFloorFromTheBodiesMotionHoldsForTheFrame) {
  SubstepLevel level(3, 1);  // the frame's bodies ask for one halving
  EXPECT_EQ(level.start(), 1);
  level.finished(1);  // ran at its level: not above the floor
  EXPECT_EQ(level.start(), 1);
  level.finished(3);
  EXPECT_EQ(level.start(), 2);
  level.finished(2);
  EXPECT_EQ(level.start(), 1);
  // The floor is at most the deepest level, and without halvings it is whole.
  EXPECT_EQ(SubstepLevel(2, 5).start(), 2);
  EXPECT_EQ(SubstepLevel(1, 1).start(), 1);
  EXPECT_EQ(SubstepLevel(0, 1).start(), 0);
}

}  // namespace
}  // namespace weft
