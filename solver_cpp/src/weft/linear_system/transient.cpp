#include "weft/linear_system/transient.h"

#include <algorithm>
#include <omp.h>
#include <stdexcept>
#include <string>

namespace weft {

void TransientElements::add(int i, int j, const Vec6& force, const Mat6& stiffness, const Mat6& damping) {
  if (i == j || i < 0 || j < 0) throw std::invalid_argument("transient element needs two distinct particles");
  elements_.push_back({i, j, force, stiffness, damping});
}

void TransientElements::add_spring(int i, int j, const Vec3& force_on_i, const Mat3& k, const Mat3& d) {
  Vec6 f;
  f << force_on_i, -force_on_i;
  Mat6 ks, ds;
  ks << k, -k, -k, k;
  ds << d, -d, -d, d;
  add(i, j, f, ks, ds);
}

namespace {
struct BlockEntry {
  int row, col;
  Mat3 a;
};
struct RhsEntry {
  int row;
  Vec3 b;
};
}  // namespace

void reduce_transient(const TransientElements& te, const std::vector<int>& new_of_old, const Positions& v, double h,
                      int threads, TransientRows& out) {
  const auto& elements = te.elements();
  const int count = static_cast<int>(elements.size());
  const int n = static_cast<int>(new_of_old.size());
  for (int r : out.rows) out.slot[r] = -1;
  out.rows.clear();
  out.start.assign(1, 0);
  out.columns.clear();
  out.blocks.clear();
  out.rhs.clear();
  if (count == 0) return;
  if (static_cast<int>(out.slot.size()) != n) out.slot.assign(n, -1);

  // Per-thread row accumulators. A static schedule hands each thread one contiguous range of
  // elements in thread order, so concatenating the threads' lists keeps element order.
  std::vector<std::vector<BlockEntry>> blocks(threads);
  std::vector<std::vector<RhsEntry>> rhs(threads);
#pragma omp parallel num_threads(threads)
  {
    const int t = omp_get_thread_num();
    auto& my_blocks = blocks[t];
    auto& my_rhs = rhs[t];
#pragma omp for schedule(static)
    for (int e = 0; e < count; ++e) {
      const TransientElement& el = elements[e];
      if (el.i >= n || el.j >= n) continue;  // validated below, outside the parallel region
      Vec6 v_local;
      v_local << row3(v, el.i), row3(v, el.j);
      const Vec6 b = h * (el.force - h * (el.stiffness * v_local));
      const Mat6 a = h * h * el.stiffness + h * el.damping;
      const int rows[2] = {new_of_old[el.i], new_of_old[el.j]};
      for (int p = 0; p < 2; ++p) {
        my_rhs.push_back({rows[p], b.segment<3>(3 * p)});
        for (int q = 0; q < 2; ++q) my_blocks.push_back({rows[p], rows[q], a.block<3, 3>(3 * p, 3 * q)});
      }
    }
    std::stable_sort(my_blocks.begin(), my_blocks.end(), [](const BlockEntry& x, const BlockEntry& y) { return x.row < y.row; });
    std::stable_sort(my_rhs.begin(), my_rhs.end(), [](const RhsEntry& x, const RhsEntry& y) { return x.row < y.row; });
  }
  for (const TransientElement& el : elements)
    if (el.i >= n || el.j >= n)
      throw std::invalid_argument("transient element references particle " + std::to_string(std::max(el.i, el.j)) +
                                  " of " + std::to_string(n));

  for (const auto& list : rhs)
    for (const RhsEntry& e : list) out.rows.push_back(e.row);
  std::sort(out.rows.begin(), out.rows.end());
  out.rows.erase(std::unique(out.rows.begin(), out.rows.end()), out.rows.end());
  const int touched = static_cast<int>(out.rows.size());
  out.rhs.assign(touched, Vec3::Zero());
  std::vector<std::vector<std::pair<int, Mat3>>> reduced(touched);

  // Reduce each touched row: its entries from every thread in thread (= element) order, then a
  // stable sort by column and in-order sums.
#pragma omp parallel for schedule(static) num_threads(threads)
  for (int k = 0; k < touched; ++k) {
    const int row = out.rows[k];
    std::vector<std::pair<int, Mat3>> entries;
    for (int t = 0; t < threads; ++t) {
      auto range = std::equal_range(blocks[t].begin(), blocks[t].end(), BlockEntry{row, 0, Mat3()},
                                    [](const BlockEntry& x, const BlockEntry& y) { return x.row < y.row; });
      for (auto it = range.first; it != range.second; ++it) entries.emplace_back(it->col, it->a);
      auto rr = std::equal_range(rhs[t].begin(), rhs[t].end(), RhsEntry{row, Vec3()},
                                 [](const RhsEntry& x, const RhsEntry& y) { return x.row < y.row; });
      for (auto it = rr.first; it != rr.second; ++it) out.rhs[k] += it->b;
    }
    std::stable_sort(entries.begin(), entries.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
    auto& mine = reduced[k];
    for (const auto& [col, a] : entries) {
      if (!mine.empty() && mine.back().first == col)
        mine.back().second += a;
      else
        mine.emplace_back(col, a);
    }
  }
  for (int k = 0; k < touched; ++k) {
    out.slot[out.rows[k]] = k;
    for (const auto& [col, a] : reduced[k]) {
      out.columns.push_back(col);
      out.blocks.push_back(a);
    }
    out.start.push_back(static_cast<int>(out.columns.size()));
  }
}

}  // namespace weft
