#include "weft/geometry/closest_points.h"

#include <algorithm>
#include <map>

namespace weft {

Vec3 closest_point_barycentric(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c) {
  // Ericson, Real-Time Collision Detection, 5.1.5 (Voronoi regions of the triangle).
  const Vec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return {1, 0, 0};
  const Vec3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return {0, 1, 0};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    const double v = d1 / (d1 - d3);
    return {1 - v, v, 0};
  }
  const Vec3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return {0, 0, 1};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    const double w = d2 / (d2 - d6);
    return {1 - w, 0, w};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {0, 1 - w, w};
  }
  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  return {1 - v - w, v, w};
}

FeatureOwnership assign_features(const Faces& faces, int vertex_count) {
  FeatureOwnership own;
  const int face_count = static_cast<int>(faces.rows());
  own.face_vertices.resize(face_count);
  own.face_edges.resize(face_count);
  std::vector<char> vertex_taken(vertex_count, 0);
  std::map<std::pair<int, int>, int> edge_owner;
  for (int f = 0; f < face_count; ++f) {
    for (int c = 0; c < 3; ++c) {
      const int v = faces(f, c);
      if (!vertex_taken[v]) {
        vertex_taken[v] = 1;
        own.face_vertices[f].push_back(v);
      }
      const int a = faces(f, c), b = faces(f, (c + 1) % 3);
      const std::pair<int, int> key{std::min(a, b), std::max(a, b)};
      if (edge_owner.emplace(key, f).second) own.face_edges[f].push_back({key.first, key.second});
    }
  }
  return own;
}

double point_triangle_distance(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c, Vec3& bary) {
  bary = closest_point_barycentric(p, a, b, c);
  return (p - (bary[0] * a + bary[1] * b + bary[2] * c)).norm();
}

double segment_segment_distance(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1, double& s,
                                double& t) {
  // Ericson, Real-Time Collision Detection, 5.1.9, with degenerate segments handled.
  const Vec3 d1 = a1 - a0, d2 = b1 - b0, r = a0 - b0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  const double tiny = 1e-300;
  if (a <= tiny && e <= tiny) {
    s = t = 0.0;
  } else if (a <= tiny) {
    s = 0.0;
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = d1.dot(r);
    if (e <= tiny) {
      t = 0.0;
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      const double b = d1.dot(d2), denom = a * e - b * b;
      s = denom > 1e-14 * a * e ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0.0) {
        t = 0.0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1.0) {
        t = 1.0;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  return ((a0 + s * d1) - (b0 + t * d2)).norm();
}

}  // namespace weft
