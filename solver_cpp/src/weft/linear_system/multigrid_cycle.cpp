// The V-cycle of the smoothed-aggregation hierarchy (multigrid.h): Chebyshev smoothing, the
// residual's restriction, the coarse correction's prolongation; the hierarchy's setup is in
// multigrid.cpp.
#include "weft/linear_system/multigrid.h"

#include <stdexcept>

namespace weft {

const float* SmoothedAggregation::smooth(const Level& level, const VectorX& f, VectorX& x, bool zero_start,
                                        const float* x_rounded, bool round_result, int threads) const {
  // Chebyshev iteration for D^-1 A on [lower, upper] (Saad, Iterative Methods, alg. 12.1). Each
  // product is fused with the update that consumes it (BcrsMatrix::multiply_rows): rr, d and x
  // are rewritten row by row while the product reads a float32 copy of the multiplied vector,
  // which the update before it wrote (multiply_rows_rounded; two copies in turn, one read while
  // the other is written). rr and d are stored only where a later step reads them: not by the
  // last step, and not by the first from a zero start (there rr = D^-1 f and d = x, which the
  // second step recomputes and reads). The same bits as separate passes.
  const int n = level.a.rows;
  const int degree = options_.smoother_degree;
  const double upper = options_.upper_factor * level.rho, lower = options_.lower_ratio * upper;
  const double theta = 0.5 * (upper + lower), delta = 0.5 * (upper - lower), sigma = theta / delta;
  VectorX& rr = level.rr;
  VectorX& d = level.d;
  for (auto& copy : level.rounded) copy.resize(4 * static_cast<size_t>(n));
  if (x_rounded && !zero_start && x_rounded != level.rounded[1].data())
    throw std::logic_error("multigrid smooth: a rounded x must be in the level's second copy");
  float* first_out = level.rounded[0].data();
  // First step: rr = D^-1 (f - A x), d = rr / theta, x += d (x = d from a zero start).
  auto first = [&](int i, const Vec3& ax) {
    const Vec3 ri = level.inverse_diagonal[i] * Vec3(f.segment<3>(3 * i) - ax);
    const Vec3 di = ri / theta;
    if (zero_start) {
      x.segment<3>(3 * i) = di;
    } else {
      x.segment<3>(3 * i) += di;
      rr.segment<3>(3 * i) = ri;
      d.segment<3>(3 * i) = di;
    }
    if (degree > 1)
      BcrsMatrix<float>::store_rounded(first_out, i, di.x(), di.y(), di.z());
    else if (round_result)
      BcrsMatrix<float>::store_rounded(first_out, i, x[3 * i], x[3 * i + 1], x[3 * i + 2]);
  };
  if (zero_start) {
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1)
    for (int i = 0; i < n; ++i) first(i, Vec3::Zero());
  } else if (x_rounded) {
    level.kernel.multiply_rows_rounded(x_rounded, threads,
                                       [&](int i, double y0, double y1, double y2) { first(i, Vec3(y0, y1, y2)); });
  } else {
    level.kernel.multiply_rows(x.data(), threads,
                               [&](int i, double y0, double y1, double y2) { first(i, Vec3(y0, y1, y2)); });
  }
  int current = 0;  // the copy holding the last step's d (or, after the last step, x)
  double rho_old = 1.0 / sigma;
  for (int k = 1; k < degree; ++k) {
    const double rho_new = 1.0 / (2.0 * sigma - rho_old);
    const double c1 = rho_new * rho_old, c2 = 2.0 * rho_new / delta;
    const bool last = k + 1 == degree, after_zero_start = zero_start && k == 1;
    float* out = level.rounded[1 - current].data();
    level.kernel.multiply_rows_rounded(level.rounded[current].data(), threads,
                                       [&](int i, double y0, double y1, double y2) {
      const Vec3 r_before = after_zero_start ? Vec3(level.inverse_diagonal[i] * Vec3(f.segment<3>(3 * i) - Vec3::Zero()))
                                             : Vec3(rr.segment<3>(3 * i));
      const Vec3 d_before = after_zero_start ? Vec3(x.segment<3>(3 * i)) : Vec3(d.segment<3>(3 * i));
      const Vec3 ri = r_before - level.inverse_diagonal[i] * Vec3(y0, y1, y2);
      const Vec3 di = c1 * d_before + c2 * ri;
      x.segment<3>(3 * i) += di;
      if (!last) {
        rr.segment<3>(3 * i) = ri;
        d.segment<3>(3 * i) = di;
        BcrsMatrix<float>::store_rounded(out, i, di.x(), di.y(), di.z());
      } else if (round_result) {
        BcrsMatrix<float>::store_rounded(out, i, x[3 * i], x[3 * i + 1], x[3 * i + 2]);
      }
    });
    current = 1 - current;
    rho_old = rho_new;
  }
  return round_result ? level.rounded[current].data() : nullptr;
}

void SmoothedAggregation::cycle(int l, const VectorX& f, VectorX& x, int threads) const {
  const Level& level = levels_[l];
  if (l + 1 == levels()) {
    x = coarse_solver_.solve(f);
    return;
  }
  const int th = level_threads(level.a.rows, threads);
  const Level& next = levels_[l + 1];
  // The pre-smoothing's last update rounds x for the residual's product.
  const float* smoothed = smooth(level, f, x, true, nullptr, true, th);
  VectorX& res = level.res;
  level.kernel.multiply_rows_rounded(smoothed, th, [&](int i, double y0, double y1, double y2) {
    res.segment<3>(3 * i) = f.segment<3>(3 * i) - Vec3(y0, y1, y2);
  });
  level.r.multiply(res, next.f, level_threads(next.a.rows, threads));
  cycle(l + 1, next.f, next.x, threads);
  // x += P x_c, rounded on the way for the post-smoothing's first product (the first step
  // writes its own rounded d into the other copy).
  level.p.multiply(next.x, x, th, true, level.rounded[1].data());
  smooth(level, f, x, false, level.rounded[1].data(), false, th);
}

void SmoothedAggregation::apply(const VectorX& r, VectorX& z, int threads) const {
  const Level& fine = levels_[0];
  if (r.size() != 3 * static_cast<Eigen::Index>(fine.a.rows)) throw std::invalid_argument("multigrid: wrong vector size");
  z.resize(r.size());
  cycle(0, r, z, threads);
}

}  // namespace weft
