#include <gtest/gtest.h>

#include "weft/common/timer.h"
#include "weft/common/union_find.h"

namespace weft {
namespace {

TEST(UnionFind, RootsAreTheLowestMembers) {
  UnionFind sets(6);
  sets.unite(4, 2);
  sets.unite(5, 4);
  sets.unite(3, 1);
  EXPECT_EQ(sets.find(5), 2);
  EXPECT_EQ(sets.find(4), 2);
  EXPECT_EQ(sets.find(3), 1);
  EXPECT_EQ(sets.find(0), 0);
  sets.unite(5, 3);
  EXPECT_EQ(sets.find(2), 1);
}

TEST(Timer, CountsUp) {
  Timer timer;
  EXPECT_GE(timer.seconds(), 0.0);
  timer.restart();
  EXPECT_LT(timer.seconds(), 10.0);
}

}  // namespace
}  // namespace weft
