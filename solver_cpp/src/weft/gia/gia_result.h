// What the intersection analysis (intersection_analysis.h) returns: hits, paths and the
// colouring of each mesh.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "weft/gia/gia_topology.h"

namespace weft {

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

}  // namespace weft
