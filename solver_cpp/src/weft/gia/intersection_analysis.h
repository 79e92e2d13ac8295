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

#include <cstdint>
#include <vector>

#include "weft/geometry/aabb_tree.h"
#include "weft/gia/gia_result.h"

namespace weft {

// Mesh A against mesh B.
GiaResult analyse_intersections(const Positions& xa, const Faces& fa, const Positions& xb, const Faces& fb,
                                const GiaOptions& options = {});

// A mesh with what the analysis builds for it: its topology (build_gia_topology) and an AABB
// tree over its triangles at these positions (gia_triangle_tree). A caller that analyses one
// mesh against several others (the cloth against every part of a character) builds them once.
struct GiaMesh {
  const Positions& x;
  const Faces& f;
  const GiaTopology& topology;
  const AabbTree& tree;
};
AabbTree gia_triangle_tree(const Positions& x, const Faces& f);
// The same as the overload above, with the meshes' structures given.
GiaResult analyse_intersections(const GiaMesh& a, const GiaMesh& b, const GiaOptions& options = {});

// One mesh against itself (triangles skip edges that share a vertex with them).
GiaResult analyse_self_intersections(const Positions& x, const Faces& f, const GiaOptions& options = {});

// Ray parity of each point against a closed mesh, with the key scheme of
// analyse_intersections (point i has key i, mesh vertex j key P + j): 1 = inside.
std::vector<std::int8_t> points_inside_closed_mesh(const Positions& points, const Positions& x, const Faces& f,
                                                   int threads = 0);

}  // namespace weft
