// Sharp body edges (sharp_edges.h) and the cloth edge contacts they give (contact_constraints.h):
// a cube's edges are sharp for cloth edges longer than 1.414 separations, never its diagonals
// nor the valleys of a concave body; a cloth edge hooked across a ridge, both ends beyond the
// contact band, gets a contact along the normal from the ridge to the edge on both ends.
#include <gtest/gtest.h>

#include <cmath>

#include "weft/collision/contact_constraints.h"
#include "weft/collision/sharp_edges.h"

namespace weft {
namespace {

// Flips faces so their normals point away from the centroid (the test bodies are convex).
Faces outward(Faces faces, const Positions& x) {
  const Vec3 centre = x.colwise().mean().transpose();
  for (Eigen::Index f = 0; f < faces.rows(); ++f) {
    const Vec3 a = row3(x, faces(f, 0)), b = row3(x, faces(f, 1)), c = row3(x, faces(f, 2));
    if ((b - a).cross(c - a).dot((a + b + c) / 3.0 - centre) < 0.0) std::swap(faces(f, 1), faces(f, 2));
  }
  return faces;
}

// The unit cube: 12 edges between faces at right angles (|n0 - n1| = sqrt 2), 6 face diagonals
// between coplanar triangles.
struct Cube {
  Positions x{8, 3};
  Faces faces{12, 3};
  Cube() {
    for (int i = 0; i < 8; ++i) x.row(i) << (i & 1), (i >> 1) & 1, (i >> 2) & 1;
    faces << 0, 1, 3, 0, 3, 2, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4, 2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 3, 7, 1, 7, 5;
    faces = outward(faces, x);
  }
};

TEST(SharpEdges, ACubesEdgesAreSharpForLongClothEdgesAndItsDiagonalsNever) {
  const Cube cube;
  SharpEdges sharp(cube.faces);
  // L |n0 - n1| > 2 s: sqrt 2 L > 2 s, so L > 1.414 s.
  EXPECT_EQ(sharp.update(cube.faces, cube.x, 1.5, 1.0), 12);
  EXPECT_NEAR(sharp.sharpest(), std::sqrt(2.0), 1e-12);
  EXPECT_EQ(sharp.update(cube.faces, cube.x, 1.4, 1.0), 0);
  EXPECT_TRUE(sharp.empty());
  // Seen from inside (normals inwards) every edge is a valley: none is sharp.
  Faces inward = cube.faces;
  inward.col(1).swap(inward.col(2));
  SharpEdges valleys(inward);
  EXPECT_EQ(valleys.update(inward, cube.x, 100.0, 1.0), 0);
}

// Normals and sharpness are kept while the body stays where it was (a body at rest) and the
// boxes while the sharp edges do too: every answer is a fresh object's, also after the body
// moved away and back and the cloth's longest edge changed in between.
TEST(SharpEdges, AnUnmovedBodyAnswersAsAFreshOneWhateverTheClothEdge) {
  const Cube cube;
  SharpEdges kept(cube.faces);
  auto expect_fresh = [&](const Positions& x, double longest, int count) {
    SharpEdges fresh(cube.faces);
    ASSERT_EQ(fresh.update(cube.faces, x, longest, 1.0), count);
    ASSERT_EQ(kept.update(cube.faces, x, longest, 1.0), count);
    EXPECT_EQ(kept.sharpest(), fresh.sharpest());
    for (int leaf = 0; leaf < count; ++leaf) {
      EXPECT_EQ(kept.edge(leaf), fresh.edge(leaf));
      EXPECT_EQ(kept.sharpness(leaf), fresh.sharpness(leaf));
    }
    if (count > 0) {
      EXPECT_EQ(kept.tree().bounds().lo, fresh.tree().bounds().lo);
      EXPECT_EQ(kept.tree().bounds().hi, fresh.tree().bounds().hi);
    }
  };
  Positions moved = cube.x;
  moved.col(0).array() += 1.0;
  expect_fresh(cube.x, 1.5, 12);
  expect_fresh(cube.x, 1.4, 0);
  expect_fresh(cube.x, 1.5, 12);
  expect_fresh(moved, 1.5, 12);  // refitted where it went
  EXPECT_EQ(kept.tree().bounds().lo.x(), 1.0);
  expect_fresh(cube.x, 1.5, 12);
  EXPECT_EQ(kept.tree().bounds().lo.x(), 0.0);
  // Standing still, nothing advances (least not below zero).
  std::vector<std::array<int, 2>> out;
  kept.advancing(cube.x, Positions(cube.x), 0.0, out);
  EXPECT_TRUE(out.empty());
}

// A cube moved between update() and `end`: the edges that are not sharp and whose ends advance
// along the edge's outward normal (its faces' normals summed) by more than the least asked
// (here half the separation); moving away from an edge or along it never advances it.
TEST(SharpEdges, BluntEdgesAdvanceAlongTheirOutwardNormal) {
  const Cube cube;
  SharpEdges sharp(cube.faces);
  auto pushing = [&](const Vec3& by) {
    Positions end = cube.x;
    end.rowwise() += by.transpose();
    std::vector<std::array<int, 2>> out;
    sharp.advancing(cube.x, end, 0.5, out);
    return out;
  };
  ASSERT_EQ(sharp.update(cube.faces, cube.x, 1.4, 1.0), 0);  // no edge sharp
  EXPECT_TRUE(pushing(Vec3(0.0, 0.0, 0.4)).empty());
  // 0.6 up: the top face's diagonal (normal +z); the top's four edges advance 0.6 / sqrt 2.
  const std::vector<std::array<int, 2>> top = pushing(Vec3(0.0, 0.0, 0.6));
  ASSERT_EQ(top.size(), 1u);
  EXPECT_EQ(cube.x(top[0][0], 2), 1.0);
  EXPECT_EQ(cube.x(top[0][1], 2), 1.0);
  EXPECT_EQ(pushing(Vec3(0.0, 0.0, 0.8)).size(), 5u);  // 0.8 / sqrt 2 > 0.5: the top's edges too
  EXPECT_EQ(pushing(Vec3(-0.8, 0.0, 0.0)).size(), 5u);
  // Sharp edges are not listed again: of the 0.8 push only the diagonal is left.
  ASSERT_EQ(sharp.update(cube.faces, cube.x, 1.5, 1.0), 12);
  EXPECT_EQ(pushing(Vec3(0.0, 0.0, 0.8)).size(), 1u);
  // The least asked can be below zero (cloth coming towards the body): edges moving away less.
  std::vector<std::array<int, 2>> all;
  sharp.advancing(cube.x, cube.x, -1.0, all);
  EXPECT_EQ(all.size(), 6u);  // the six diagonals, standing still
}

// The cube's edge 0-1 (x from 0 to 1 at y = z = 0) between its faces y = 0 and z = 0: a cloth
// edge in the plane x = 0.5 cuts its corner when it goes in through one face and out through
// the other, either way round; one with an end inside the wedge (through the body) or passing
// outside does not.
TEST(SharpEdges, AClothEdgeCutsACornerInThroughOneFaceAndOutThroughTheOther) {
  const Cube cube;
  SharpEdges sharp(cube.faces);
  ASSERT_EQ(sharp.update(cube.faces, cube.x, 1.5, 1.0), 12);
  int leaf = 0;
  while (leaf < sharp.size() && sharp.edge(leaf) != std::array<int, 2>{0, 1}) ++leaf;
  ASSERT_LT(leaf, sharp.size());
  const Vec3 on_edge(0.5, 0.0, 0.0);
  const Vec3 a(0.5, -0.1, 0.2), b(0.5, 0.2, -0.1), middle = 0.5 * (a + b);  // middle at y = z = 0.05
  EXPECT_TRUE(sharp.corner_cut(leaf, on_edge, a, b, middle));
  EXPECT_TRUE(sharp.corner_cut(leaf, on_edge, b, a, middle));
  const Vec3 inside(0.5, 0.3, 0.4);
  EXPECT_FALSE(sharp.corner_cut(leaf, on_edge, a, inside, 0.5 * (a + inside)));
  const Vec3 c(0.5, -0.1, 0.05), d(0.5, 0.05, -0.1);  // its middle at y = z = -0.025: outside
  EXPECT_FALSE(sharp.corner_cut(leaf, on_edge, c, d, 0.5 * (c + d)));
}

TEST(SharpEdges, AnOpenMeshsBorderIsSharp) {
  Positions x(4, 3);
  x << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0;
  Faces faces(2, 3);
  faces << 0, 1, 2, 0, 2, 3;
  SharpEdges sharp(faces);
  // A border is a knife edge (|n0 - n1| taken as 2): sharp for cloth edges longer than s.
  EXPECT_EQ(sharp.update(faces, x, 0.9, 1.0), 0);
  ASSERT_EQ(sharp.update(faces, x, 1.1, 1.0), 4);  // the square's sides, not its diagonal
  for (int leaf = 0; leaf < 4; ++leaf) {
    const auto& e = sharp.edge(leaf);
    EXPECT_NE(std::abs(e[0] - e[1]), 2) << "the diagonal 0-2 is no border";
  }
}

constexpr double kThickness = 0.002;

// A ridge (a closed triangular prism along y, its crest at z = 0) with half-width `half_width`
// at depth 0.02 below the crest, and a cloth triangle whose edge a-b crosses over the crest at
// height `height`, its ends 3 cm to either side; the whole cloth falls at 10 m/s.
ConstraintFilter hook(double half_width, double height, int threads, CollisionTelemetry& frame) {
  Positions ridge(6, 3);
  for (int end = 0; end < 2; ++end) {
    const double y = end == 0 ? -0.5 : 0.5;
    ridge.row(3 * end + 0) << 0.0, y, 0.0;
    ridge.row(3 * end + 1) << -half_width, y, -0.02;
    ridge.row(3 * end + 2) << half_width, y, -0.02;
  }
  Faces ridge_faces(8, 3);
  ridge_faces << 0, 1, 4, 0, 4, 3, 0, 2, 5, 0, 5, 3, 1, 2, 5, 1, 5, 4, 0, 1, 2, 3, 4, 5;
  std::vector<KinematicBody> bodies;
  bodies.emplace_back(outward(ridge_faces, ridge), ridge);
  Positions x(3, 3);
  x << -0.03, 0.0, height, 0.03, 0.0, height, 0.0, 0.03, 0.05;
  Faces cloth(1, 3);
  cloth << 0, 1, 2;
  ContactProperties props;
  props.inverse_mass.assign(3, 1.0);
  props.thickness.assign(3, kThickness);
  props.friction.assign(3, 0.3);
  ContactDetection detection(cloth, x, {1}, {0}, {kThickness}, bodies, {1});
  detection.set_threads(threads);
  Positions v = Positions::Zero(3, 3);
  v.col(2).setConstant(-10.0);
  CollisionStep step;
  step.begin(x, v, 0.01);
  step.body_start.push_back(ridge);
  step.body_end.push_back(ridge);
  ConstraintFilter filter;
  filter.reset(3);
  ContactConstraints().constrain(x, v, 0.01, step, detection, props, filter, frame);
  return filter;
}

TEST(ContactConstraints, AClothEdgeHookedOnASharpRidgeHoldsBothEnds) {
  for (int threads : {1, 2}) {
    CollisionTelemetry frame;
    const double height = 0.003;  // within the band (two thicknesses), its ends 3 cm away
    const ConstraintFilter filter = hook(0.01, height, threads, frame);
    const Vec3 n(0.0, 0.0, 1.0);  // from the crest to the edge
    const Mat3 expected = Mat3::Identity() - n * n.transpose();
    // Each end's normal speed is prescribed: from -10 m/s to the speed that ends the step at
    // the thickness, (thickness - height) / h.
    const double delta = (kThickness - height) / 0.01 + 10.0;
    for (int end : {0, 1}) {
      EXPECT_LT((filter.projection[end] - expected).cwiseAbs().maxCoeff(), 1e-12) << "threads " << threads;
      EXPECT_NEAR(filter.prescribed.segment<3>(3 * end).dot(n), delta, 1e-9);
    }
    EXPECT_EQ(filter.projection[2], Mat3::Identity()) << "the far corner touches nothing";
    EXPECT_EQ(frame.contact_constraints, 2);
  }
}

TEST(ContactConstraints, NoEdgeContactBeyondTheBand) {
  CollisionTelemetry beyond;
  const ConstraintFilter far = hook(0.01, 0.005, 2, beyond);  // 5 mm: beyond two thicknesses
  EXPECT_EQ(beyond.contact_constraints, 0);
  EXPECT_EQ(far.constrained_vertices, 0);
}

}  // namespace
}  // namespace weft
