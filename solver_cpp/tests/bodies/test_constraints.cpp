// Pins attached to bodies: the closest point of a triangle, by region.
#include <gtest/gtest.h>

#include "weft/bodies/constraints.h"

using namespace weft;

TEST(Constraints, ClosestPointRegions) {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  EXPECT_TRUE(closest_point_barycentric(Vec3(-1, -1, 0), a, b, c).isApprox(Vec3(1, 0, 0)));
  EXPECT_TRUE(closest_point_barycentric(Vec3(0.25, 0.25, 3), a, b, c).isApprox(Vec3(0.5, 0.25, 0.25)));
  EXPECT_TRUE(closest_point_barycentric(Vec3(0.5, -2, 0), a, b, c).isApprox(Vec3(0.5, 0.5, 0)));
}
