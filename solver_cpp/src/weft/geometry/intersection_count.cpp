#include "weft/geometry/intersection_count.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "weft/common/ordered_append.h"
#include "weft/geometry/aabb_tree.h"
#include "weft/geometry/exact_predicates.h"

namespace weft {

namespace {

// Coplanar case: project onto the coordinate plane in which the triangle has non-zero
// (exactly computed) area, and test in 2D.
bool coplanar_segment_triangle(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c) {
  for (int drop = 0; drop < 3; ++drop) {
    const int i = (drop + 1) % 3, j = (drop + 2) % 3;
    const int area = orient2d(a[i], a[j], b[i], b[j], c[i], c[j]);
    if (area == 0) continue;
    auto o = [&](const Vec3& u, const Vec3& v, const Vec3& w) { return orient2d(u[i], u[j], v[i], v[j], w[i], w[j]) * area; };
    auto inside = [&](const Vec3& r) { return o(a, b, r) >= 0 && o(b, c, r) >= 0 && o(c, a, r) >= 0; };
    if (inside(p) || inside(q)) return true;
    // Segment against each triangle edge (closed segments in 2D).
    const Vec3* corners[3] = {&a, &b, &c};
    for (int e = 0; e < 3; ++e) {
      const Vec3& u = *corners[e];
      const Vec3& v = *corners[(e + 1) % 3];
      const int s1 = o(p, q, u), s2 = o(p, q, v), s3 = o(u, v, p), s4 = o(u, v, q);
      if (s1 * s2 <= 0 && s3 * s4 <= 0) {
        if (s1 == 0 && s2 == 0) {  // collinear: overlap of the projections on the line
          for (int k : {i, j}) {
            const double lo1 = std::min(p[k], q[k]), hi1 = std::max(p[k], q[k]);
            const double lo2 = std::min(u[k], v[k]), hi2 = std::max(u[k], v[k]);
            if (hi1 < lo2 || hi2 < lo1) return false;
          }
          return true;
        }
        return true;
      }
    }
    return false;
  }
  return false;  // degenerate triangle (a segment or a point): not counted
}

}  // namespace

bool segment_intersects_triangle(const Vec3& p, const Vec3& q, const Vec3& a, const Vec3& b, const Vec3& c) {
  const int sp = orient3d(a, b, c, p), sq = orient3d(a, b, c, q);
  if (sp != 0 && sp == sq) return false;
  if (sp == 0 && sq == 0) return coplanar_segment_triangle(p, q, a, b, c);
  // The segment crosses (or touches) the plane: the line pq must pass inside the triangle.
  const int o1 = orient3d(p, q, a, b), o2 = orient3d(p, q, b, c), o3 = orient3d(p, q, c, a);
  return (o1 >= 0 && o2 >= 0 && o3 >= 0) || (o1 <= 0 && o2 <= 0 && o3 <= 0);
}

bool triangles_intersect(const std::array<Vec3, 3>& ta, const std::array<Vec3, 3>& tb) {
  // A triangle whose corners all lie strictly on one side of the other's plane meets nothing
  // of it (exact signs): three predicates decide most separated pairs, where the edge tests
  // below take twelve (each edge's two ends against the other plane).
  auto off_plane = [](const std::array<Vec3, 3>& plane, const std::array<Vec3, 3>& t) {
    const int s0 = orient3d(plane[0], plane[1], plane[2], t[0]);
    if (s0 == 0) return false;
    return orient3d(plane[0], plane[1], plane[2], t[1]) == s0 && orient3d(plane[0], plane[1], plane[2], t[2]) == s0;
  };
  if (off_plane(ta, tb) || off_plane(tb, ta)) return false;
  for (int e = 0; e < 3; ++e) {
    if (segment_intersects_triangle(ta[e], ta[(e + 1) % 3], tb[0], tb[1], tb[2])) return true;
    if (segment_intersects_triangle(tb[e], tb[(e + 1) % 3], ta[0], ta[1], ta[2])) return true;
  }
  return false;
}

namespace {

std::array<Vec3, 3> corners(const Positions& x, const Faces& f, int i) {
  return {row3(x, f(i, 0)), row3(x, f(i, 1)), row3(x, f(i, 2))};
}

// Triangles of one mesh: skip those sharing an edge; with one shared vertex test the edges
// opposite it.
bool mesh_pair_intersects(const Positions& x, const Faces& faces, int fa, int fb) {
  int shared = 0, sa = -1, sb = -1;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (faces(fa, i) == faces(fb, j)) {
        ++shared;
        sa = i;
        sb = j;
      }
  if (shared >= 2) return false;
  const auto ta = corners(x, faces, fa), tb = corners(x, faces, fb);
  if (shared == 0) return triangles_intersect(ta, tb);
  return segment_intersects_triangle(ta[(sa + 1) % 3], ta[(sa + 2) % 3], tb[0], tb[1], tb[2]) ||
         segment_intersects_triangle(tb[(sb + 1) % 3], tb[(sb + 2) % 3], ta[0], ta[1], ta[2]);
}

// The candidates for which `hit` holds: counted, and appended to pairs in candidate order.
template <class Hit>
int count_hits(const std::vector<std::pair<int, int>>& candidates, std::vector<std::pair<int, int>>* pairs,
               int threads, Hit&& hit) {
  std::vector<std::pair<int, int>> hits;
  ordered_append(static_cast<std::int64_t>(candidates.size()), 1024, threads, hits,
                 [&](std::int64_t k, std::vector<std::pair<int, int>>& out) {
                   if (hit(candidates[k].first, candidates[k].second)) out.push_back(candidates[k]);
                 });
  if (pairs) pairs->insert(pairs->end(), hits.begin(), hits.end());
  return static_cast<int>(hits.size());
}

}  // namespace

int count_self_intersections(const Positions& x, const Faces& faces, const std::vector<char>& face_mask,
                             std::vector<std::pair<int, int>>* pairs, int threads) {
  std::vector<Aabb> boxes;
  triangle_boxes(faces, x, x, {}, boxes);
  AabbTree tree;
  tree.build(boxes);
  std::vector<std::pair<int, int>> candidates;
  tree.self_pairs(candidates);
  return count_hits(candidates, pairs, threads, [&](int a, int b) {
    return (face_mask.empty() || (face_mask[a] && face_mask[b])) && mesh_pair_intersects(x, faces, a, b);
  });
}

int count_intersections(const Positions& xa, const Faces& fa, const Positions& xb, const Faces& fb,
                        const std::vector<char>& face_mask_a, std::vector<std::pair<int, int>>* pairs, int threads) {
  std::vector<Aabb> boxes_a, boxes_b;
  triangle_boxes(fa, xa, xa, {}, boxes_a);
  triangle_boxes(fb, xb, xb, {}, boxes_b);
  AabbTree ta, tb;
  ta.build(boxes_a);
  tb.build(boxes_b);
  std::vector<std::pair<int, int>> candidates;
  ta.pairs(tb, candidates);
  return count_hits(candidates, pairs, threads, [&](int a, int b) {
    return (face_mask_a.empty() || face_mask_a[a]) && triangles_intersect(corners(xa, fa, a), corners(xb, fb, b));
  });
}

int count_self_intersections_among(const Positions& x, const Faces& faces,
                                   const std::vector<std::pair<int, int>>& candidates,
                                   const std::vector<char>& face_mask, int threads) {
  return count_hits(candidates, nullptr, threads, [&](int a, int b) {
    return (face_mask.empty() || (face_mask[a] && face_mask[b])) && mesh_pair_intersects(x, faces, a, b);
  });
}

int count_intersections_among(const Positions& xa, const Faces& fa, const Positions& xb, const Faces& fb,
                              const std::vector<std::pair<int, int>>& candidates,
                              const std::vector<char>& face_mask_a, int threads) {
  return count_hits(candidates, nullptr, threads, [&](int a, int b) {
    return (face_mask_a.empty() || face_mask_a[a]) && triangles_intersect(corners(xa, fa, a), corners(xb, fb, b));
  });
}

}  // namespace weft
