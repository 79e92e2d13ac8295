#include "weft/collision/self_culling.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "weft/geometry/closest_points.h"

namespace weft {

namespace {

// Cones of half-angle 60 degrees or more are not culled. Below 90 degrees the projection of a
// connected patch with a clear boundary is one-to-one, so the patch is the graph of a function
// over its projection with slope at most tan(half-angle); two of its points within `margin` of
// each other are then joined on the surface by a path no longer than margin / cos(half-angle),
// here twice the margin: neighbours whose interaction is elastic, not contact. Near 90 degrees
// that bound is lost (the two walls of a steep tent-shaped fold are within a thickness of each
// other yet far apart on the cloth), so the limit is 60 degrees: a unit control lies inside
// the cone of a unit axis when axis . control > cos(60 degrees) = 1/2, here a little more so
// that rounding of the dot product cannot admit one beyond the limit.
constexpr double kMinCosine = 0.5 + 1e-12;

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
  // Leaf order: post-order visits a node's subtree as one run, so its faces are contiguous.
  leaf_order_.clear();
  first_.assign(nodes, 0);
  last_.assign(nodes, 0);
  for (int n : tree.post_order()) {
    if (tree.leaf(n) >= 0) {
      first_[n] = static_cast<int>(leaf_order_.size());
      leaf_order_.push_back(tree.leaf(n));
      last_[n] = first_[n] + 1;
    } else {
      first_[n] = std::min(first_[tree.left(n)], first_[tree.right(n)]);
      last_[n] = std::max(last_[tree.left(n)], last_[tree.right(n)]);
    }
  }
  controls_.assign(3 * static_cast<size_t>(faces.rows()), Vec3::Zero());
  no_cone_.assign(faces.rows(), 1);
}

void SelfCollisionCulling::face_controls(const Faces& faces, int f, const Positions& x, const Positions& x_end) {
  Vec3* out = &controls_[3 * static_cast<size_t>(f)];
  const Vec3 a0 = row3(x, faces(f, 0)), b0 = row3(x, faces(f, 1)), c0 = row3(x, faces(f, 2));
  const Vec3 e1s = b0 - a0, e2s = c0 - a0;
  const Vec3 n0 = e1s.cross(e2s);
  const double norm0 = n0.norm();
  if (&x_end == &x) {  // static: one normal
    no_cone_[f] = !(norm0 > 0.0);
    out[0] = no_cone_[f] ? Vec3::Zero() : Vec3(n0 / norm0);
    return;
  }
  const Vec3 a1 = row3(x_end, faces(f, 0)), b1 = row3(x_end, faces(f, 1)), c1 = row3(x_end, faces(f, 2));
  const Vec3 e1e = b1 - a1, e2e = c1 - a1;
  const Vec3 m = 0.5 * (e1s.cross(e2e) + e1e.cross(e2s)), n1 = e1e.cross(e2e);
  const double norm_m = m.norm(), norm1 = n1.norm();
  no_cone_[f] = !(norm0 > 0.0) || !(norm1 > 0.0);  // degenerate triangle: no cone
  if (no_cone_[f]) {
    out[0] = out[1] = out[2] = Vec3::Zero();
    return;
  }
  // A zero middle control adds nothing to the Bezier curve's cone: the start normal stands in.
  out[0] = n0 / norm0;
  out[1] = norm_m > 0.0 ? Vec3(m / norm_m) : out[0];
  out[2] = n1 / norm1;
}

void SelfCollisionCulling::sum_controls() {
  const size_t count = leaf_order_.size();
  control_sum_.resize(count + 1);
  no_cone_count_.resize(count + 1);
  control_sum_[0] = Vec3::Zero();
  no_cone_count_[0] = 0;
  for (size_t k = 0; k < count; ++k) {
    const int f = leaf_order_[k];
    Vec3 sum = controls_[3 * static_cast<size_t>(f)];
    for (int c = 1; c < controls_per_face_; ++c) sum += controls_[3 * static_cast<size_t>(f) + c];
    control_sum_[k + 1] = control_sum_[k] + sum;
    no_cone_count_[k + 1] = no_cone_count_[k] + no_cone_[f];
  }
}

bool SelfCollisionCulling::narrow_cone(int n, Vec3& axis) const {
  const int first = first_[n], last = last_[n];
  if (no_cone_count_[last] != no_cone_count_[first]) return false;
  // Any axis gives a valid cone (the controls are checked against it); the sum of the unit
  // controls is the usual choice. A difference of prefix sums may lose low bits: harmless.
  const Vec3 sum = control_sum_[last] - control_sum_[first];
  const double norm = sum.norm();
  if (!(norm > 1e-12 * (last - first))) return false;
  axis = sum / norm;
  for (int k = first; k < last; ++k) {
    const Vec3* c = &controls_[3 * static_cast<size_t>(leaf_order_[k])];
    for (int j = 0; j < controls_per_face_; ++j)
      if (!(axis.dot(c[j]) > kMinCosine)) return false;
  }
  return true;
}

int SelfCollisionCulling::update(const AabbTree& tree, const Faces& faces, const Positions& x, const Positions& x_end,
                                 double margin, int threads) {
  const int nodes = tree.node_count();
  culled_.assign(nodes, 0);
  if (nodes == 0) return 0;
  // Each face's controls from its own triangle only: any thread count, same bits.
  const int face_count = static_cast<int>(faces.rows());
  controls_per_face_ = &x_end == &x ? 1 : 3;
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1 && face_count > 1024)
  for (int f = 0; f < face_count; ++f) face_controls(faces, f, x, x_end);
  sum_controls();
  test_.assign(nodes, -1);
  last_margin_ = margin;
  return cull_from_root(tree, x, x_end, margin, threads);
}

