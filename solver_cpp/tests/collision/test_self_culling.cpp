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

}  // namespace
}  // namespace weft
