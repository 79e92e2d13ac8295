// Collision module unit tests: CCD edge cases, exact predicates, intersection counting.
#include <gtest/gtest.h>

#include <random>

#include "weft/collision/ccd.h"
#include "weft/geometry/exact_predicates.h"
#include "weft/geometry/intersection_count.h"

using namespace weft;

namespace {
const Vec3 kA(0, 0, 0), kB(1, 0, 0), kC(0, 1, 0);

CcdResult vt(const Vec3& p0, const Vec3& p1) { return vertex_triangle_ccd({p0, kA, kB, kC}, {p1, kA, kB, kC}); }
}  // namespace

TEST(Ccd, VertexThroughFaceGivesLowerBoundTime) {
  const CcdResult r = vt({0.2, 0.2, 1}, {0.2, 0.2, -1});
  ASSERT_TRUE(r.hit);
  EXPECT_LE(r.toi, 0.5);
  EXPECT_GE(r.toi, 0.5 - 1e-5);
  EXPECT_FALSE(vt({0.6, 0.6, 1}, {0.6, 0.6, -1}).hit);
}

TEST(Ccd, GrazingEdgeAndTouchingAtEnds) {
  EXPECT_TRUE(vt({0.2, 0.8, 1}, {0.8, 0.2, -1}).hit);  // through the hypotenuse
  EXPECT_TRUE(vt({0.2, 0.2, 0}, {0.2, 0.2, 1}).hit);   // touching at t = 0
  EXPECT_EQ(vt({0.2, 0.2, 0}, {0.2, 0.2, 1}).toi, 0.0);
  EXPECT_TRUE(vt({0.2, 0.2, 1}, {0.2, 0.2, 0}).hit);  // touching at t = 1
}

TEST(Ccd, ParallelEdges) {
  const std::array<Vec3, 4> s{Vec3(0, 0, 1), Vec3(1, 0, 1), Vec3(0.5, 0, 0), Vec3(1.5, 0, 0)};
  std::array<Vec3, 4> e = s;
  e[0].z() = e[1].z() = -1;
  EXPECT_TRUE(edge_edge_ccd(s, e).hit);
  std::array<Vec3, 4> s2 = s, e2 = e;
  for (int i = 2; i < 4; ++i) s2[i].x() += 1.5, e2[i].x() += 1.5;
  EXPECT_FALSE(edge_edge_ccd(s2, e2).hit);
}

TEST(ExactPredicates, Orient3dSignsAndCoplanarity) {
  EXPECT_EQ(orient3d(kA, kB, kC, Vec3(0, 0, -1)), 1);
  EXPECT_EQ(orient3d(kA, kB, kC, Vec3(0, 0, 1)), -1);
  EXPECT_EQ(orient3d(kA, kB, kC, Vec3(0.3, 0.3, 0)), 0);
  // Nearly coplanar points far from the origin: the filter fails, the exact path decides.
  const Vec3 o(1e8, 1e8, 1e8);
  EXPECT_EQ(orient3d(o + kA, o + kB, o + kC, o + Vec3(0.25, 0.25, 0)), 0);
  EXPECT_EQ(orient3d(o + kA, o + kB, o + kC, o + Vec3(0.25, 0.25, -1.4901161193847656e-8)), 1);
}

// orient2d against an exact integer determinant: integer coordinates up to 2^40 (exact in
// double), points on or next to a line, so the float filter must defer to the expansion.
TEST(ExactPredicates, Orient2dMatchesExactIntegerSigns) {
  std::mt19937_64 rng(11);
  std::uniform_int_distribution<long long> coordinate(-(1LL << 40), 1LL << 40), step(-8, 8), nudge(-1, 1);
  int zeros = 0, filtered = 0;
  for (int q = 0; q < 20000; ++q) {
    const long long ax = coordinate(rng), ay = coordinate(rng), dx = step(rng), dy = step(rng);
    const long long k = step(rng) * 1000003, m = step(rng) * 999983;
    // b and c on the line through a with direction (dx, dy), c nudged off it half the time.
    const long long bx = ax + k * dx, by = ay + k * dy;
    const long long cx = ax + m * dx + (q % 2 ? nudge(rng) : 0), cy = ay + m * dy + (q % 2 ? nudge(rng) : 0);
    const __int128 det = static_cast<__int128>(ax - cx) * (by - cy) - static_cast<__int128>(ay - cy) * (bx - cx);
    const int expected = det > 0 ? 1 : (det < 0 ? -1 : 0);
    zeros += expected == 0;
    filtered += expected != 0;
    ASSERT_EQ(orient2d(static_cast<double>(ax), static_cast<double>(ay), static_cast<double>(bx),
                       static_cast<double>(by), static_cast<double>(cx), static_cast<double>(cy)),
              expected)
        << q;
  }
  EXPECT_GT(zeros, 5000);
  EXPECT_GT(filtered, 2000);
  // Clear cases take the filter, with the right sign.
  EXPECT_EQ(orient2d(0, 0, 1, 0, 0, 1), 1);
  EXPECT_EQ(orient2d(0, 0, 0, 1, 1, 0), -1);
  // Four points sharing a coordinate exactly are coplanar.
  EXPECT_EQ(orient3d(Vec3(0.1, 0.3, 0.7), Vec3(0.9, 0.3, 0.2), Vec3(0.4, 0.3, 0.5), Vec3(0.6, 0.3, 0.1)), 0);
}

TEST(IntersectionCount, TrianglePairs) {
  EXPECT_TRUE(triangles_intersect({kA, kB, kC}, {Vec3(0.2, 0.2, -1), Vec3(0.2, 0.2, 1), Vec3(0.3, 0.5, 0)}));
  EXPECT_FALSE(triangles_intersect({kA, kB, kC}, {Vec3(0.2, 0.2, 0.5), Vec3(0.2, 0.2, 1), Vec3(0.3, 0.5, 1)}));
  EXPECT_TRUE(triangles_intersect({kA, kB, kC}, {Vec3(0.2, 0.2, 0), Vec3(1.2, 0.2, 0), Vec3(0.2, 1.2, 0)}));
}
