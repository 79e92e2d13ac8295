// Pre-filtered preconditioned conjugate gradients (Tamstorf, Jones & McCormick 2015).
//
// Each vertex i carries a filter S_i (orthogonal projection onto its unconstrained directions)
// and a prescribed value z_i in its constrained directions. Instead of Baraff-Witkin's modified
// PCG we solve the symmetric system
//     (S A S + I - S) y = S (b - A z),    x = y + z,
// so constraints hold exactly (y has no component in constrained directions) and any SPD
// preconditioner applies: 3x3 block Jacobi of the filtered matrix (fused into the vector pass),
// or a caller's SPD operator B applied as z = S B S r (multigrid.h).
#pragma once

#include <Eigen/Dense>
#include <cmath>
#include <cstddef>
#include <limits>
#include <type_traits>

#include "weft/common/ordered_sum.h"

#include "weft/common/types.h"

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
  double preconditioner_setup_seconds = 0.0;  // multigrid: hierarchy values (and structure, first solve)
};

// apply_matrix(in, out) computes out = A in (out already sized). It may instead take a third
// argument, double* chunk_dots, and then also write the fixed-order partial sums of in . out per
// chunk of kReductionChunk vertices (or ignore a null pointer): the dot of the CG step is then
// fused into the matrix pass. x holds an initial guess on
// entry and the solution on exit. Vector updates run on `threads` threads; every dot product is
// a fixed-order chunked sum (ordered_sum.h), so the iterates are bitwise independent of the
// thread count. The filter is applied only at its constrained vertices.
// precondition: nullptr for block Jacobi of the filtered diagonal blocks, or a callable
// (const VectorX& r, VectorX& z) applying an SPD operator B; CG then uses z = S B S r.
template <class ApplyMatrix, class Precondition = std::nullptr_t>
PcgStats prefiltered_pcg(const ApplyMatrix& apply_matrix, const std::vector<Mat3>& diagonal_blocks,
                         const ConstraintFilter& filter, const VectorX& b, VectorX& x, const PcgSettings& settings,
                         int threads = 1, const Precondition& precondition = nullptr) {
  constexpr bool custom = !std::is_same_v<Precondition, std::nullptr_t>;
  const Eigen::Index n = b.size();
  const std::int64_t vertex_count = n / 3;
  PcgStats stats;
  VectorX tmp(n), r(n), z(n), p(n), q(n), y(n);

  std::vector<int> constrained;
  if (filter.constrained_vertices > 0)
    for (std::int64_t i = 0; i < vertex_count; ++i)
      if (filter.projection[i] != Mat3::Identity()) constrained.push_back(static_cast<int>(i));
  auto apply_filter = [&](VectorX& vec) {
    for (int i : constrained) vec.segment<3>(3 * i) = filter.projection[i] * vec.segment<3>(3 * i);
  };
  // Sums over vertex ranges [begin, end) of a per-vertex term, K at a time, fixed order.
  auto vertex_sums = [&](auto k_const, auto&& term) {
    constexpr int K = decltype(k_const)::value;
    return ordered_sums<K>(vertex_count, threads, [&](std::int64_t begin, std::int64_t end) {
      std::array<double, K> s{};
      for (std::int64_t i = begin; i < end; ++i) term(i, s);
      return s;
    });
  };
  using One = std::integral_constant<int, 1>;
  using Two = std::integral_constant<int, 2>;
  constexpr bool fused = std::is_invocable_v<const ApplyMatrix&, const VectorX&, VectorX&, double*>;
  auto multiply = [&](const VectorX& in, VectorX& out) {
    if constexpr (fused)
      apply_matrix(in, out, nullptr);
    else
      apply_matrix(in, out);
  };
  // out = S A in; returns in . out (fixed order).
  std::vector<double> chunk_dots(static_cast<size_t>((vertex_count + kReductionChunk - 1) / kReductionChunk));
  std::vector<Vec3> unfiltered;
  auto multiply_filtered_dot = [&](const VectorX& in, VectorX& out) {
    if constexpr (fused) {
      apply_matrix(in, out, chunk_dots.data());
      unfiltered.clear();
      for (int i : constrained) unfiltered.push_back(out.segment<3>(3 * i));
      apply_filter(out);
      double dot = 0.0;
      for (double c : chunk_dots) dot += c;
      for (size_t k = 0; k < constrained.size(); ++k) {  // the chunks summed A in; correct to S A in
        const Vec3 xi = in.segment<3>(3 * constrained[k]);
        dot += xi.dot(out.segment<3>(3 * constrained[k])) - xi.dot(unfiltered[k]);
      }
      return dot;
    } else {
      apply_matrix(in, out);
      apply_filter(out);
      return vertex_sums(One{}, [&](std::int64_t i, std::array<double, 1>& s) {
        s[0] += in.segment<3>(3 * i).dot(out.segment<3>(3 * i));
      })[0];
    }
  };

  // Right-hand side of the filtered system.
  multiply(filter.prescribed, tmp);
  VectorX rhs = b - tmp;
  apply_filter(rhs);
  const double rhs_norm = std::sqrt(vertex_sums(One{}, [&](std::int64_t i, std::array<double, 1>& s) {
    s[0] += rhs.segment<3>(3 * i).squaredNorm();
  })[0]);

  // Block-Jacobi preconditioner of S A S + I - S.
  std::vector<Mat3> inverse_blocks(custom ? 0 : vertex_count);
  if constexpr (!custom) {
#pragma omp parallel for schedule(static) num_threads(threads)
    for (std::int64_t i = 0; i < vertex_count; ++i) inverse_blocks[i] = diagonal_blocks[i].inverse();
    for (int i : constrained) {
      const Mat3& s = filter.projection[i];
      inverse_blocks[i] = (s * diagonal_blocks[i] * s + (Mat3::Identity() - s)).inverse();
    }
  }
  // Caller's preconditioner: z = S B S r; returns r . z (fixed order).
  auto precondition_dot = [&]() {
    if constexpr (custom) {
#pragma omp parallel for schedule(static) num_threads(threads)
      for (Eigen::Index k = 0; k < n; ++k) tmp[k] = r[k];
      apply_filter(tmp);
      precondition(tmp, z);
      apply_filter(z);
    }
    return vertex_sums(One{}, [&](std::int64_t i, std::array<double, 1>& s) {
      s[0] += r.segment<3>(3 * i).dot(z.segment<3>(3 * i));
    })[0];
  };

  y = x;
  apply_filter(y);
  if (!std::isfinite(rhs_norm)) {
    // Non-finite forces or matrix: report it as such (a non-finite solution) rather than a
    // quiet zero update, so the integrator fails the step with a clear reason.
    x.setConstant(std::numeric_limits<double>::quiet_NaN());
    stats.converged = false;
    stats.relative_residual = rhs_norm;
    return stats;
  }
  if (rhs_norm == 0.0) {
    y.setZero();
    x = y + filter.prescribed;
    stats.converged = true;
    stats.relative_residual = 0.0;
    return stats;
  }
  multiply(y, tmp);
  apply_filter(tmp);
  // The warm start scaled to its best multiple, alpha y with alpha = (y . rhs) / (y . S A S y):
  // the least error in the energy norm along y (never more than y's or a zero start's). A
  // previous substep's velocity change on cloth come to rest is often more wrong than zero
  // (docs/multigrid.md, "Warm start").
  const auto fit = vertex_sums(Two{}, [&](std::int64_t i, std::array<double, 2>& s) {
    s[0] += y.segment<3>(3 * i).dot(tmp.segment<3>(3 * i));
    s[1] += y.segment<3>(3 * i).dot(rhs.segment<3>(3 * i));
  });
  const double scale = fit[0] > 0.0 && std::isfinite(fit[1] / fit[0]) ? std::max(fit[1] / fit[0], 0.0) : 1.0;
  // r = rhs - S A S y; z = P r; p = z.
  auto start = vertex_sums(Two{}, [&](std::int64_t i, std::array<double, 2>& s) {
    y.segment<3>(3 * i) *= scale;
    const Vec3 ri = rhs.segment<3>(3 * i) - scale * tmp.segment<3>(3 * i);
    r.segment<3>(3 * i) = ri;
    s[0] += ri.squaredNorm();
    if constexpr (!custom) {
      const Vec3 zi = inverse_blocks[i] * ri;
      z.segment<3>(3 * i) = zi;
      p.segment<3>(3 * i) = zi;
      s[1] += ri.dot(zi);
    }
  });
  if constexpr (custom) {
    start[1] = precondition_dot();
    p = z;
  }
  double residual_norm = std::sqrt(start[0]);
  double rz = start[1];
  while (residual_norm > settings.tolerance * rhs_norm && stats.iterations < settings.max_iterations) {
    const double pq = multiply_filtered_dot(p, q);
    if (!(pq > 0.0)) break;  // loss of positive definiteness or breakdown: keep what we have
    const double alpha = rz / pq;
    // y += alpha p; r -= alpha q; z = P r; with |r|^2 and r.z in the same pass.
    auto sums = vertex_sums(Two{}, [&](std::int64_t i, std::array<double, 2>& s) {
      y.segment<3>(3 * i) += alpha * p.segment<3>(3 * i);
      const Vec3 ri = r.segment<3>(3 * i) - alpha * q.segment<3>(3 * i);
      r.segment<3>(3 * i) = ri;
      s[0] += ri.squaredNorm();
      if constexpr (!custom) {
        const Vec3 zi = inverse_blocks[i] * ri;
        z.segment<3>(3 * i) = zi;
        s[1] += ri.dot(zi);
      }
    });
    residual_norm = std::sqrt(sums[0]);
    ++stats.iterations;
    if constexpr (custom) {  // a V-cycle is worth skipping after the last iteration
      if (residual_norm <= settings.tolerance * rhs_norm || stats.iterations >= settings.max_iterations) break;
      sums[1] = precondition_dot();
      if (!(sums[1] > 0.0)) break;  // B not positive on r: breakdown, keep what we have
    }
    const double beta = sums[1] / rz;
    rz = sums[1];
#pragma omp parallel for schedule(static) num_threads(threads)
    for (Eigen::Index k = 0; k < n; ++k) p[k] = z[k] + beta * p[k];
  }
  stats.relative_residual = residual_norm / rhs_norm;
  stats.converged = residual_norm <= settings.tolerance * rhs_norm;
  x = y + filter.prescribed;
  return stats;
}

}  // namespace weft
