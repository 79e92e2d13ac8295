// Self-collision culling by normal cones: a flat sheet cannot touch itself (every node culled,
// no self pair), a sheet folded back over itself can (the nodes spanning the fold are kept),
// and two separate sheets are never culled as one patch.
#include <gtest/gtest.h>

#include <cmath>

#include "support/grid_faces.h"
#include "weft/collision/self_culling.h"

namespace weft {
namespace {

// An n x n grid of vertices in the xz plane, spacing 1 cm, two triangles per cell.
struct Grid {
  Faces faces;
  Positions x;
  explicit Grid(int n, double y = 0.0) : faces(testing::grid_faces(n)), x(n * n, 3) {
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) x.row(i * n + j) << 0.01 * i, y, 0.01 * j;
  }
};

std::vector<std::pair<int, int>> self_pairs(const Faces& faces, const Positions& x, double margin, int* culled_nodes) {
  std::vector<Aabb> boxes;
  const std::vector<double> margins(faces.rows(), margin);
  triangle_boxes(faces, x, x, margins, boxes);
  AabbTree tree;
  tree.build(boxes);
  SelfCollisionCulling culling;
  culling.rebuild(tree, faces, std::vector<char>(faces.rows(), 1));
  *culled_nodes = culling.update(tree, faces, x, x, margin);
  std::vector<std::pair<int, int>> pairs;
  tree.self_pairs(pairs, &culling.culled());
  return pairs;
}

TEST(SelfCulling, AFlatSheetHasNoSelfPairs) {
  const Grid grid(12);
  int culled = 0;
  EXPECT_TRUE(self_pairs(grid.faces, grid.x, 0.002, &culled).empty());
  EXPECT_EQ(culled, 1);  // the root
  // Without culling, neighbouring triangles' boxes overlap.
  std::vector<Aabb> boxes;
  triangle_boxes(grid.faces, grid.x, grid.x, std::vector<double>(grid.faces.rows(), 0.002), boxes);
  AabbTree tree;
  tree.build(boxes);
  std::vector<std::pair<int, int>> all;
  tree.self_pairs(all);
  EXPECT_GT(all.size(), 100u);
}

// Over a step a patch is tested in the frame that moves with its boundary (or in the world,
// whichever moves it less): a whole sheet sliding 5 cm in its own plane, five times its grid
// spacing, is still one patch that cannot touch itself; its right half sliding over its left
// half is not.
TEST(SelfCulling, APatchIsTestedInTheFrameThatMovesWithIt) {
  const Grid grid(12);
  const double margin = 0.002;
  auto culled_root = [&](const Positions& end, size_t* pairs) {
    std::vector<Aabb> boxes;
    triangle_boxes(grid.faces, grid.x, end, std::vector<double>(grid.faces.rows(), margin), boxes);
    AabbTree tree;
    tree.build(boxes);
    SelfCollisionCulling culling;
    culling.rebuild(tree, grid.faces, std::vector<char>(grid.faces.rows(), 1));
    culling.update(tree, grid.faces, grid.x, end, margin);
    std::vector<std::pair<int, int>> kept;
    tree.self_pairs(kept, &culling.culled());
    *pairs = kept.size();
    return culling.culled()[0] != 0;
  };
  Positions sliding = grid.x;
  sliding.col(0).array() += 0.05;
  size_t pairs = 0;
  EXPECT_TRUE(culled_root(sliding, &pairs));
  EXPECT_EQ(pairs, 0u);
  Positions over = grid.x;
  for (int v = 0; v < over.rows(); ++v)
    if (grid.x(v, 0) > 0.055) over(v, 0) -= 0.08;
  EXPECT_FALSE(culled_root(over, &pairs));
  EXPECT_GT(pairs, 100u);
}

TEST(SelfCulling, ASheetFoldedOverItselfKeepsThePairsAcrossTheFold) {
  // Fold the grid about x = 5.5 cm: the far half lies 4 mm above the near half, upside down.
  Grid grid(12);
  for (int v = 0; v < grid.x.rows(); ++v) {
    const double x = grid.x(v, 0);
    if (x > 0.055) grid.x.row(v) << 0.11 - x, 0.004, grid.x(v, 2);
    else if (x > 0.05) grid.x(v, 1) = 0.002;
  }
  int culled = 0;
  const auto pairs = self_pairs(grid.faces, grid.x, 0.005, &culled);
  // Faces of the two layers (x < 5 cm and x > 6 cm before folding) are paired across the fold.
  auto layer = [&](int f) { return grid.x(grid.faces(f, 0), 1) > 0.003 ? 1 : grid.x(grid.faces(f, 0), 1) < 0.001 ? 0 : -1; };
  int across = 0;
  for (const auto& [a, b] : pairs) across += layer(a) >= 0 && layer(b) >= 0 && layer(a) != layer(b);
  EXPECT_GT(across, 50);
}

TEST(SelfCulling, TwoSeparateSheetsAreNotOnePatch) {
  // Two flat sheets 3 mm apart, both facing up: parallel normals, but not connected.
  const Grid a(8), b(8, 0.003);
  Faces faces(a.faces.rows() * 2, 3);
  faces << a.faces, (b.faces.array() + static_cast<int>(a.x.rows())).matrix();
  Positions x(a.x.rows() * 2, 3);
  x << a.x, b.x;
  int culled = 0;
  const auto pairs = self_pairs(faces, x, 0.005, &culled);
  const int first_b = static_cast<int>(a.faces.rows());
  int across = 0;
  for (const auto& [f, g] : pairs) across += (f < first_b) != (g < first_b);
  EXPECT_GT(across, 50);
  EXPECT_GE(culled, 2);  // each sheet on its own is culled
}

TEST(SelfCulling, ASheetTurningOverTheStepIsNotCulled) {
  // A flat sheet whose end position is turned 150 degrees about the z axis: over the step its
  // normals sweep 150 degrees, so no cone holding them all is narrower than 75 degrees, wider
  // than any culled cone (60): no node is culled and every pair the boxes give is kept. Turned
  // 20 degrees, the whole sheet is still one patch.
  const Grid grid(12);
  std::vector<Aabb> boxes;
  auto turned = [&](double degrees) {
    const double a = degrees * 3.14159265358979323846 / 180.0;
    Positions end = grid.x;
    for (int v = 0; v < end.rows(); ++v) {
      const double px = grid.x(v, 0), py = grid.x(v, 1);
      end(v, 0) = std::cos(a) * px - std::sin(a) * py;
      end(v, 1) = std::sin(a) * px + std::cos(a) * py;
    }
    return end;
  };
  const std::vector<char> all_self(grid.faces.rows(), 1);
  for (const double degrees : {150.0, 20.0}) {
    const Positions end = turned(degrees);
    triangle_boxes(grid.faces, grid.x, end, std::vector<double>(grid.faces.rows(), 0.001), boxes);
    AabbTree tree;
    tree.build(boxes);
    SelfCollisionCulling culling;
    culling.rebuild(tree, grid.faces, all_self);
    const int culled = culling.update(tree, grid.faces, grid.x, end, 0.001);
    std::vector<std::pair<int, int>> all, kept;
    tree.self_pairs(all);
    tree.self_pairs(kept, &culling.culled());
    if (degrees > 120.0) {
      EXPECT_EQ(culled, 0);
      EXPECT_EQ(kept.size(), all.size());
    } else {
      EXPECT_EQ(culled, 1);  // the root
      EXPECT_TRUE(kept.empty());
    }
  }
}

TEST(SelfCulling, AnIncrementalUpdateCullsAsAFullOne) {
  // A wavy sheet moving over a step; then, again and again, a few vertices get a new end
  // position (as CCD impulses change them): update_changed must give what a full update gives,
  // and a full update on two threads what it gives on one.
  const int n = 16;
  Grid grid(n);
  for (int v = 0; v < grid.x.rows(); ++v) grid.x(v, 1) = 0.004 * std::sin(40.0 * grid.x(v, 0)) * std::cos(30.0 * grid.x(v, 2));
  Positions end = grid.x;
  for (int v = 0; v < end.rows(); ++v) end(v, 1) += 0.001 * std::sin(7.0 * v);
  std::vector<Aabb> boxes;
  triangle_boxes(grid.faces, grid.x, end, std::vector<double>(grid.faces.rows(), 0.0005), boxes);
  AabbTree tree;
  tree.build(boxes);
  const std::vector<char> all_self(grid.faces.rows(), 1);
  SelfCollisionCulling incremental, full, two_threads;
  incremental.rebuild(tree, grid.faces, all_self);
  full.rebuild(tree, grid.faces, all_self);
  two_threads.rebuild(tree, grid.faces, all_self);
  const double margin = 0.0005;
  incremental.update(tree, grid.faces, grid.x, end, margin);
  int differing_updates = 0;
  for (int round = 0; round < 40; ++round) {
    // Kick a few vertices: some so hard that their patches fold (cones over 60 degrees).
    std::vector<char> changed_vertex(end.rows(), 0);
    for (int k = 0; k < 3; ++k) {
      const int v = (round * 37 + k * 101) % static_cast<int>(end.rows());
      end(v, 1) += (round % 3 == 0 ? 0.02 : 0.0005) * (k % 2 ? 1.0 : -1.0);
      changed_vertex[v] = 1;
    }
    std::vector<char> face_changed(grid.faces.rows(), 0);
    for (int f = 0; f < grid.faces.rows(); ++f)
      for (int c = 0; c < 3; ++c) face_changed[f] |= changed_vertex[grid.faces(f, c)];
    const std::vector<char> before = incremental.culled();
    const int culled = incremental.update_changed(tree, grid.faces, grid.x, end, margin, face_changed);
    const int expected = full.update(tree, grid.faces, grid.x, end, margin);
    ASSERT_EQ(incremental.culled(), full.culled()) << "round " << round;
    EXPECT_EQ(culled, expected);
    // The tests of one tree depth run in parallel: the same nodes culled on two threads.
    EXPECT_EQ(expected, two_threads.update(tree, grid.faces, grid.x, end, margin, 2));
    ASSERT_EQ(two_threads.culled(), full.culled()) << "round " << round;
    differing_updates += incremental.culled() != before;
  }
  EXPECT_GT(differing_updates, 5);  // the kicks did change what is culled
  // A different margin is not an incremental change: a full update.
  incremental.update_changed(tree, grid.faces, grid.x, end, 0.01, std::vector<char>(grid.faces.rows(), 0));
  full.update(tree, grid.faces, grid.x, end, 0.01);
  EXPECT_EQ(incremental.culled(), full.culled());
}

}  // namespace
}  // namespace weft

