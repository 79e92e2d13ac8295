// Fixed-order parallel reductions. The range is cut into chunks of a fixed size (independent of
// the thread count); each chunk is summed sequentially by whichever thread owns it and the chunk
// partials are then added in chunk order by one thread. The result is therefore bitwise the same
// for any number of threads, which the regression CI relies on (caches compared bit for bit).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

namespace weft {

// Small enough that a 10k-vertex system splits evenly over a few threads (the SpMV and the CG
// passes are scheduled by these chunks too).
constexpr std::int64_t kReductionChunk = 1024;

// term_range(begin, end) returns std::array<double, K>: the K sums over [begin, end), in order.
template <int K, class TermRange>
std::array<double, K> ordered_sums(std::int64_t n, int threads, TermRange&& term_range) {
  const std::int64_t chunks = (n + kReductionChunk - 1) / kReductionChunk;
  std::array<double, K> total{};
  if (chunks <= 1) return n > 0 ? term_range(std::int64_t{0}, n) : total;
  std::vector<std::array<double, K>> partial(static_cast<size_t>(chunks));
#pragma omp parallel for schedule(static) num_threads(threads)
  for (std::int64_t c = 0; c < chunks; ++c) {
    const std::int64_t begin = c * kReductionChunk;
    const std::int64_t end = begin + kReductionChunk < n ? begin + kReductionChunk : n;
    partial[static_cast<size_t>(c)] = term_range(begin, end);
  }
  for (const auto& p : partial)
    for (int k = 0; k < K; ++k) total[k] += p[k];
  return total;
}

// Sum of values[i], fixed order.
inline double ordered_sum(const std::vector<double>& values, int threads) {
  return ordered_sums<1>(static_cast<std::int64_t>(values.size()), threads, [&](std::int64_t b, std::int64_t e) {
    double s = 0.0;
    for (std::int64_t i = b; i < e; ++i) s += values[static_cast<size_t>(i)];
    return std::array<double, 1>{s};
  })[0];
}

}  // namespace weft
