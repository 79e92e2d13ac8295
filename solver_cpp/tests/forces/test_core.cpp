// Unit tests of the solver core's building blocks (ctest via GoogleTest).
#include <gtest/gtest.h>

#include <random>

#include "weft/bodies/constraints.h"
#include "weft/common/dual.h"
#include "weft/forces/forces.h"
#include "weft/mesh/mesh.h"
#include "weft/linear_system/pcg.h"

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

TEST(Dual, ProductQuotientAndSqrtDerivatives) {
  using D = Dual<3>;
  const D x = D::variable(2.0, 0), y = D::variable(3.0, 1), z = D::variable(4.0, 2);
  const D f = x * y / sqrt(z);  // 2*3/2 = 3
  EXPECT_DOUBLE_EQ(f.v, 3.0);
  EXPECT_DOUBLE_EQ(f.d[0], 3.0 / 2.0);            // y / sqrt(z)
  EXPECT_DOUBLE_EQ(f.d[1], 2.0 / 2.0);            // x / sqrt(z)
  EXPECT_DOUBLE_EQ(f.d[2], -0.5 * 6.0 / 8.0);     // -x y / (2 z^1.5)
}

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

TEST(Forces, RestStateHasNoForce) {
  Mat2 dm;
  dm << 1, 0, 0, 1;
  const MembraneResult m = membrane_element(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), dm.inverse(), 0.5, 100.0,
                                            80.0, 10.0, false);
  EXPECT_NEAR(m.energy, 0.0, 1e-15);
  EXPECT_NEAR(m.gradient.norm(), 0.0, 1e-12);
  // Rigid rotation of the triangle: still no force.
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  const MembraneResult rotated =
      membrane_element(r * Vec3(0, 0, 0), r * Vec3(1, 0, 0), r * Vec3(0, 1, 0), dm.inverse(), 0.5, 100.0, 80.0, 10.0, false);
  EXPECT_NEAR(rotated.gradient.norm(), 0.0, 1e-12);
}

TEST(Forces, StretchForceMatchesHookeanStrip) {
  // Stretch along u by 10%: energy = A k/2 (0.1)^2.
  Mat2 dm;
  dm << 1, 0, 0, 1;
  const MembraneResult m = membrane_element(Vec3(0, 0, 0), Vec3(1.1, 0, 0), Vec3(0, 1, 0), dm.inverse(), 0.5, 100.0,
                                            80.0, 0.0, false);
  EXPECT_NEAR(m.energy, 0.5 * 100.0 / 2 * 0.01, 1e-12);
}

TEST(Constraints, ClosestPointRegions) {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  EXPECT_TRUE(closest_point_barycentric(Vec3(-1, -1, 0), a, b, c).isApprox(Vec3(1, 0, 0)));
  EXPECT_TRUE(closest_point_barycentric(Vec3(0.25, 0.25, 3), a, b, c).isApprox(Vec3(0.5, 0.25, 0.25)));
  EXPECT_TRUE(closest_point_barycentric(Vec3(0.5, -2, 0), a, b, c).isApprox(Vec3(0.5, 0.5, 0)));
}

TEST(Pcg, SolvesSpdSystemAndHonoursConstraintsExactly) {
  const int n = 30;  // 10 vertices
  std::mt19937 gen(7);
  std::normal_distribution<double> normal;
  Eigen::MatrixXd b_mat(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) b_mat(i, j) = normal(gen);
  const Eigen::MatrixXd a = b_mat * b_mat.transpose() + n * Eigen::MatrixXd::Identity(n, n);
  VectorX rhs(n);
  for (int i = 0; i < n; ++i) rhs[i] = normal(gen);
  std::vector<Mat3> diag(n / 3);
  for (int i = 0; i < n / 3; ++i) diag[i] = a.block<3, 3>(3 * i, 3 * i);
  ConstraintFilter filter;
  filter.reset(n / 3);
  filter.constrain_fully(2, Vec3(1.0, -2.0, 0.5));
  const Vec3 normal_dir = Vec3(1, 1, 0).normalized();
  filter.constrain_direction(5, normal_dir, 0.25);
  VectorX x = VectorX::Zero(n);
  auto apply = [&a](const VectorX& in, VectorX& out) { out = a * in; };
  const PcgStats stats = prefiltered_pcg(apply, diag, filter, rhs, x, PcgSettings{1e-12, 200});
  EXPECT_TRUE(stats.converged);
  EXPECT_EQ(x.segment<3>(6), Vec3(1.0, -2.0, 0.5));              // exactly
  EXPECT_NEAR(x.segment<3>(15).dot(normal_dir), 0.25, 1e-13);   // to round-off of the projection
  // Free directions satisfy the equations: S (A x - b) = 0.
  VectorX r = a * x - rhs;
  filter.apply(r);
  EXPECT_LT(r.norm(), 1e-9 * rhs.norm());
}
