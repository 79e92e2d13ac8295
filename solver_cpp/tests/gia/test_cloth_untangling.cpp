// Cloth/cloth untangling (cloth_untangling.h): colouring, membrane flags, and the pull that
// takes an edge back through the triangle it crosses.
#include <gtest/gtest.h>

#include "weft/gia/cloth_untangling.h"
#include "weft/gia/intersection_analysis.h"

using namespace weft;

namespace {

// Triangle 0 = (0, 1, 2) flat in z = 0; triangle 1 = (3, 4, 5) with vertex 3 below the plane
// and 4, 5 above, so its edges 3-4 and 3-5 cross triangle 0 (inside it), edge 4-5 does not.
void two_triangles(Positions& x, Faces& f) {
  x.resize(6, 3);
  x << -1, -1, 0, 1, -1, 0, 0, 1, 0, 0, 0, -0.1, -0.3, 0, 0.5, 0.3, 0.2, 0.5;
  f.resize(2, 3);
  f << 0, 1, 2, 3, 4, 5;
}

}  // namespace

TEST(ClothUntangling, OneEdgeThroughATriangleIsPulledBackWithinOneCall) {
  Positions x;
  Faces f;
  two_triangles(x, f);
  ClothUntangling untangle(f, {1, 1}, 6);
  untangle.analyse(x, 1);
  ASSERT_EQ(untangle.path_count(), 1);
  ASSERT_EQ(untangle.coloured_count(), 1);  // the tip below the plane, the smaller region
  EXPECT_TRUE(untangle.coloured(3));
  ASSERT_EQ(untangle.hits().size(), 2u);
  for (const UntangleHit& h : untangle.hits()) {
    EXPECT_EQ(h.coloured, 3);
    EXPECT_EQ(h.face, 0);
  }
  // Membrane flags: the coloured vertex and the pierced triangle are tangled on both sides.
  EXPECT_TRUE(untangle.tangled_vertex(3));
  EXPECT_TRUE(untangle.tangled_face(0));
  EXPECT_TRUE(untangle.tangled_vertex(0));

  const double h = 0.01, th = 0.002;
  Positions v = Positions::Zero(6, 3);
  const std::vector<double> inverse_mass(6, 1.0), thickness(6, th);
  EXPECT_EQ(untangle.pull(x, v, h, inverse_mass, thickness), 1);  // the second hit is then satisfied
  // Momentum conserved (equal masses): the velocities sum to zero.
  EXPECT_NEAR(v.colwise().sum().norm(), 0.0, 1e-12);
  // Only the coloured vertex and the triangle moved; vertex 3 goes up, the triangle down.
  EXPECT_GT(v(3, 2), 0.0);
  for (int k = 0; k < 3; ++k) EXPECT_LE(v(k, 2), 0.0);
  EXPECT_EQ(v.row(4).norm(), 0.0);
  EXPECT_EQ(v.row(5).norm(), 0.0);
  // After the step vertex 3 is above the (tilted) triangle's plane and nothing crosses.
  const Positions x1 = x + h * v;
  const Vec3 a = x1.row(0).transpose(), b = x1.row(1).transpose(), c = x1.row(2).transpose();
  const Vec3 n = (b - a).cross(c - a).normalized();
  EXPECT_GT(n.z(), 0.0);
  EXPECT_GT(n.dot(Vec3(x1.row(3).transpose()) - a), 0.0);
  GiaOptions options;
  options.inside_test = false;
  const GiaResult after = analyse_self_intersections(x1, f, options);
  EXPECT_TRUE(after.hits.empty());
  // A second analysis finds nothing to do.
  untangle.analyse(x1, 1);
  EXPECT_FALSE(untangle.any());
  Positions v1 = v;
  EXPECT_EQ(untangle.pull(x1, v1, h, inverse_mass, thickness), 0);
  EXPECT_EQ(v1, v);
}

TEST(ClothUntangling, PinnedTriangleMovesOnlyTheEdge) {
  Positions x;
  Faces f;
  two_triangles(x, f);
  ClothUntangling untangle(f, {1, 1}, 6);
  untangle.analyse(x, 1);
  Positions v = Positions::Zero(6, 3);
  std::vector<double> inverse_mass(6, 1.0);
  inverse_mass[0] = inverse_mass[1] = inverse_mass[2] = 0.0;
  const double h = 0.01;
  untangle.pull(x, v, h, inverse_mass, std::vector<double>(6, 0.002));
  EXPECT_EQ(v.topRows(3).norm(), 0.0);
  EXPECT_NEAR(v(3, 2), (0.1 + 0.002) / h, 1e-9);
}

TEST(ClothUntangling, FacesWithoutSelfCollisionAreNotAnalysed) {
  Positions x;
  Faces f;
  two_triangles(x, f);
  ClothUntangling untangle(f, {1, 0}, 6);
  untangle.analyse(x, 1);
  EXPECT_FALSE(untangle.any());
  EXPECT_FALSE(untangle.tangled_vertex(3));
}

