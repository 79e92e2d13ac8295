#include "weft/gia/gia_topology.h"

#include <algorithm>
#include <string>

#include "weft/mesh/mesh.h"

namespace weft {

namespace {
std::array<int, 2> ordered(int a, int b) { return {std::min(a, b), std::max(a, b)}; }
}  // namespace

GiaTopology build_gia_topology(int vertex_count, const Faces& faces) {
  GiaTopology topo;
  const int nf = static_cast<int>(faces.rows());
  // (v0, v1, face, local edge) with v0 < v1, sorted to number edges.
  std::vector<std::array<int, 4>> half(3 * static_cast<size_t>(nf));
  for (int t = 0; t < nf; ++t) {
    for (int k = 0; k < 3; ++k) {
      const int v = faces(t, k);
      if (v < 0 || v >= vertex_count)
        throw MeshError("face " + std::to_string(t) + " has vertex index " + std::to_string(v) + " outside [0, " +
                        std::to_string(vertex_count) + ")");
    }
    if (faces(t, 0) == faces(t, 1) || faces(t, 1) == faces(t, 2) || faces(t, 0) == faces(t, 2))
      throw MeshError("face " + std::to_string(t) + " repeats a vertex");
    for (int k = 0; k < 3; ++k) {
      const auto e = ordered(faces(t, k), faces(t, (k + 1) % 3));
      half[3 * t + k] = {e[0], e[1], t, k};
    }
  }
  std::sort(half.begin(), half.end());
  topo.face_edges.resize(nf);
  std::vector<std::array<int, 2>> edges;
  topo.edge_face_offset.push_back(0);
  for (size_t i = 0; i < half.size();) {
    size_t j = i;
    const int id = static_cast<int>(edges.size());
    edges.push_back({half[i][0], half[i][1]});
    for (; j < half.size() && half[j][0] == half[i][0] && half[j][1] == half[i][1]; ++j) {
      topo.face_edges[half[j][2]][half[j][3]] = id;
      topo.edge_faces.push_back(half[j][2]);
    }
    topo.edge_face_offset.push_back(static_cast<int>(topo.edge_faces.size()));
    const int count = static_cast<int>(j - i);
    topo.boundary_edge_count += count == 1;
    topo.nonmanifold_edge_count += count > 2;
    i = j;
  }
  const int ne = static_cast<int>(edges.size());
  topo.edges.resize(ne, 2);
  for (int e = 0; e < ne; ++e) topo.edges.row(e) << edges[e][0], edges[e][1];
  topo.closed = nf > 0 && topo.boundary_edge_count == 0 && topo.nonmanifold_edge_count == 0;
  // Vertex adjacency through edges.
  topo.vertex_offset.assign(vertex_count + 1, 0);
  for (const auto& e : edges) {
    ++topo.vertex_offset[e[0] + 1];
    ++topo.vertex_offset[e[1] + 1];
  }
  for (int v = 0; v < vertex_count; ++v) topo.vertex_offset[v + 1] += topo.vertex_offset[v];
  topo.vertex_neighbour.resize(topo.vertex_offset.back());
  topo.vertex_edge.resize(topo.vertex_offset.back());
  std::vector<int> fill(topo.vertex_offset.begin(), topo.vertex_offset.end() - 1);
  for (int e = 0; e < ne; ++e)
    for (int side = 0; side < 2; ++side) {
      const int v = edges[e][side];
      topo.vertex_neighbour[fill[v]] = edges[e][1 - side];
      topo.vertex_edge[fill[v]++] = e;
    }
  return topo;
}

}  // namespace weft
