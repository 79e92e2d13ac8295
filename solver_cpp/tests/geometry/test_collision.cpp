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

TEST(ExactPredicates, Orient3dMatchesIntegerArithmeticOnNearlyCoplanarPoints) {
  // Points on lattice planes near 1000 (coordinates n / 2^20, exact in double, as are their
  // differences), one nudged by -1..1 lattice steps off the plane: the determinant is an exact
  // integer multiple of 2^-60, computed here in 128-bit integers. Most inputs fail the
  // floating-point filter and are decided by the exact paths.
  std::mt19937 rng(7);
  std::uniform_int_distribution<long long> coord(-4096, 4096), nudge(-1, 1), normal(-3, 3);
  const double unit = std::ldexp(1.0, -20);
  const long long base = 1000LL << 20;
  int zero = 0, nonzero = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    const long long nx = normal(rng), ny = normal(rng);  // the plane z = -(nx x + ny y)
    long long p[4][3];
    for (auto& q : p) {
      q[0] = coord(rng);
      q[1] = coord(rng);
      q[2] = -(nx * q[0] + ny * q[1]);
    }
    p[3][2] += nudge(rng);
    __int128 det = 0;
    {
      long long u[3], v[3], w[3];
      for (int k = 0; k < 3; ++k) u[k] = p[0][k] - p[3][k], v[k] = p[1][k] - p[3][k], w[k] = p[2][k] - p[3][k];
      det = static_cast<__int128>(u[0]) * (static_cast<__int128>(v[1]) * w[2] - static_cast<__int128>(v[2]) * w[1]) -
            static_cast<__int128>(u[1]) * (static_cast<__int128>(v[0]) * w[2] - static_cast<__int128>(v[2]) * w[0]) +
            static_cast<__int128>(u[2]) * (static_cast<__int128>(v[0]) * w[1] - static_cast<__int128>(v[1]) * w[0]);
    }
    // orient3d's sign is that of det[a - d; b - d; c - d] (positive for d below the plane of the
    // counter-clockwise a, b, c, as in the test above).
    Vec3 q[4];
    for (int i = 0; i < 4; ++i)
      for (int k = 0; k < 3; ++k) q[i][k] = static_cast<double>(base + p[i][k]) * unit;
    const int expected = det > 0 ? 1 : (det < 0 ? -1 : 0);
    ASSERT_EQ(orient3d(q[0], q[1], q[2], q[3]), expected) << "trial " << trial;
    (expected == 0 ? zero : nonzero) += 1;
  }
  EXPECT_GT(zero, 500);
  EXPECT_GT(nonzero, 500);
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

// The plane early-out of triangles_intersect (three corners strictly on one side of the other
// triangle's plane) never changes the answer of the six edge/triangle tests: random pairs on a
// coarse integer lattice (many coplanar corners, shared points and touching edges) and pairs
// just off each other's planes.
TEST(IntersectionCount, PlaneEarlyOutAgreesWithTheEdgeTests) {
  auto edge_tests = [](const std::array<Vec3, 3>& ta, const std::array<Vec3, 3>& tb) {
    for (int e = 0; e < 3; ++e)
      if (segment_intersects_triangle(ta[e], ta[(e + 1) % 3], tb[0], tb[1], tb[2]) ||
          segment_intersects_triangle(tb[e], tb[(e + 1) % 3], ta[0], ta[1], ta[2]))
        return true;
    return false;
  };
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> lattice(0, 3);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  int hits = 0;
  for (int k = 0; k < 20000; ++k) {
    std::array<Vec3, 3> ta, tb;
    const bool coarse = k % 2 == 0;
    for (auto* t : {&ta, &tb})
      for (Vec3& c : *t)
        c = coarse ? Vec3(lattice(rng), lattice(rng), lattice(rng)) : Vec3(unit(rng), unit(rng), 1e-9 * unit(rng));
    const bool expected = edge_tests(ta, tb);
    ASSERT_EQ(triangles_intersect(ta, tb), expected) << "pair " << k;
    hits += expected;
  }
  EXPECT_GT(hits, 2000);  // both answers are well represented
  EXPECT_LT(hits, 18000);
}
