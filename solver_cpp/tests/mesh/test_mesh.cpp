// ClothMesh: rest frames, hinges, lumped areas, malformed input, edge strain.
#include <gtest/gtest.h>

#include <cmath>

#include "weft/mesh/mesh.h"

using namespace weft;

namespace {
ClothMesh unit_square() {
  Faces faces(2, 3);
  faces << 0, 1, 2, 1, 3, 2;
  FaceUVs uv(2, 6);
  uv << 0, 0, 1, 0, 0, 1,  //
      1, 0, 1, 1, 0, 1;
  return build_cloth_mesh(4, faces, uv, Positions());
}
}  // namespace

TEST(Mesh, SquareHasOneHingeAndLumpedAreas) {
  const ClothMesh mesh = unit_square();
  ASSERT_EQ(mesh.hinges.size(), 1u);
  EXPECT_DOUBLE_EQ(mesh.rest_area[0], 0.5);
  double total = 0.0;
  for (double a : mesh.vertex_rest_area) total += a;
  EXPECT_DOUBLE_EQ(total, 1.0);
  // Shared edge is the diagonal (1, 2): length^2 = 2, weight = 3 * 2 / 1.
  EXPECT_DOUBLE_EQ(mesh.hinge_weight[0], 6.0);
  EXPECT_DOUBLE_EQ(mesh.hinge_rest_angle[0], 0.0);
}

TEST(Mesh, RejectsOutOfRangeAndDegenerateFaces) {
  Faces faces(1, 3);
  faces << 0, 1, 5;
  FaceUVs uv(1, 6);
  uv << 0, 0, 1, 0, 0, 1;
  EXPECT_THROW(build_cloth_mesh(3, faces, uv, Positions()), MeshError);
  faces << 0, 1, 2;
  uv << 0, 0, 1, 0, 2, 0;  // collinear
  EXPECT_THROW(build_cloth_mesh(3, faces, uv, Positions()), MeshError);
}

TEST(Mesh, EdgeStrainIsOneAtRestAndFollowsAStretch) {
  const ClothMesh mesh = unit_square();
  Positions x(4, 3);
  x << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0;
  EXPECT_NEAR(max_edge_strain(mesh, x), 1.0, 1e-12);
  x.col(0) *= 1.5;  // stretched by half along u: the u edges and the diagonal's u part
  EXPECT_NEAR(max_edge_strain(mesh, x), 1.5, 1e-12);
  const auto& rest = mesh.rest_edge_length;
  EXPECT_NEAR(rest[0][0], 1.0, 1e-12);            // (0, 1)
  EXPECT_NEAR(rest[0][1], std::sqrt(2.0), 1e-12);  // (1, 2), the diagonal
}
