// Global Intersection Analysis (GIA, after Baraff, Witkin & Kass 2003, "Untangling Cloth"):
// find where two triangle meshes (or one mesh and itself) pass through each other, trace the
// crossings into intersection paths, and colour the regions the paths cut off ("in
// intersection"). Standalone: nothing here touches the time step. See
// docs/intersection-analysis.md for the algorithm and the degenerate/boundary rules.
//
// Conventions
// - Mesh 0 is A, mesh 1 is B. In self mode there is only mesh 0 and mesh[1] stays empty.
// - A hit (node) is "edge e of mesh M strictly crosses triangle t of mesh M'" (M' == M in self
//   mode, where t never shares a vertex with e). Crossings are decided by exact orient3d signs
//   under a symbolic perturbation (exact_predicates.h) with vertex keys: A's vertex i has key i,
//   B's vertex j has key nA + j. Exact contact is therefore resolved consistently: every
//   intersecting triangle pair has exactly two hits (except self-mode pairs that share a vertex,
//   which have one; see GiaEndKind::kSharedVertex).
#pragma once

#include <array>
#include <cstdint>
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

// How an open path ends.
enum class GiaEndKind : int {
  kClosed = 0,        // (closed paths have no ends)
  kBoundary = 1,      // the end hit's edge is a boundary edge of its mesh (end_mesh says which)
  kSharedVertex = 2,  // self mode: the path runs into a vertex shared by two crossing triangles
                      // (joined through the vertex when exactly two half-paths meet there)
  kNonManifold = 3,   // the end hit's edge has more than two faces; paths meet there
  kDangling = 4,      // should not happen (inconsistent pair); counted, never expected
};

struct GiaHit {
  int edge_mesh = 0;   // mesh of the crossing edge
  int edge = 0;        // edge id in that mesh's GiaTopology
  int tri_mesh = 0;    // mesh of the crossed triangle
  int tri = 0;         // face id
  double edge_t = 0;   // approximate crossing parameter along the edge (v0 -> v1, sorted ids)
  Vec3 point = Vec3::Zero();  // approximate crossing point
};

struct GiaPath {
  std::vector<int> hits;  // hit ids in order along the path
  // Self mode only: vertices the path passes through or ends at (kSharedVertex cases). They act
  // as walls in the colouring and are never coloured.
  std::vector<int> vertices;
  bool closed = false;
  std::array<GiaEndKind, 2> end_kind = {GiaEndKind::kClosed, GiaEndKind::kClosed};  // first, last hit
  std::array<int, 2> end_mesh = {-1, -1};      // mesh whose boundary each end lies on, or -1
  std::array<bool, 2> separates = {false, false};  // the path splits mesh 0 / mesh 1
  std::array<int, 2> coloured_vertices = {0, 0};   // vertices this path coloured on mesh 0 / 1
};

// Colour codes per edge and face.
constexpr std::int8_t kGiaFree = 0;     // not in intersection
constexpr std::int8_t kGiaInside = 1;   // all vertices coloured (in intersection)
constexpr std::int8_t kGiaContour = 2;  // an intersection path passes through it

struct GiaMeshColouring {
  EdgeList edges;                      // the mesh's edges (ids used by hits and edge_colour)
  std::vector<std::int8_t> vertex_colour;  // 1 = in intersection (coloured by some path)
  std::vector<int> vertex_path;            // lowest id of the paths that coloured it, or -1
  std::vector<std::int8_t> edge_colour;    // kGiaFree / kGiaInside / kGiaContour
  std::vector<std::int8_t> face_colour;    // kGiaFree / kGiaInside / kGiaContour
  // Parity colouring over all separating paths together (see docs): regions alternate in/out
  // across every wall, and per group of adjacent regions the smaller class is coloured. Equals
  // vertex_colour for one path or disjoint paths; right where several paths bound one region
  // (a sheet through a long cylinder). Groups that do not two-colour count as parity_conflicts.
  std::vector<std::int8_t> vertex_parity_colour;
  int parity_conflicts = 0;
  // Only when the *other* mesh is closed (watertight) and GiaOptions::inside_test: 1 for
  // vertices inside it (ray parity with the same perturbed predicates), else empty.
  std::vector<std::int8_t> inside_other;
  int coloured_vertex_count = 0;
  int boundary_edge_count = 0;
  bool closed = false;
};

struct GiaOptions {
  bool colour = true;       // flood-fill colouring (off: hits and paths only, e.g. body/body)
  bool inside_test = true;  // direct inside classification against a closed other mesh
  int threads = 0;          // OpenMP threads, 0 = default; results do not depend on it
};

struct GiaResult {
  bool self = false;
  std::vector<GiaHit> hits;
  std::vector<GiaPath> paths;
  std::array<GiaMeshColouring, 2> mesh;
  long long candidate_pairs = 0;    // triangle pairs whose boxes overlap
  int intersecting_pairs = 0;      // triangle pairs with at least one hit
  int inconsistent_pairs = 0;      // pairs whose hit count is not 2 (1 allowed for shared vertex)
  int closed_path_count = 0;
  int open_path_count = 0;
  // Body/body (pinch) query: whether the meshes intersect at all; with paths counted above.
  bool intersecting = false;
  double seconds = 0.0;
};

// Mesh A against mesh B.
GiaResult analyse_intersections(const Positions& xa, const Faces& fa, const Positions& xb, const Faces& fb,
                                const GiaOptions& options = {});

// One mesh against itself (triangles skip edges that share a vertex with them).
GiaResult analyse_self_intersections(const Positions& x, const Faces& f, const GiaOptions& options = {});

// Ray parity of each point against a closed mesh, with the key scheme of
// analyse_intersections (point i has key i, mesh vertex j key P + j): 1 = inside.
std::vector<std::int8_t> points_inside_closed_mesh(const Positions& points, const Positions& x, const Faces& f,
                                                   int threads = 0);

}  // namespace weft
