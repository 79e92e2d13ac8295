#include "weft/geometry/aabb_tree.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <vector>

#include "weft/common/ordered_append.h"
#include "weft/common/union_find.h"

namespace weft {

namespace {
// Below this many boxes the work is not worth a parallel region.
constexpr int kParallelBoxes = 2048;
}  // namespace

void triangle_boxes(const Faces& faces, const Positions& start, const Positions& end,
                    const std::vector<double>& margin, std::vector<Aabb>& boxes, int threads) {
  const int count = static_cast<int>(faces.rows());
  boxes.resize(count);
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1 && count >= kParallelBoxes)
  for (int f = 0; f < count; ++f) boxes[f] = triangle_box(faces, start, end, margin, f);
}

Aabb triangle_box(const Faces& faces, const Positions& start, const Positions& end, const std::vector<double>& margin,
                  int f) {
  Aabb box;
  for (int c = 0; c < 3; ++c) {
    box.expand(row3(start, faces(f, c)));
    if (&end != &start) box.expand(row3(end, faces(f, c)));
  }
  box.inflate(margin.empty() ? 0.0 : margin[f]);
  return box;
}

std::vector<int> face_components(const Faces& faces, int vertex_count) {
  UnionFind pieces(vertex_count);
  for (int f = 0; f < faces.rows(); ++f) {
    pieces.unite(faces(f, 0), faces(f, 1));
    pieces.unite(faces(f, 0), faces(f, 2));
  }
  std::vector<int> group(faces.rows());
  for (int f = 0; f < faces.rows(); ++f) group[f] = pieces.find(faces(f, 0));
  return group;
}

std::vector<int> pair_faces_across_edges(const Faces& faces, const Positions& x) {
  const int face_count = static_cast<int>(faces.rows());
  // Edges as (lower vertex, higher vertex, face), sorted: a manifold edge's two faces adjacent.
  std::vector<std::array<int, 3>> edges;
  edges.reserve(3 * static_cast<size_t>(face_count));
  for (int f = 0; f < face_count; ++f)
    for (int c = 0; c < 3; ++c) {
      const int a = faces(f, c), b = faces(f, (c + 1) % 3);
      edges.push_back({std::min(a, b), std::max(a, b), f});
    }
  std::sort(edges.begin(), edges.end());
  // Per face and corner c: the face across edge (c, c + 1), or -1.
  std::vector<std::array<int, 3>> across(face_count, {-1, -1, -1});
  auto corner_of = [&](int f, int a, int b) {
    for (int c = 0; c < 3; ++c) {
      const int p = faces(f, c), q = faces(f, (c + 1) % 3);
      if (std::min(p, q) == a && std::max(p, q) == b) return c;
    }
    return -1;
  };
  for (size_t k = 0; k < edges.size();) {
    size_t end = k + 1;
    while (end < edges.size() && edges[end][0] == edges[k][0] && edges[end][1] == edges[k][1]) ++end;
    if (end - k == 2) {
      const int f = edges[k][2], g = edges[k + 1][2];
      if (f != g) {
        across[f][corner_of(f, edges[k][0], edges[k][1])] = g;
        across[g][corner_of(g, edges[k][0], edges[k][1])] = f;
      }
    }
    k = end;
  }
  std::vector<int> partner(face_count, -1);
  for (int f = 0; f < face_count; ++f) {
    if (partner[f] >= 0) continue;
    std::array<int, 3> corner{0, 1, 2};
    std::array<double, 3> length;
    for (int c = 0; c < 3; ++c) length[c] = (row3(x, faces(f, (c + 1) % 3)) - row3(x, faces(f, c))).squaredNorm();
    std::stable_sort(corner.begin(), corner.end(), [&](int a, int b) { return length[a] > length[b]; });
    for (int c : corner) {
      const int g = across[f][c];
      if (g >= 0 && partner[g] < 0) {
        partner[f] = g;
        partner[g] = f;
        break;
      }
    }
  }
  return partner;
}

