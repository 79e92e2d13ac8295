// Reverse Cuthill-McKee ordering of a symmetric graph, computed once at start-up from the
// cloth's fixed connectivity so that the fixed-pattern matrix is banded (its column indices
// then fit in 16-bit offsets from the diagonal).
#pragma once

#include <algorithm>
#include <vector>

namespace weft {

// Symmetric adjacency in compressed rows: the neighbours of vertex i are
// neighbors[offsets[i] .. offsets[i+1]), without i itself.
struct Graph {
  std::vector<int> offsets;
  std::vector<int> neighbors;
  int size() const { return static_cast<int>(offsets.size()) - 1; }
  int degree(int i) const { return offsets[i + 1] - offsets[i]; }
  bool has_edge(int i, int j) const {
    const auto first = neighbors.begin() + offsets[i], last = neighbors.begin() + offsets[i + 1];
    return std::find(first, last, j) != last;
  }
};

// Builds a Graph from undirected edges (duplicates and self loops are dropped).
Graph graph_from_edges(int vertex_count, const std::vector<std::pair<int, int>>& edges);

// order[new_index] = old_index. Each connected component starts from a pseudo-peripheral vertex
// of lowest degree; ties are broken by index, so the result is deterministic.
std::vector<int> reverse_cuthill_mckee(const Graph& graph);

// Largest |new(i) - new(j)| over the edges, for order as returned above (identity if empty).
int bandwidth(const Graph& graph, const std::vector<int>& order);

}  // namespace weft
