// The pre-filtered PCG (Tamstorf et al. 2015) on a small dense SPD system with constraints.
#include <gtest/gtest.h>

#include <random>

#include "weft/linear_system/pcg.h"

using namespace weft;

namespace {

// A random dense SPD system of 10 vertices, its diagonal blocks and a rhs.
struct DenseSystem {
  Eigen::MatrixXd a;
  VectorX rhs;
  std::vector<Mat3> diag;
};

DenseSystem dense_system(int n, unsigned seed) {
  std::mt19937 gen(seed);
  std::normal_distribution<double> normal;
  Eigen::MatrixXd b_mat(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) b_mat(i, j) = normal(gen);
  const Eigen::MatrixXd a = b_mat * b_mat.transpose() + n * Eigen::MatrixXd::Identity(n, n);
  VectorX rhs(n);
  for (int i = 0; i < n; ++i) rhs[i] = normal(gen);
  std::vector<Mat3> diag(n / 3);
  for (int i = 0; i < n / 3; ++i) diag[i] = a.block<3, 3>(3 * i, 3 * i);
  return {a, rhs, diag};
}

}  // namespace

TEST(Pcg, SolvesSpdSystemAndHonoursConstraintsExactly) {
  const int n = 30;  // 10 vertices
  const auto [a, rhs, diag] = dense_system(n, 7);
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

// The warm start is scaled to its best multiple (least energy-norm error along it): one pointing
// away from the solution (a resting cloth's last velocity change often does) starts CG as a
// zero start does, bit for bit, and one that is a multiple of the solution needs no iteration.
TEST(Pcg, ScalesTheWarmStartToItsBestMultiple) {
  const int n = 30;
  const auto [a, rhs, diag] = dense_system(n, 11);
  ConstraintFilter filter;
  filter.reset(n / 3);
  filter.constrain_direction(4, Vec3(0, 1, 1).normalized(), -0.5);
  auto apply = [&a](const VectorX& in, VectorX& out) { out = a * in; };
  const PcgSettings settings{1e-10, 200};
  VectorX from_zero = VectorX::Zero(n);
  const PcgStats zero_stats = prefiltered_pcg(apply, diag, filter, rhs, from_zero, settings);
  ASSERT_TRUE(zero_stats.converged);
  const VectorX solution = from_zero;

  VectorX away = -(solution - filter.prescribed);  // y . rhs < 0: scaled to zero
  const PcgStats away_stats = prefiltered_pcg(apply, diag, filter, rhs, away, settings);
  EXPECT_EQ(away_stats.iterations, zero_stats.iterations);
  EXPECT_EQ(away, from_zero);

  VectorX twice = 2.0 * (solution - filter.prescribed) + filter.prescribed;
  const PcgStats twice_stats = prefiltered_pcg(apply, diag, filter, rhs, twice, PcgSettings{1e-8, 200});
  EXPECT_EQ(twice_stats.iterations, 0);
  EXPECT_TRUE(twice_stats.converged);
  EXPECT_LT((twice - solution).norm(), 1e-8 * solution.norm());
}
