// Exact triangle/triangle intersection counting, built on exact orientation predicates: the
// answer depends only on the double inputs, never on rounding. Used by tests, telemetry and
// the hard cases.
//
// Two triangles intersect when an edge of one meets the other (closed segment against closed
// triangle, coplanar contact included). Triangles that share an edge are never counted (their
// common edge is not an intersection); triangles that share one vertex are counted when the
// edge of one opposite the shared vertex meets the other.
#pragma once

#include <utility>
#include <vector>

#include "weft/common/types.h"

namespace weft {

// Whether the closed segment pq meets the closed triangle abc (exact).
bool segment_intersects_triangle(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c);

// Whether triangles (a0, a1, a2) and (b0, b1, b2), sharing no vertex, intersect (exact).
bool triangles_intersect(const std::array<Vec3, 3>& ta, const std::array<Vec3, 3>& tb);

// Intersecting pairs among the faces of one mesh (self) or between two meshes. The exact tests
// of the candidate pairs run on `threads` threads; count and pairs (in candidate order) are the
// same for any thread count.
int count_self_intersections(const Positions& x, const Faces& faces, const std::vector<char>& face_mask = {},
                             std::vector<std::pair<int, int>>* pairs = nullptr, int threads = 1);
int count_intersections(const Positions& xa, const Faces& fa, const Positions& xb, const Faces& fb,
                        const std::vector<char>& face_mask_a = {},
                        std::vector<std::pair<int, int>>* pairs = nullptr, int threads = 1);

// The same counts over given candidate triangle pairs (a broad phase's, e.g. one with culled
// self-pairs): self pairs of `faces` at x, or pairs (face of fa, face of fb) between two meshes.
int count_self_intersections_among(const Positions& x, const Faces& faces,
                                   const std::vector<std::pair<int, int>>& candidates,
                                   const std::vector<char>& face_mask, int threads);
int count_intersections_among(const Positions& xa, const Faces& fa, const Positions& xb, const Faces& fb,
                              const std::vector<std::pair<int, int>>& candidates,
                              const std::vector<char>& face_mask_a, int threads);

}  // namespace weft
