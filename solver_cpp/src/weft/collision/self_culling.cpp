#include "weft/collision/self_culling.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "weft/geometry/closest_points.h"

namespace weft {

namespace {

constexpr double kPi = 3.14159265358979323846;
// Cones at or above this half-angle are not culled. Below 90 degrees the projection of a
// connected patch with a clear boundary is one-to-one, so the patch is the graph of a function
// over its projection with slope at most tan(half-angle); two of its points within `margin` of
// each other are then joined on the surface by a path no longer than margin / cos(half-angle),
// here twice the margin: neighbours whose interaction is elastic, not contact. Near 90 degrees
// that bound is lost (the two walls of a steep tent-shaped fold are within a thickness of each
// other yet far apart on the cloth), so the limit is 60 degrees.
constexpr double kMaxHalfAngle = kPi / 3.0;

std::array<int, 2> edge_key(int a, int b) { return {std::min(a, b), std::max(a, b)}; }

// The symmetric difference of two sorted edge lists (edges shared by the two children are
// interior to the parent).
std::vector<std::array<int, 2>> symmetric_difference(const std::vector<std::array<int, 2>>& a,
                                                     const std::vector<std::array<int, 2>>& b, bool& shared) {
  std::vector<std::array<int, 2>> out;
  out.reserve(a.size() + b.size());
  size_t i = 0, j = 0;
  shared = false;
  while (i < a.size() || j < b.size()) {
    if (j == b.size() || (i < a.size() && a[i] < b[j])) {
      out.push_back(a[i++]);
    } else if (i == a.size() || b[j] < a[i]) {
      out.push_back(b[j++]);
    } else {
      shared = true;
      ++i;
      ++j;
    }
  }
  return out;
}

double angle_between(const Vec3& a, const Vec3& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

}  // namespace

void SelfCollisionCulling::rebuild(const AabbTree& tree, const Faces& faces, const std::vector<char>& face_self) {
  const int nodes = tree.node_count();
  connected_.assign(nodes, 0);
  boundary_.assign(nodes, {});
  std::vector<std::vector<int>> leaves(nodes);  // faces below each node, freed once the parent has them
  std::vector<int> parent(faces.rows());
  std::vector<std::pair<std::array<int, 2>, int>> edge_faces;
  for (int n : tree.post_order()) {
    const int leaf = tree.leaf(n);
    if (leaf >= 0) {
      leaves[n] = {leaf};
      connected_[n] = face_self.empty() || face_self[leaf];
      auto& edges = boundary_[n];
      for (int c = 0; c < 3; ++c) edges.push_back(edge_key(faces(leaf, c), faces(leaf, (c + 1) % 3)));
      std::sort(edges.begin(), edges.end());
      continue;
    }
    const int l = tree.left(n), r = tree.right(n);
    bool shared = false;
    boundary_[n] = symmetric_difference(boundary_[l], boundary_[r], shared);
    leaves[n] = std::move(leaves[l]);
    leaves[n].insert(leaves[n].end(), leaves[r].begin(), leaves[r].end());
    std::vector<int>().swap(leaves[r]);
    // Connected across shared edges (exact: union-find over the node's faces), and only faces
    // that self-collide.
    bool all_self = true;
    edge_faces.clear();
    for (int f : leaves[n]) {
      all_self = all_self && (face_self.empty() || face_self[f]);
      parent[f] = f;
      for (int c = 0; c < 3; ++c) edge_faces.push_back({edge_key(faces(f, c), faces(f, (c + 1) % 3)), f});
    }
    if (!all_self || !shared) continue;
    std::sort(edge_faces.begin(), edge_faces.end());
    auto find = [&](int f) {
      while (parent[f] != f) f = parent[f] = parent[parent[f]];
      return f;
    };
    int components = static_cast<int>(leaves[n].size());
    for (size_t k = 1; k < edge_faces.size(); ++k) {
      if (edge_faces[k].first != edge_faces[k - 1].first) continue;
      const int a = find(edge_faces[k].second), b = find(edge_faces[k - 1].second);
      if (a == b) continue;
      parent[std::max(a, b)] = std::min(a, b);
      --components;
    }
    connected_[n] = components == 1;
  }
  cone_.assign(nodes, {});
  culled_.assign(nodes, 0);
  test_.assign(nodes, -1);
  last_margin_ = -1.0;
  parent_.assign(nodes, -1);
  leaf_node_.assign(faces.rows(), -1);
  for (int n = 0; n < nodes; ++n) {
    if (tree.leaf(n) >= 0) {
      leaf_node_[tree.leaf(n)] = n;
    } else {
      parent_[tree.left(n)] = n;
      parent_[tree.right(n)] = n;
    }
  }
  // Nodes by height (leaves 0): the cones of one height depend only on the height below.
  std::vector<int> height(nodes, 0);
  by_height_.clear();
  for (int n : tree.post_order()) {
    if (tree.leaf(n) < 0) height[n] = 1 + std::max(height[tree.left(n)], height[tree.right(n)]);
    if (static_cast<int>(by_height_.size()) <= height[n]) by_height_.resize(height[n] + 1);
    by_height_[height[n]].push_back(n);
  }
}

SelfCollisionCulling::Cone SelfCollisionCulling::merge(const Cone& a, const Cone& b) {
  if (a.half_angle >= kMaxHalfAngle || b.half_angle >= kMaxHalfAngle) return {a.axis, kPi};
  const double between = angle_between(a.axis, b.axis);
  if (between + b.half_angle <= a.half_angle) return a;
  if (between + a.half_angle <= b.half_angle) return b;
  const double half = 0.5 * (between + a.half_angle + b.half_angle);
  if (half >= kMaxHalfAngle) return {a.axis, kPi};
  // Rotate a's axis towards b's by (half - a.half_angle) in their common plane.
  const Vec3 normal = a.axis.cross(b.axis);
  if (normal.norm() <= 1e-300) return {a.axis, half};
  const Vec3 towards = normal.normalized().cross(a.axis);
  const double turn = half - a.half_angle;
  Cone out;
  out.axis = (std::cos(turn) * a.axis + std::sin(turn) * towards).normalized();
  out.half_angle = half;
  return out;
}

SelfCollisionCulling::Cone SelfCollisionCulling::leaf_cone(const Faces& faces, int leaf, const Positions& x,
                                                           const Positions& x_end) {
  const Vec3 a0 = row3(x, faces(leaf, 0)), b0 = row3(x, faces(leaf, 1)), c0 = row3(x, faces(leaf, 2));
  if (&x_end == &x) {  // static: one normal, a cone of half-angle 0
    const Vec3 normal = (b0 - a0).cross(c0 - a0);
    const double norm = normal.norm();
    if (!(norm > 0.0)) return {Vec3::UnitZ(), kPi};
    return {normal / norm, 0.0};
  }
  const Vec3 a1 = row3(x_end, faces(leaf, 0)), b1 = row3(x_end, faces(leaf, 1)), c1 = row3(x_end, faces(leaf, 2));
  const Vec3 e1s = b0 - a0, e2s = c0 - a0, e1e = b1 - a1, e2e = c1 - a1;
  const Vec3 control[3] = {e1s.cross(e2s), 0.5 * (e1s.cross(e2e) + e1e.cross(e2s)), e1e.cross(e2e)};
  const double norms[3] = {control[0].norm(), control[1].norm(), control[2].norm()};
  if (!(norms[0] > 0.0) || !(norms[2] > 0.0)) return {Vec3::UnitZ(), kPi};  // degenerate triangle: no cone
  Vec3 axis = control[0] / norms[0] + control[2] / norms[2];
  if (norms[1] > 0.0) axis += control[1] / norms[1];
  if (!(axis.norm() > 1e-12)) return {Vec3::UnitZ(), kPi};
  Cone cone;
  cone.axis = axis.normalized();
  for (int k = 0; k < 3; ++k)
    if (norms[k] > 0.0) cone.half_angle = std::max(cone.half_angle, angle_between(cone.axis, control[k]));
  return cone;
}

int SelfCollisionCulling::update(const AabbTree& tree, const Faces& faces, const Positions& x, const Positions& x_end,
                                 double margin, int threads) {
  const int nodes = tree.node_count();
  culled_.assign(nodes, 0);
  if (nodes == 0) return 0;
  // Cones bottom-up, one height at a time, the nodes of a height in parallel (each node's cone
  // is computed from its own triangle or its children's cones only: any thread count, same bits).
  for (const std::vector<int>& level : by_height_) {
    const std::int64_t count = static_cast<std::int64_t>(level.size());
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1 && count > 256)
    for (std::int64_t k = 0; k < count; ++k) {
      const int n = level[k];
      const int leaf = tree.leaf(n);
      cone_[n] = leaf < 0 ? merge(cone_[tree.left(n)], cone_[tree.right(n)]) : leaf_cone(faces, leaf, x, x_end);
    }
  }
  test_.assign(nodes, -1);
  last_margin_ = margin;
  return cull_from_root(tree, x, x_end, margin);
}

int SelfCollisionCulling::cull_from_root(const AabbTree& tree, const Positions& x, const Positions& x_end,
                                         double margin) {
  // Top-down: the first node on each path that passes is culled, with everything below it.
  // Tests are run where test_ has no result (-1) and kept for update_changed().
  std::fill(culled_.begin(), culled_.end(), 0);
  int culled = 0;
  std::vector<int> stack = {0};
  while (!stack.empty()) {
    const int n = stack.back();
    stack.pop_back();
    if (tree.leaf(n) >= 0) continue;
    if (test_[n] < 0)
      test_[n] = connected_[n] && cone_[n].half_angle < kMaxHalfAngle &&
                 static_cast<int>(boundary_[n].size()) <= kMaxBoundaryEdges &&
                 boundary_clear(n, cone_[n].axis, x, x_end, margin);
    if (test_[n] > 0) {
      culled_[n] = 1;
      ++culled;
      continue;
    }
    stack.push_back(tree.right(n));
    stack.push_back(tree.left(n));
  }
  return culled;
}

int SelfCollisionCulling::update_changed(const AabbTree& tree, const Faces& faces, const Positions& x,
                                         const Positions& x_end, double margin,
                                         const std::vector<char>& face_changed, int threads) {
  if (margin != last_margin_ || tree.node_count() == 0) return update(tree, faces, x, x_end, margin, threads);
  // A node's cone and test depend only on its own faces' motion: the nodes above a changed face
  // get new cones and lose their test result (also those below a culled node, which the
  // traversal does not reach now: a later call may), the others keep theirs.
  const int nodes = tree.node_count();
  dirty_.assign(nodes, 0);
  for (size_t f = 0; f < face_changed.size(); ++f) {
    if (!face_changed[f]) continue;
    for (int n = leaf_node_[f]; n >= 0 && !dirty_[n]; n = parent_[n]) {
      dirty_[n] = 1;
      test_[n] = -1;
    }
  }
  // Cones of the dirty nodes, bottom-up by height (serial: few nodes; the same arithmetic as
  // update(), so the same bits).
  for (const std::vector<int>& level : by_height_)
    for (int n : level) {
      if (!dirty_[n]) continue;
      const int leaf = tree.leaf(n);
      cone_[n] = leaf < 0 ? merge(cone_[tree.left(n)], cone_[tree.right(n)]) : leaf_cone(faces, leaf, x, x_end);
    }
  return cull_from_root(tree, x, x_end, margin);
}

bool SelfCollisionCulling::boundary_clear(int node, const Vec3& axis, const Positions& x, const Positions& x_end,
                                          double margin) const {
  const auto& edges = boundary_[node];
  const int count = static_cast<int>(edges.size());
  auto project = [&](const Vec3& p) { return Vec3(p - axis.dot(p) * axis); };
  // A direction in the projection plane to sweep along.
  const Vec3 sweep = (std::abs(axis.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).cross(axis).normalized();
  std::vector<std::array<Vec3, 2>> segment(count);
  std::vector<double> motion(count, 0.0);  // largest projected displacement of the edge's ends
  std::vector<std::array<double, 2>> extent(count);  // along `sweep`, widened by motion and margin
  std::vector<int> order(count);
  for (int k = 0; k < count; ++k) {
    for (int e = 0; e < 2; ++e) {
      const int v = edges[k][e];
      segment[k][e] = project(row3(x, v));
      motion[k] = std::max(motion[k], project(row3(x_end, v) - row3(x, v)).norm());
    }
    const double a = sweep.dot(segment[k][0]), b = sweep.dot(segment[k][1]);
    extent[k] = {std::min(a, b) - motion[k] - 0.5 * margin, std::max(a, b) + motion[k] + 0.5 * margin};
    order[k] = k;
  }
  // Sweep and prune: only segments whose widened extents along `sweep` overlap can be within
  // margin of each other (the distance is at least the gap between the extents).
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return extent[a][0] < extent[b][0] || (extent[a][0] == extent[b][0] && a < b);
  });
  for (int oi = 0; oi < count; ++oi) {
    const int i = order[oi];
    for (int oj = oi + 1; oj < count && extent[order[oj]][0] <= extent[i][1]; ++oj) {
      const int j = order[oj];
      const auto& a = edges[i];
      const auto& b = edges[j];
      if (a[0] == b[0] || a[0] == b[1] || a[1] == b[0] || a[1] == b[1]) continue;
      double s, t;
      const double d = segment_segment_distance(segment[i][0], segment[i][1], segment[j][0], segment[j][1], s, t);
      if (d - motion[i] - motion[j] <= margin) return false;
    }
  }
  return true;
}

}  // namespace weft
