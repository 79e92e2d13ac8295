// Edge topology of a triangle mesh as GIA numbers it (edges with sorted endpoints, face -> edge,
// edge -> faces, vertex -> neighbours), shared by the analysis, its colouring and untangling.
#pragma once

#include <array>
#include <vector>

#include "weft/common/types.h"

namespace weft {

using EdgeList = Eigen::Matrix<int, Eigen::Dynamic, 2, Eigen::RowMajor>;

// Edge topology of one triangle mesh.
struct GiaTopology {
  EdgeList edges;                             // E x 2, endpoints sorted (v0 < v1)
  std::vector<std::array<int, 3>> face_edges;  // face_edges[f][k] is edge (f[k], f[(k+1)%3])
  std::vector<int> edge_face_offset;           // CSR edge -> incident faces
  std::vector<int> edge_faces;
  std::vector<int> vertex_offset;               // CSR vertex -> (neighbour vertex, edge)
  std::vector<int> vertex_neighbour;
  std::vector<int> vertex_edge;
  int boundary_edge_count = 0;                  // edges with one face
  int nonmanifold_edge_count = 0;               // edges with more than two faces
  bool closed = false;                          // every edge has exactly two faces

  int edge_face_count(int e) const { return edge_face_offset[e + 1] - edge_face_offset[e]; }
};

// Throws MeshError for out-of-range or repeated vertex indices in a face.
GiaTopology build_gia_topology(int vertex_count, const Faces& faces);

}  // namespace weft
