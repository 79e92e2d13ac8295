// Pre-filtered preconditioned conjugate gradients (Tamstorf, Jones & McCormick 2015).
//
// Each vertex i carries a filter S_i (orthogonal projection onto its unconstrained directions)
// and a prescribed value z_i in its constrained directions. Instead of Baraff-Witkin's modified
// PCG we solve the symmetric system
//     (S A S + I - S) y = S (b - A z),    x = y + z,
// so constraints hold exactly (y has no component in constrained directions) and any SPD
// preconditioner applies. The preconditioner here is 3x3 block Jacobi of the filtered matrix.
#pragma once

#include <Eigen/Dense>
#include <cmath>

#include "types.h"

namespace weft {

struct ConstraintFilter {
  std::vector<Mat3> projection;  // S_i
  VectorX prescribed;            // z, zero in free directions
  int constrained_vertices = 0;

  void reset(int vertex_count) {
    projection.assign(vertex_count, Mat3::Identity());
    prescribed.setZero(3 * vertex_count);
    constrained_vertices = 0;
  }
  // All three directions of vertex i prescribed.
  void constrain_fully(int i, const Vec3& value) {
    projection[i].setZero();
    prescribed.segment<3>(3 * i) = value;
    ++constrained_vertices;
  }
  // Only direction n (unit) prescribed, e.g. a contact normal.
  void constrain_direction(int i, const Vec3& n, double value) {
    projection[i] -= n * n.transpose();
    prescribed.segment<3>(3 * i) += value * n;
    ++constrained_vertices;
  }
  void apply(VectorX& vec) const {
    if (constrained_vertices == 0) return;
    for (size_t i = 0; i < projection.size(); ++i) vec.segment<3>(3 * i) = projection[i] * vec.segment<3>(3 * i);
  }
};

struct PcgSettings {
  double tolerance = 1e-5;  // on ||r|| / ||S (b - A z)||
  int max_iterations = 500;
};

struct PcgStats {
  int iterations = 0;
  double relative_residual = 0.0;
  bool converged = false;
};

// apply_matrix(in, out) computes out = A in. x holds an initial guess on entry and the
// solution on exit.
template <class ApplyMatrix>
PcgStats prefiltered_pcg(const ApplyMatrix& apply_matrix, const std::vector<Mat3>& diagonal_blocks,
                         const ConstraintFilter& filter, const VectorX& b, VectorX& x, const PcgSettings& settings) {
  const Eigen::Index n = b.size();
  const int vertex_count = static_cast<int>(n / 3);
  PcgStats stats;
  VectorX tmp(n), r(n), z(n), p(n), q(n);

  // Right-hand side of the filtered system.
  apply_matrix(filter.prescribed, tmp);
  VectorX rhs = b - tmp;
  filter.apply(rhs);
  const double rhs_norm = rhs.norm();

  // Block-Jacobi preconditioner of S A S + I - S.
  std::vector<Mat3> inverse_blocks(vertex_count);
  for (int i = 0; i < vertex_count; ++i) {
    const Mat3& s = filter.projection[i];
    const Mat3 block = s * diagonal_blocks[i] * s + (Mat3::Identity() - s);
    inverse_blocks[i] = block.inverse();
  }
  auto precondition = [&](const VectorX& in, VectorX& out) {
    for (int i = 0; i < vertex_count; ++i) out.segment<3>(3 * i) = inverse_blocks[i] * in.segment<3>(3 * i);
  };

  VectorX y = x;
  filter.apply(y);
  if (rhs_norm == 0.0 || !std::isfinite(rhs_norm)) {
    y.setZero();
    x = y + filter.prescribed;
    stats.converged = rhs_norm == 0.0;
    stats.relative_residual = rhs_norm == 0.0 ? 0.0 : rhs_norm;
    return stats;
  }
  apply_matrix(y, tmp);
  filter.apply(tmp);
  r = rhs - tmp;
  double residual_norm = r.norm();
  precondition(r, z);
  p = z;
  double rz = r.dot(z);
  while (residual_norm > settings.tolerance * rhs_norm && stats.iterations < settings.max_iterations) {
    apply_matrix(p, q);
    filter.apply(q);
    const double pq = p.dot(q);
    if (!(pq > 0.0)) break;  // loss of positive definiteness or breakdown: keep what we have
    const double alpha = rz / pq;
    y += alpha * p;
    r -= alpha * q;
    residual_norm = r.norm();
    ++stats.iterations;
    precondition(r, z);
    const double rz_next = r.dot(z);
    p = z + (rz_next / rz) * p;
    rz = rz_next;
  }
  stats.relative_residual = residual_norm / rhs_norm;
  stats.converged = residual_norm <= settings.tolerance * rhs_norm;
  x = y + filter.prescribed;
  return stats;
}

}  // namespace weft
