// The pre-filtered PCG (Tamstorf et al. 2015) on a small dense SPD system with constraints.
#include <gtest/gtest.h>

#include <random>

#include "weft/linear_system/pcg.h"

using namespace weft;

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
