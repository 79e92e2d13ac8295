#include "weft/collision/sharp_edges.h"

#include <algorithm>
#include <map>

namespace weft {

SharpEdges::SharpEdges(const Faces& faces) {
  std::map<std::array<int, 2>, int> index;
  for (Eigen::Index f = 0; f < faces.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int a = faces(f, c), b = faces(f, (c + 1) % 3), opposite = faces(f, (c + 2) % 3);
      const std::array<int, 2> key{std::min(a, b), std::max(a, b)};
      const auto [it, added] = index.emplace(key, static_cast<int>(edges_.size()));
      if (added) {
        edges_.push_back(key);
        faces_.push_back({static_cast<int>(f), -1});
        far_.push_back(-1);
      } else if (faces_[it->second][1] < 0) {
        faces_[it->second][1] = static_cast<int>(f);
        far_[it->second] = opposite;
      }
    }
}

bool SharpEdges::corner_cut(int leaf, const Vec3& on_edge, const Vec3& cloth_a, const Vec3& cloth_b,
                            const Vec3& cloth_point) const {
  const auto [f0, f1] = faces(leaf);
  if (f1 < 0) return false;
  const Vec3& n0 = normals_[f0];
  const Vec3& n1 = normals_[f1];
  const auto below_both = [&](const Vec3& p) { return (p - on_edge).dot(n0) < 0.0 && (p - on_edge).dot(n1) < 0.0; };
  return below_both(cloth_point) && !below_both(cloth_a) && !below_both(cloth_b);
}

int SharpEdges::update(const Faces& faces, const Positions& x, double longest_cloth_edge,
                       double smallest_separation) {
  const bool moved = !same_bits(x, normals_at_);
  if (moved) {
    normals_.resize(faces.rows());
    for (Eigen::Index f = 0; f < faces.rows(); ++f) {
      const Vec3 a = row3(x, faces(f, 0));
      const Vec3 n = (row3(x, faces(f, 1)) - a).cross(row3(x, faces(f, 2)) - a);
      const double length = n.norm();
      normals_[f] = length > 0.0 ? Vec3(n / length) : Vec3::Zero();
    }
    edge_sharpness_.assign(edges_.size(), 2.0);  // a border
    convex_.assign(edges_.size(), 1);
    for (size_t e = 0; e < edges_.size(); ++e) {
      const auto [f0, f1] = faces_[e];
      if (f1 < 0) continue;
      // Convex when the far corner of the second face lies below the first face's plane.
      convex_[e] = (row3(x, far_[e]) - row3(x, edges_[e][0])).dot(normals_[f0]) < 0.0;
      if (convex_[e]) edge_sharpness_[e] = (normals_[f0] - normals_[f1]).norm();
    }
    normals_at_ = x;
  }
  std::vector<int> sharp;
  sharpness_.clear();
  sharpest_ = 0.0;
  for (size_t e = 0; e < edges_.size(); ++e) {
    if (!convex_[e] || !sharp_for(edge_sharpness_[e], longest_cloth_edge, smallest_separation)) continue;
    sharp.push_back(static_cast<int>(e));
    sharpness_.push_back(edge_sharpness_[e]);
    sharpest_ = std::max(sharpest_, edge_sharpness_[e]);
  }
  // The same edges at the same positions: the same boxes and tree. The same edges moved (a
  // rigid part): the tree's boxes are refitted, not rebuilt.
  if (moved || sharp != sharp_ || tree_.empty()) {
    boxes_.resize(sharp.size());
    for (size_t k = 0; k < sharp.size(); ++k) {
      Aabb& box = boxes_[k];
      box.lo = box.hi = row3(x, edges_[sharp[k]][0]);
      box.expand(row3(x, edges_[sharp[k]][1]));
    }
    if (!boxes_.empty()) {
      if (sharp == sharp_ && !tree_.empty())
        tree_.refit(boxes_);
      else
        tree_.build(boxes_);
    }
  }
  sharp_.swap(sharp);
  separation_ = smallest_separation;
  is_sharp_.assign(edges_.size(), 0);
  for (int e : sharp_) is_sharp_[e] = 1;
  return static_cast<int>(sharp_.size());
}

void SharpEdges::advancing(const Positions& start, const Positions& end, double least,
                           std::vector<std::array<int, 2>>& out) const {
  if (is_sharp_.size() != edges_.size()) return;  // update() has not run
  if (least >= 0.0 && same_bits(start, end)) return;  // nothing advances
  for (size_t e = 0; e < edges_.size(); ++e) {
    if (is_sharp_[e]) continue;
    const auto [f0, f1] = faces_[e];
    Vec3 n = normals_[f0];
    if (f1 >= 0) n += normals_[f1];
    const double length = n.norm();
    if (length == 0.0) continue;
    n /= length;
    const auto [a, b] = edges_[e];
    const double advance = std::max((row3(end, a) - row3(start, a)).dot(n), (row3(end, b) - row3(start, b)).dot(n));
    if (advance > least) out.push_back(edges_[e]);
  }
}

}  // namespace weft
