#include "weft/linear_system/rcm.h"

#include <algorithm>
#include <cstdlib>
#include <numeric>
#include <utility>

namespace weft {

Graph graph_from_edges(int vertex_count, const std::vector<std::pair<int, int>>& edges) {
  Graph g;
  g.offsets.assign(vertex_count + 1, 0);
  for (const auto& [a, b] : edges)
    if (a != b) {
      ++g.offsets[a + 1];
      ++g.offsets[b + 1];
    }
  std::partial_sum(g.offsets.begin(), g.offsets.end(), g.offsets.begin());
  std::vector<int> fill(g.offsets.begin(), g.offsets.end() - 1);
  g.neighbors.resize(g.offsets.back());
  for (const auto& [a, b] : edges)
    if (a != b) {
      g.neighbors[fill[a]++] = b;
      g.neighbors[fill[b]++] = a;
    }
  // Sort and deduplicate each row, then compact.
  std::vector<int> compact_offsets(vertex_count + 1, 0);
  size_t out = 0;
  for (int i = 0; i < vertex_count; ++i) {
    auto begin = g.neighbors.begin() + g.offsets[i], end = g.neighbors.begin() + g.offsets[i + 1];
    std::sort(begin, end);
    end = std::unique(begin, end);
    for (auto it = begin; it != end; ++it) g.neighbors[out++] = *it;
    compact_offsets[i + 1] = static_cast<int>(out);
  }
  g.neighbors.resize(out);
  g.offsets = std::move(compact_offsets);
  return g;
}

namespace {
// Breadth-first level structure from root over unvisited vertices; returns the vertices of the
// last level and the depth.
std::pair<std::vector<int>, int> last_level(const Graph& g, int root, std::vector<int>& stamp, int mark) {
  std::vector<int> level{root}, next;
  stamp[root] = mark;
  int depth = 0;
  while (true) {
    next.clear();
    for (int u : level)
      for (int k = g.offsets[u]; k < g.offsets[u + 1]; ++k) {
        const int w = g.neighbors[k];
        if (stamp[w] != mark) {
          stamp[w] = mark;
          next.push_back(w);
        }
      }
    if (next.empty()) return {level, depth};
    level.swap(next);
    ++depth;
  }
}
}  // namespace

std::vector<int> reverse_cuthill_mckee(const Graph& g) {
  const int n = g.size();
  std::vector<int> order;
  order.reserve(n);
  std::vector<char> placed(n, 0);
  std::vector<int> stamp(n, -1);
  int mark = 0;
  std::vector<int> by_degree(n);
  std::iota(by_degree.begin(), by_degree.end(), 0);
  std::stable_sort(by_degree.begin(), by_degree.end(), [&](int a, int b) { return g.degree(a) < g.degree(b); });
  std::vector<int> children;
  for (int seed : by_degree) {
    if (placed[seed]) continue;
    // Pseudo-peripheral root (George-Liu): walk to a lowest-degree vertex of the last BFS level
    // while the eccentricity grows.
    int root = seed;
    auto [level, depth] = last_level(g, root, stamp, mark++);
    for (int iteration = 0; iteration < 8; ++iteration) {
      const int candidate = *std::min_element(level.begin(), level.end(), [&](int a, int b) {
        return g.degree(a) != g.degree(b) ? g.degree(a) < g.degree(b) : a < b;
      });
      auto [candidate_level, candidate_depth] = last_level(g, candidate, stamp, mark++);
      if (candidate_depth <= depth) break;
      root = candidate;
      level = std::move(candidate_level);
      depth = candidate_depth;
    }
    // Cuthill-McKee from root: children in increasing degree (then index).
    size_t head = order.size();
    order.push_back(root);
    placed[root] = 1;
    while (head < order.size()) {
      const int u = order[head++];
      children.clear();
      for (int k = g.offsets[u]; k < g.offsets[u + 1]; ++k)
        if (!placed[g.neighbors[k]]) {
          children.push_back(g.neighbors[k]);
          placed[g.neighbors[k]] = 1;
        }
      std::sort(children.begin(), children.end(), [&](int a, int b) {
        return g.degree(a) != g.degree(b) ? g.degree(a) < g.degree(b) : a < b;
      });
      order.insert(order.end(), children.begin(), children.end());
    }
  }
  std::reverse(order.begin(), order.end());
  return order;
}

int bandwidth(const Graph& g, const std::vector<int>& order) {
  const int n = g.size();
  std::vector<int> position(n);
  if (order.empty())
    std::iota(position.begin(), position.end(), 0);
  else
    for (int k = 0; k < n; ++k) position[order[k]] = k;
  int width = 0;
  for (int i = 0; i < n; ++i)
    for (int k = g.offsets[i]; k < g.offsets[i + 1]; ++k)
      width = std::max(width, std::abs(position[i] - position[g.neighbors[k]]));
  return width;
}

}  // namespace weft