void AabbTree::build(const std::vector<Aabb>& leaves, const std::vector<int>& partner, const std::vector<int>& group) {
  nodes_.clear();
  post_order_.clear();
  if (leaves.empty()) return;
  const int count = static_cast<int>(leaves.size());
  if (!partner.empty()) {
    if (static_cast<int>(partner.size()) != count) throw std::invalid_argument("AabbTree::build: one partner per leaf");
    for (int i = 0; i < count; ++i)
      if (partner[i] >= count || (partner[i] >= 0 && (partner[i] == i || partner[partner[i]] != i)))
        throw std::invalid_argument("AabbTree::build: partners must pair leaves mutually");
  }
  if (!group.empty()) {
    if (static_cast<int>(group.size()) != count) throw std::invalid_argument("AabbTree::build: one group per leaf");
    for (int i = 0; i < count; ++i)
      if (!partner.empty() && partner[i] >= 0 && group[partner[i]] != group[i])
        throw std::invalid_argument("AabbTree::build: partners must share a group");
  }
  // One entry per cluster (a leaf, or a pair under its lower index), at its box's centre.
  std::vector<int> order;
  std::vector<Vec3> centre(leaves.size());
  order.reserve(leaves.size());
  for (int i = 0; i < count; ++i) {
    const int other = partner.empty() ? -1 : partner[i];
    if (other >= 0 && other < i) continue;
    Aabb box = leaves[i];
    if (other >= 0) box.expand(leaves[other]);
    order.push_back(i);
    centre[i] = 0.5 * (box.lo + box.hi);
  }
  nodes_.reserve(2 * leaves.size());
  build_range(order, centre, partner, group, 0, static_cast<int>(order.size()));
  std::vector<int> height(nodes_.size(), 0);
  by_height_.clear();
  for (int n : post_order_) {
    const Node& node = nodes_[n];
    if (node.leaf < 0) height[n] = 1 + std::max(height[node.left], height[node.right]);
    if (static_cast<int>(by_height_.size()) <= height[n]) by_height_.resize(height[n] + 1);
    by_height_[height[n]].push_back(n);
  }
  refit(leaves);
}

double AabbTree::surface_cost() const {
  double cost = 0.0;
  for (const Node& node : nodes_) {
    if (node.leaf >= 0) continue;
    const Vec3 e = node.box.hi - node.box.lo;
    cost += e.x() * e.y() + e.y() * e.z() + e.z() * e.x();
  }
  return cost;
}

int AabbTree::group_split(std::vector<int>& order, const std::vector<int>& group, int begin, int end) {
  if (group.empty()) return -1;
  // Entries per group in the range (a cluster of two faces is one entry: partners share a group).
  std::vector<std::pair<int, int>> counts;  // (group, entries)
  for (int i = begin; i < end; ++i) {
    const int g = group[order[i]];
    auto it = std::find_if(counts.begin(), counts.end(), [g](const auto& c) { return c.first == g; });
    if (it == counts.end()) {
      if (counts.size() >= 64) return -1;  // many small pieces: median splits
      counts.push_back({g, 1});
    } else {
      ++it->second;
    }
  }
  if (counts.size() < 2) return -1;
  for (const auto& [g, n] : counts)
    if (n < kGroupLeaves / 2) return -1;  // clusters are pairs: entries, not leaves
  std::stable_sort(order.begin() + begin, order.begin() + end, [&](int a, int b) { return group[a] < group[b]; });
  int split = -1;
  for (int i = begin + 1; i < end; ++i)
    if (group[order[i]] != group[order[i - 1]] && (split < 0 || std::abs(2 * i - begin - end) < std::abs(2 * split - begin - end)))
      split = i;
  return split;
}

int AabbTree::build_range(std::vector<int>& order, std::vector<Vec3>& centre, const std::vector<int>& partner,
                           const std::vector<int>& group, int begin, int end) {
  const int index = static_cast<int>(nodes_.size());
  nodes_.push_back({});
  if (end - begin == 1) {
    const int leaf = order[begin], other = partner.empty() ? -1 : partner[leaf];
    if (other < 0) {
      nodes_[index].leaf = leaf;
    } else {  // a pair: two leaves under this node
      for (const int member : {leaf, other}) {
        const int child = static_cast<int>(nodes_.size());
        nodes_.push_back({});
        nodes_[child].leaf = member;
        post_order_.push_back(child);
        (member == leaf ? nodes_[index].left : nodes_[index].right) = child;
      }
    }
    post_order_.push_back(index);
    return index;
  }
  int mid = group_split(order, group, begin, end);
  if (mid < 0) {
    Aabb bounds;
    for (int i = begin; i < end; ++i) bounds.expand(centre[order[i]]);
    int axis;
    (bounds.hi - bounds.lo).maxCoeff(&axis);
    mid = (begin + end) / 2;
    std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end, [&](int a, int b) {
      return centre[a][axis] < centre[b][axis] || (centre[a][axis] == centre[b][axis] && a < b);
    });
  }
  const int left = build_range(order, centre, partner, group, begin, mid);
  const int right = build_range(order, centre, partner, group, mid, end);
  nodes_[index].left = left;
  nodes_[index].right = right;
  post_order_.push_back(index);
  return index;
}

template <class Fit>
void AabbTree::fit_bottom_up(Fit&& fit, int threads) {
  if (threads <= 1 || static_cast<int>(nodes_.size()) < 2 * kParallelBoxes) {
    for (int n : post_order_) fit(n);
    return;
  }
  for (const std::vector<int>& level : by_height_) {
    const int count = static_cast<int>(level.size());
#pragma omp parallel for schedule(static) num_threads(threads) if (count >= kParallelBoxes / 4)
    for (int k = 0; k < count; ++k) fit(level[k]);
  }
}