namespace weft {
namespace {

// A tree whose grid cells are pairs of sibling faces (AabbTree::build with
// pair_faces_across_edges) has edge-connected nodes, so a sheet bent into a half cylinder, too
// curved to be one patch, is culled in large patches: it lists less than half the pairs that a
// tree of box centres lists (the two faces of a cell share a box, and split by index they made
// nodes of faces that touch at corners only, which are never culled).
TEST(SelfCulling, ATreeOfPairedCellsCullsACurvedSheetInLargePatches) {
  const int n = 24;
  Grid grid(n);
  const double radius = 0.23 / 2.6;  // 2.6 radians of arc over the sheet
  for (int v = 0; v < grid.x.rows(); ++v) {
    const double s = grid.x(v, 0), z = grid.x(v, 2);
    grid.x.row(v) << radius * std::sin(s / radius), radius * (1.0 - std::cos(s / radius)), z;
  }
  const double margin = 0.002;
  auto listed = [&](bool paired) {
    std::vector<Aabb> boxes;
    triangle_boxes(grid.faces, grid.x, grid.x, std::vector<double>(grid.faces.rows(), margin), boxes);
    AabbTree tree;
    if (paired)
      tree.build(boxes, pair_faces_across_edges(grid.faces, grid.x));
    else
      tree.build(boxes);
    SelfCollisionCulling culling;
    culling.rebuild(tree, grid.faces, std::vector<char>(grid.faces.rows(), 1));
    culling.update(tree, grid.faces, grid.x, grid.x, margin);
    EXPECT_EQ(culling.culled()[0], 0);  // too curved to be one patch
    std::vector<std::pair<int, int>> pairs;
    tree.self_pairs(pairs, &culling.culled());
    return pairs.size();
  };
  const size_t paired = listed(true), plain = listed(false);
  EXPECT_GT(paired, 0u);
  EXPECT_LT(2 * paired, plain) << paired << " against " << plain;
}

}  // namespace
}  // namespace weft
