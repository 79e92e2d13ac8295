#include "bench_support.h"

#include <algorithm>
#include <memory>
#include <stdexcept>

#include "weft/common/timer.h"
#include "weft/linear_system/fast_linear_system.h"
#include "weft/linear_system/linear_system.h"

namespace weft {

namespace {
double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

template <class F>
auto with_fast(LinearSystemPath& path, F&& f) {
  if (auto* p = dynamic_cast<FastLinearSystem<float>*>(&path)) return f(*p);
  if (auto* p = dynamic_cast<FastLinearSystem<double>*>(&path)) return f(*p);
  throw std::invalid_argument("this measurement needs the fast linear system");
}
}  // namespace

double stream_triad_bandwidth(long long n, int repeats, int threads) {
  std::unique_ptr<double[]> a(new double[n]), b(new double[n]), c(new double[n]);
#pragma omp parallel for schedule(static) num_threads(threads)
  for (long long i = 0; i < n; ++i) {
    a[i] = 0.0;
    b[i] = 1.0;
    c[i] = 2.0;
  }
  const double s = 3.0;
  double best = 1e300;
  for (int k = 0; k < repeats; ++k) {
    const Timer t;
    double* pa = a.get();
    const double* pb = b.get();
    const double* pc = c.get();
#pragma omp parallel for schedule(static) num_threads(threads)
    for (long long i = 0; i < n; ++i) pa[i] = pb[i] + s * pc[i];
    best = std::min(best, t.seconds());
  }
  if (a[n / 2] != 7.0) throw std::runtime_error("triad check failed");
  return 24.0 * static_cast<double>(n) / best;
}

SpmvTiming time_spmv(LinearSystemPath& path, int repeats, int threads) {
  return with_fast(path, [&](auto& fast) {
    const auto& m = fast.matrix();
    VectorX x = VectorX::Ones(3 * m.rows()), y(3 * m.rows());
    m.multiply(x.data(), y.data(), threads);  // warm
    std::vector<double> times;
    for (int k = 0; k < repeats; ++k) {
      const Timer t;
      m.multiply(x.data(), y.data(), threads);
      times.push_back(t.seconds());
    }
    return SpmvTiming{median(times), m.bytes_per_multiply()};
  });
}

SolveComparison compare_with_eigen_cg(LinearSystemPath& path, const ConstraintFilter& filter, double tolerance,
                                      int max_iterations, int threads) {
  return with_fast(path, [&](auto& fast) {
    SolveComparison out;
    const int n = static_cast<int>(fast.order().size());
    VectorX dv = VectorX::Zero(3 * n);
    const Timer t;
    const PcgStats fs = fast.solve_with(filter, dv, PcgSettings{tolerance, max_iterations});
    out.fast_seconds = t.seconds();
    out.fast_iterations = fs.iterations;
    out.fast_residual = fs.relative_residual;
    const SparseMatrix a = fast.to_sparse_original();
    const VectorX b = fast.rhs_original();
    VectorX dv_eigen = VectorX::Zero(3 * n);
    const PcgStats es = eigen_cg_prefiltered(a, b, filter, dv_eigen,
                                             PcgSettings{std::max(fs.relative_residual, 1e-14), max_iterations * 20},
                                             threads, &out.eigen_seconds);
    out.eigen_iterations = es.iterations;
    out.eigen_residual = es.relative_residual;
    return out;
  });
}

}  // namespace weft