void AabbTree::refit(const std::vector<Aabb>& leaves, int threads) {
  moving_valid_ = false;
  auto fit = [&](int n) {
    Node& node = nodes_[n];
    if (node.leaf >= 0) {
      node.box = leaves[node.leaf];
    } else {
      node.box = nodes_[node.left].box;
      node.box.expand(nodes_[node.right].box);
    }
  };
  fit_bottom_up(fit, threads);
}

void AabbTree::refit(const std::vector<Aabb>& start, const std::vector<Aabb>& end, int threads) {
  moving_.resize(nodes_.size());
  moving_valid_ = true;
  auto fit = [&](int n) {
    Node& node = nodes_[n];
    Moving& m = moving_[n];
    if (node.leaf >= 0) {
      m.start = start[node.leaf];
      m.end = end[node.leaf];
    } else {
      m.start = moving_[node.left].start;
      m.start.expand(moving_[node.right].start);
      m.end = moving_[node.left].end;
      m.end.expand(moving_[node.right].end);
    }
    node.box = m.start;
    node.box.expand(m.end);
  };
  fit_bottom_up(fit, threads);
}

void AabbTree::topmost_marked(const std::vector<char>& marked, std::vector<int>& leaf_top) const {
  int leaves = 0;
  for (const Node& node : nodes_) leaves += node.leaf >= 0;
  leaf_top.assign(leaves, -1);
  if (nodes_.empty()) return;
  std::vector<std::pair<int, int>> stack = {{0, marked[0] ? 0 : -1}};  // (node, topmost marked above)
  while (!stack.empty()) {
    const auto [n, top] = stack.back();
    stack.pop_back();
    const Node& node = nodes_[n];
    if (node.leaf >= 0) {
      leaf_top[node.leaf] = top;
      continue;
    }
    for (int child : {node.left, node.right}) stack.push_back({child, top >= 0 ? top : (marked[child] ? child : -1)});
  }
}

void AabbTree::self_pairs(std::vector<std::pair<int, int>>& out, const std::vector<char>* culled, int threads,
                          double shrink) const {
  if (nodes_.empty()) return;
  if (threads <= 1) {
    self_node(0, out, culled, nullptr, shrink);
    return;
  }
  run_tasks(split_tasks({{0, 0, true}}, *this, true, culled, 16 * threads), *this, true, culled, threads, out, nullptr,
            shrink);
}

void AabbTree::self_pairs(const Vec3& shift, std::vector<std::pair<int, int>>& out, const std::vector<char>* culled,
                          int threads, double shrink) const {
  if (nodes_.empty()) return;
  if (threads <= 1) {
    self_node(0, out, culled, &shift, shrink);
    return;
  }
  run_tasks(split_tasks({{0, 0, true}}, *this, true, culled, 16 * threads, &shift), *this, true, culled, threads, out,
            &shift, shrink);
}

std::vector<AabbTree::Task> AabbTree::split_tasks(std::vector<Task> tasks, const AabbTree& tb, bool same,
                                                  const std::vector<char>* culled, int wanted,
                                                  const Vec3* shift) const {
  // Breadth-first: replace every task by its sub-tasks in the recursion's order until there are
  // enough (or nothing splits); leaf-leaf and non-overlapping tasks stay as they are.
  for (int round = 0; round < 32 && static_cast<int>(tasks.size()) < wanted; ++round) {
    std::vector<Task> next;
    next.reserve(2 * tasks.size());
    bool split = false;
    for (const Task& t : tasks) {
      if (t.self) {
        const Node& node = nodes_[t.a];
        if (node.leaf >= 0 || (culled && (*culled)[t.a])) continue;  // no pairs
        next.push_back({node.left, 0, true});
        next.push_back({node.right, 0, true});
        next.push_back({node.left, node.right, false});
        split = true;
        continue;
      }
      const Node& na = nodes_[t.a];
      const Node& nb = tb.nodes_[t.b];
      const Aabb box_a = box_of(t.a, shift), box_b = tb.box_of(t.b, shift);
      if (!box_a.overlaps(box_b)) continue;  // no pairs
      if (na.leaf >= 0 && nb.leaf >= 0) {
        next.push_back(t);
        continue;
      }
      const bool split_a =
          nb.leaf >= 0 || (na.leaf < 0 && (box_a.hi - box_a.lo).sum() >= (box_b.hi - box_b.lo).sum());
      if (split_a) {
        next.push_back({na.left, t.b, false});
        next.push_back({na.right, t.b, false});
      } else {
        next.push_back({t.a, nb.left, false});
        next.push_back({t.a, nb.right, false});
      }
      split = true;
    }
    tasks.swap(next);
    if (!split) break;
  }
  return tasks;
}

