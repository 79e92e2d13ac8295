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
  level.finished(2);  // a half of it had to be halved again: deeper is not allowed, one halving stays in reserve
  EXPECT_EQ(level.start(), 1);
  level.finished(1);  // ran at its level without a halving: the next goes one level up
  EXPECT_EQ(level.start(), 0);
}

TEST(SubstepLevel, OneLevelAtATimeAndNeverDeeperThanLeavesAHalving) {
  SubstepLevel level(3);
  level.finished(3);  // needed three halvings: the next starts one level deeper, not three
  EXPECT_EQ(level.start(), 1);
  level.finished(3);
  EXPECT_EQ(level.start(), 2);
  level.finished(3);
  EXPECT_EQ(level.start(), 2);
  level.finished(2);
  EXPECT_EQ(level.start(), 1);
  level.finished(1);
  EXPECT_EQ(level.start(), 0);
}

TEST(SubstepLevel, WithoutHalvingsOrWithOneEverySubstepStartsWhole) {
  for (int max_halvings : {0, 1}) {
    SubstepLevel level(max_halvings);
    level.finished(max_halvings);
    EXPECT_EQ(level.start(), 0) << max_halvings;
  }
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
  // The floor keeps the reserve halving too, and without halvings it is whole.
  EXPECT_EQ(SubstepLevel(2, 5).start(), 1);
  EXPECT_EQ(SubstepLevel(1, 1).start(), 0);
  EXPECT_EQ(SubstepLevel(0, 1).start(), 0);
}

}  // namespace
}  // namespace weft