// Two layers interlocked at an edge pair (an "X"): sheet A is a valley whose middle edge 0-1 (along
// y) dips 5 cm under the ridge 4-5 (along x) of sheet B's roof, so edge 0-1 crosses both roof
// faces and edge 4-5 crosses both valley faces. The intersection is a loop of four crossings
// around no vertex: nothing can be coloured, yet the pair is found and pushed apart within one
// step, A up and B down, with momentum kept.
TEST(ClothUntangling, InterlockedEdgesArePushedApartWithinOneCall) {
  Positions x(8, 3);
  x << 0, -1, -0.05, 0, 1, -0.05, -1, 0, 0.15, 1, 0, 0.15,  // A: edge 0-1, wings 2 and 3
      -1, 0, 0, 1, 0, 0, 0, -1, -0.2, 0, 1, -0.2;            // B: ridge 4-5, eaves 6 and 7
  Faces f(4, 3);
  f << 0, 1, 2, 1, 0, 3, 4, 5, 6, 5, 4, 7;
  GiaOptions options;
  options.inside_test = false;
  const GiaResult before = analyse_self_intersections(x, f, options);
  ASSERT_EQ(before.hits.size(), 4u);
  ClothUntangling untangle(f, {1, 1, 1, 1}, 8);
  untangle.analyse(x, 1);
  EXPECT_EQ(untangle.path_count(), 1);
  EXPECT_EQ(untangle.coloured_count(), 0);
  EXPECT_TRUE(untangle.hits().empty());
  ASSERT_EQ(untangle.interlocks().size(), 1u);
  EXPECT_FALSE(untangle.any());  // nothing coloured, no crossing edge to pull
  EXPECT_TRUE(untangle.interlocked());
  // The faces around the two edges are skipped against each other, so they may pass back.
  EXPECT_TRUE(untangle.skip_triangle_pair(0, 2));
  EXPECT_TRUE(untangle.skip_triangle_pair(3, 1));
  const double h = 0.01, th = 0.002;
  Positions v = Positions::Zero(8, 3);
  const std::vector<double> inverse_mass(8, 1.0), thickness(8, th);
  EXPECT_EQ(untangle.pull(x, v, h, inverse_mass, thickness), 1);
  EXPECT_NEAR(v.colwise().sum().norm(), 0.0, 1e-12);
  EXPECT_GT(v(0, 2), 0.0);
  EXPECT_GT(v(1, 2), 0.0);
  EXPECT_LT(v(4, 2), 0.0);
  EXPECT_LT(v(5, 2), 0.0);
  for (int k : {2, 3, 6, 7}) EXPECT_EQ(v.row(k).norm(), 0.0) << "vertex " << k;
  const Positions x1 = x + h * v;
  EXPECT_NEAR(x1(0, 2) - x1(4, 2), th, 1e-12);  // edge 0-1 ends the thickness above the ridge
  EXPECT_TRUE(analyse_self_intersections(x1, f, options).hits.empty());
  untangle.analyse(x1, 1);
  EXPECT_FALSE(untangle.interlocked());
  EXPECT_FALSE(untangle.skip_triangle_pair(0, 2));
}

// A hem folded tightly onto the cloth above it: the boundary edge 4-5 has one face, which edge
// 0-1 crosses; 4-5 crosses both faces around 0-1. The path of three crossings ends on the
// boundary, splits nothing and colours nothing; the pair is pushed apart as the X is.
TEST(ClothUntangling, AHemEdgeThroughTheClothAboveIsPushedBack) {
  Positions x(7, 3);
  x << 0, -1, -0.05, 0, 1, -0.05, -1, 0, 0.15, 1, 0, 0.15,  // A: edge 0-1, wings 2 and 3
      -1, 0, 0, 1, 0, 0, 0, -1, -0.2;                        // B: hem edge 4-5 and one face
  Faces f(3, 3);
  f << 0, 1, 2, 1, 0, 3, 4, 5, 6;
  GiaOptions options;
  options.inside_test = false;
  ASSERT_EQ(analyse_self_intersections(x, f, options).hits.size(), 3u);
  ClothUntangling untangle(f, {1, 1, 1}, 7);
  untangle.analyse(x, 1);
  EXPECT_EQ(untangle.coloured_count(), 0);
  ASSERT_EQ(untangle.interlocks().size(), 1u);
  const double h = 0.01, th = 0.002;
  Positions v = Positions::Zero(7, 3);
  const std::vector<double> inverse_mass(7, 1.0), thickness(7, th);
  EXPECT_EQ(untangle.pull(x, v, h, inverse_mass, thickness), 1);
  EXPECT_NEAR(v.colwise().sum().norm(), 0.0, 1e-12);
  EXPECT_GT(v(0, 2), 0.0);  // the cloth edge up, the hem down: the side each one's ends are on
  EXPECT_LT(v(4, 2), 0.0);
  EXPECT_TRUE(analyse_self_intersections(x + h * v, f, options).hits.empty());
}
