// Narrow-phase geometry shared by proximity, CCD response and tests: representative-triangle
// feature ownership (each vertex and edge belongs to exactly one triangle, so that each
// vertex-triangle and edge-edge pair is generated once from triangle pairs) and closest points.
#pragma once

#include <vector>

#include "weft/common/types.h"

namespace weft {

struct FeatureOwnership {
  std::vector<std::vector<int>> face_vertices;             // vertices owned by each face
  std::vector<std::vector<std::array<int, 2>>> face_edges;  // edges owned by each face
};

// Vertex -> the first face using it; edge -> the first face containing it.
FeatureOwnership assign_features(const Faces& faces, int vertex_count);

// Closest point on triangle (a, b, c) to p, as barycentric coordinates.
Vec3 closest_point_barycentric(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c);

// Closest point of triangle (a, b, c) to p: returns the distance, bary gets its barycentric
// coordinates (weights of a, b, c).
double point_triangle_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, Vec3& bary);

// Closest points of segments a0 + s (a1 - a0) and b0 + t (b1 - b0), s, t in [0, 1]; returns
// the distance.
double segment_segment_distance(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1, double& s,
                                double& t);

}  // namespace weft