void AabbTree::run_tasks(const std::vector<Task>& tasks, const AabbTree& tb, bool same,
                         const std::vector<char>* culled, int threads, std::vector<std::pair<int, int>>& out,
                         const Vec3* shift, double shrink) const {
  ordered_append(static_cast<std::int64_t>(tasks.size()), 1, threads, out,
                 [&](std::int64_t k, std::vector<std::pair<int, int>>& part) {
                   const Task& t = tasks[k];
                   if (t.self)
                     self_node(t.a, part, culled, shift, shrink);
                   else
                     cross(t.a, tb, t.b, same, part, shift, shrink);
                 });
}

void AabbTree::self_node(int n, std::vector<std::pair<int, int>>& out, const std::vector<char>* culled,
                         const Vec3* shift, double shrink) const {
  const Node& node = nodes_[n];
  if (node.leaf >= 0 || (culled && (*culled)[n])) return;
  self_node(node.left, out, culled, shift, shrink);
  self_node(node.right, out, culled, shift, shrink);
  cross(node.left, *this, node.right, true, out, shift, shrink);
}

void AabbTree::pairs(const AabbTree& other, std::vector<std::pair<int, int>>& out, int threads) const {
  if (nodes_.empty() || other.nodes_.empty()) return;
  if (threads <= 1) {
    cross(0, other, 0, false, out);
    return;
  }
  run_tasks(split_tasks({{0, 0, false}}, other, false, nullptr, 16 * threads), other, false, nullptr, threads, out);
}

void AabbTree::pairs(const AabbTree& other, const Vec3& shift, std::vector<std::pair<int, int>>& out,
                     int threads) const {
  if (nodes_.empty() || other.nodes_.empty()) return;
  if (threads <= 1) {
    cross(0, other, 0, false, out, &shift);
    return;
  }
  run_tasks(split_tasks({{0, 0, false}}, other, false, nullptr, 16 * threads, &shift), other, false, nullptr, threads,
            out, &shift);
}

void AabbTree::cross(int a, const AabbTree& tb, int b, bool same, std::vector<std::pair<int, int>>& out,
                     const Vec3* shift, double shrink) const {
  if (shift == nullptr) {
    cross_with(a, tb, b, same, out, [this](int n) -> const Aabb& { return nodes_[n].box; },
               [&tb](int n) -> const Aabb& { return tb.nodes_[n].box; }, shrink);
  } else {
    cross_with(a, tb, b, same, out, [this, shift](int n) { return shifted_box(n, *shift); },
               [&tb, shift](int n) { return tb.shifted_box(n, *shift); }, shrink);
  }
}

template <class BoxA, class BoxB>
void AabbTree::cross_with(int a, const AabbTree& tb, int b, bool same, std::vector<std::pair<int, int>>& out,
                          BoxA&& box_a, BoxB&& box_b, double shrink) const {
  // Depth-first, the larger box split first, the two halves in order: an explicit stack that
  // visits (and lists) exactly as the recursion would, with each half's boxes tested before it
  // is pushed. Each step pushes at most two pairs and descends one level in one of the trees
  // (each under 64 levels deep, see query()), so 256 entries are enough.
  if (!box_a(a).overlaps(box_b(b), shrink)) return;
  std::pair<int, int> stack[256];
  int top = 0;
  stack[top++] = {a, b};
  while (top > 0) {
    const auto [ia, ib] = stack[--top];
    const Node& na = nodes_[ia];
    const Node& nb = tb.nodes_[ib];
    if (na.leaf >= 0 && nb.leaf >= 0) {
      if (same)
        out.emplace_back(std::min(na.leaf, nb.leaf), std::max(na.leaf, nb.leaf));
      else
        out.emplace_back(na.leaf, nb.leaf);
      continue;
    }
    const auto& ba = box_a(ia);
    const auto& bb = box_b(ib);
    const bool split_a = nb.leaf >= 0 || (na.leaf < 0 && (ba.hi - ba.lo).sum() >= (bb.hi - bb.lo).sum());
    // Second half first onto the stack: the first is visited first.
    if (split_a) {
      if (box_a(na.right).overlaps(bb, shrink)) stack[top++] = {na.right, ib};
      if (box_a(na.left).overlaps(bb, shrink)) stack[top++] = {na.left, ib};
    } else {
      if (ba.overlaps(box_b(nb.right), shrink)) stack[top++] = {ia, nb.right};
      if (ba.overlaps(box_b(nb.left), shrink)) stack[top++] = {ia, nb.left};
    }
  }
}

}  // namespace weft