int SelfCollisionCulling::cull_from_root(const AabbTree& tree, const Positions& x, const Positions& x_end,
                                         double margin, int threads) {
  // Top-down: the first node on each path that passes is culled, with everything below it.
  // Tests are run where test_ has no result (-1) and kept for update_changed(). Level by level,
  // the tests of one level in parallel: a node's test depends on its own faces only, so the
  // nodes tested and the culled ones are those of a depth-first walk, for any thread count.
  // From two nodes on, one at a time: the top levels' few nodes are the largest patches, with
  // the longest boundaries to test.
  std::fill(culled_.begin(), culled_.end(), 0);
  int culled = 0;
  frontier_.assign(1, 0);
  while (!frontier_.empty()) {
    const int count = static_cast<int>(frontier_.size());
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads) if (threads > 1 && count >= 2)
    for (int i = 0; i < count; ++i) {
      const int n = frontier_[i];
      if (tree.leaf(n) >= 0 || test_[n] >= 0) continue;
      Vec3 axis;
      test_[n] = connected_[n] && static_cast<int>(boundary_[n].size()) <= kMaxBoundaryEdges && narrow_cone(n, axis) &&
                 boundary_clear(n, axis, x, x_end, margin);
    }
    next_frontier_.clear();
    for (int n : frontier_) {
      if (tree.leaf(n) >= 0) continue;
      if (test_[n] > 0) {
        culled_[n] = 1;
        ++culled;
        continue;
      }
      next_frontier_.push_back(tree.left(n));
      next_frontier_.push_back(tree.right(n));
    }
    frontier_.swap(next_frontier_);
  }
  return culled;
}

int SelfCollisionCulling::update_changed(const AabbTree& tree, const Faces& faces, const Positions& x,
                                         const Positions& x_end, double margin,
                                         const std::vector<char>& face_changed, int threads) {
  if (margin != last_margin_ || controls_per_face_ != (&x_end == &x ? 1 : 3) || tree.node_count() == 0)
    return update(tree, faces, x, x_end, margin, threads);
  // A node's cone and test depend only on its own faces' motion: the changed faces get new
  // controls and the nodes above them lose their test result (also those below a culled node,
  // which the traversal does not reach now: a later call may), the others keep theirs. The
  // prefix sums are redone whole, in the same order as update(): the same bits.
  for (size_t f = 0; f < face_changed.size(); ++f) {
    if (!face_changed[f]) continue;
    face_controls(faces, static_cast<int>(f), x, x_end);
    for (int n = leaf_node_[f]; n >= 0; n = parent_[n]) test_[n] = -1;
  }
  sum_controls();
  return cull_from_root(tree, x, x_end, margin, threads);
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
  // The patch cannot come near itself whatever frame its motion is seen from (the distances
  // between its points are the same in all): displacements are measured in the world or in the
  // frame of the boundary's mean displacement, whichever moves it least (a patch carried along
  // by a walking character, or falling with the rest of the sheet, hardly moves in its own).
  Vec3 mean = Vec3::Zero();
  if (&x_end != &x) {
    for (const auto& edge : edges)
      for (int v : edge) mean += row3(x_end, v) - row3(x, v);
    mean /= 2.0 * std::max(count, 1);
    double world = 0.0, own = 0.0;
    for (const auto& edge : edges)
      for (int v : edge) {
        const Vec3 d = row3(x_end, v) - row3(x, v);
        world = std::max(world, project(d).squaredNorm());
        own = std::max(own, project(d - mean).squaredNorm());
      }
    if (!(own < world)) mean = Vec3::Zero();
  }
  for (int k = 0; k < count; ++k) {
    for (int e = 0; e < 2; ++e) {
      const int v = edges[k][e];
      segment[k][e] = project(row3(x, v));
      motion[k] = std::max(motion[k], project(row3(x_end, v) - row3(x, v) - mean).norm());
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
