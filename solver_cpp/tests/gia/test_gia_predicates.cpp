// Exact predicates and the symbolic perturbation used by the intersection analysis.
#include <gtest/gtest.h>

#include <random>

#include "weft/geometry/exact_predicates.h"
#include "weft/gia/intersection_analysis.h"

using namespace weft;

namespace {
using I128 = __int128;

// Exact reference for integer coordinates (|c| < 2^35): det[a-d; b-d; c-d] in 128-bit integers.
int orient_int128(const long long* a, const long long* b, const long long* c, const long long* d) {
  I128 m[3][3];
  for (int k = 0; k < 3; ++k) {
    m[0][k] = a[k] - d[k];
    m[1][k] = b[k] - d[k];
    m[2][k] = c[k] - d[k];
  }
  const I128 det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                   m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
  return det > 0 ? 1 : (det < 0 ? -1 : 0);
}
}  // namespace

TEST(GiaPredicates, ExactSignMatchesIntegerReferenceNearCoplanar) {
  // Points a + m u + n v on an integer plane (coordinates up to ~2^35, exact in doubles), the
  // fourth one exactly on the plane or one unit off it.
  std::mt19937_64 rng(7);
  std::uniform_int_distribution<long long> base(-(1LL << 34), 1LL << 34), dir(-(1LL << 16), 1LL << 16);
  std::uniform_int_distribution<long long> step(-(1LL << 16), 1LL << 16);
  const double scale = std::ldexp(1.0, -30);  // exact scaling: doubles carry the integers exactly
  int zero = 0, naive_wrong = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    long long a[3], u[3], v[3], p[4][3];
    for (int k = 0; k < 3; ++k) {
      a[k] = base(rng);
      u[k] = dir(rng);
      v[k] = dir(rng);
    }
    for (int i = 0; i < 4; ++i) {
      const long long m = step(rng), n = step(rng);
      for (int k = 0; k < 3; ++k) p[i][k] = a[k] + m * u[k] + n * v[k];
    }
    p[3][2] += (trial % 3) - 1;
    double q[4][3];
    for (int i = 0; i < 4; ++i)
      for (int k = 0; k < 3; ++k) q[i][k] = static_cast<double>(p[i][k]) * scale;
    const int ref = orient_int128(p[0], p[1], p[2], p[3]);
    ASSERT_EQ(orient3d_exact_sign(q[0], q[1], q[2], q[3]), ref) << "trial " << trial;
    const double approx = orient3d_approx(q[0], q[1], q[2], q[3]);
    naive_wrong += (approx > 0) - (approx < 0) != ref;
    zero += ref == 0;
  }
  EXPECT_GT(naive_wrong, 0) << "the test should include cases plain floating point gets wrong";
  EXPECT_GT(zero, 0);
}

TEST(GiaPredicates, SymbolicPerturbationIsNonZeroAndAntisymmetric) {
  const double pts[5][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {2, 2, 0}};  // all coplanar
  const KeyedPoint k[5] = {{pts[0], 10}, {pts[1], 3}, {pts[2], 7}, {pts[3], 1}, {pts[4], 4}};
  for (int a = 0; a < 5; ++a)
    for (int b = 0; b < 5; ++b)
      for (int c = 0; c < 5; ++c)
        for (int d = 0; d < 5; ++d) {
          if (a == b || a == c || a == d || b == c || b == d || c == d) continue;
          const int s = orient3d_sos(k[a], k[b], k[c], k[d]);
          ASSERT_NE(s, 0);
          EXPECT_EQ(orient3d_sos(k[b], k[a], k[c], k[d]), -s);
          EXPECT_EQ(orient3d_sos(k[a], k[c], k[b], k[d]), -s);
          EXPECT_EQ(orient3d_sos(k[a], k[b], k[d], k[c]), -s);
          EXPECT_EQ(orient3d_sos(k[b], k[c], k[a], k[d]), s);
        }
  // Non-degenerate configurations keep their exact sign.
  const double up[3] = {0, 0, -1};
  const KeyedPoint below{up, 99};
  EXPECT_EQ(orient3d_sos(k[0], k[1], k[2], below), orient3d_exact_sign(pts[0], pts[1], pts[2], up));
  EXPECT_EQ(orient3d_exact_sign(pts[0], pts[1], pts[2], up), 1);  // d below ccw abc: positive
}

// On a tiny integer lattice almost every configuration is degenerate (shared planes, lines
// through vertices, coplanar triangles). The perturbed predicates must still make every
// triangle pair cross in exactly zero or two edge/triangle hits.
TEST(GiaPredicates, TrianglePairsHaveZeroOrTwoHitsOnDegenerateLattice) {
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> c(0, 2);
  int crossing_pairs = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    double p[6][3];
    for (auto& q : p)
      for (double& v : q) v = c(rng);
    KeyedPoint k[6];
    for (int i = 0; i < 6; ++i) k[i] = {p[i], i};
    int hits = 0;
    for (int side = 0; side < 2; ++side) {
      const int e = side * 3, t = 3 - side * 3;
      for (int j = 0; j < 3; ++j)
        hits += segment_crosses_triangle(k[e + j], k[e + (j + 1) % 3], k[t], k[t + 1], k[t + 2]);
    }
    ASSERT_TRUE(hits == 0 || hits == 2) << "trial " << trial << " hits " << hits;
    crossing_pairs += hits == 2;
  }
  EXPECT_GT(crossing_pairs, 100);
}

TEST(GiaTopology, TetrahedronIsClosedAndSquareHasBoundary) {
  Faces tet(4, 3);
  tet << 0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2;
  const GiaTopology t = build_gia_topology(4, tet);
  EXPECT_EQ(t.edges.rows(), 6);
  EXPECT_TRUE(t.closed);
  EXPECT_EQ(t.boundary_edge_count, 0);
  Faces square(2, 3);
  square << 0, 1, 2, 0, 2, 3;
  const GiaTopology s = build_gia_topology(4, square);
  EXPECT_EQ(s.edges.rows(), 5);
  EXPECT_EQ(s.boundary_edge_count, 4);
  EXPECT_FALSE(s.closed);
  Faces bad(1, 3);
  bad << 0, 0, 1;
  EXPECT_THROW(build_gia_topology(4, bad), std::invalid_argument);
}

TEST(GiaInside, PointsInsideTetrahedronIncludingDegenerateRays) {
  Positions x(4, 3);
  x << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  Faces tet(4, 3);
  tet << 0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2;
  Positions p(4, 3);
  p << 0.1, 0.1, 0.1,  // inside
      0.5, 0.5, 0.5,   // outside
      0.2, 0.0, 0.2,   // on a face, ray grazing it: decided by the perturbation, but no crash
      -0.5, 0.25, 0.25;  // outside, ray through the interior (two crossings)
  const std::vector<std::int8_t> inside = points_inside_closed_mesh(p, x, tet);
  EXPECT_EQ(inside[0], 1);
  EXPECT_EQ(inside[1], 0);
  EXPECT_EQ(inside[3], 0);
}
