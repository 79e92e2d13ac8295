// Fixed-order parallel list building, the companion of ordered_sum.h: items [0, count) are cut
// into chunks of a fixed size, each chunk appends its results to a list of its own (items in
// order), and the chunk lists are appended to the output in chunk order by one thread. The
// output is therefore the serial one, element for element, for any number of threads.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

namespace weft {

// produce(item, list) appends item's results (any number) to list. `chunks` is scratch that
// callers on a hot path keep between calls (its lists keep their capacity).
template <class T, class Produce>
void ordered_append(std::int64_t count, std::int64_t chunk, int threads, std::vector<T>& out,
                    std::vector<std::vector<T>>& chunks, Produce&& produce) {
  const std::int64_t chunk_count = (count + chunk - 1) / chunk;
  if (static_cast<std::int64_t>(chunks.size()) < chunk_count) chunks.resize(static_cast<size_t>(chunk_count));
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads) if (threads > 1 && chunk_count > 1)
  for (std::int64_t c = 0; c < chunk_count; ++c) {
    std::vector<T>& list = chunks[static_cast<size_t>(c)];
    list.clear();
    for (std::int64_t item = c * chunk; item < std::min(count, (c + 1) * chunk); ++item) produce(item, list);
  }
  for (std::int64_t c = 0; c < chunk_count; ++c) {
    const std::vector<T>& list = chunks[static_cast<size_t>(c)];
    out.insert(out.end(), list.begin(), list.end());
  }
}

template <class T, class Produce>
void ordered_append(std::int64_t count, std::int64_t chunk, int threads, std::vector<T>& out, Produce&& produce) {
  std::vector<std::vector<T>> chunks;
  ordered_append(count, chunk, threads, out, chunks, produce);
}

}  // namespace weft
