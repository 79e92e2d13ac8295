#include "weft/geometry/aabb_tree.h"

#include <algorithm>

namespace weft {

void triangle_boxes(const Faces& faces, const Positions& start, const Positions& end,
                    const std::vector<double>& margin, std::vector<Aabb>& boxes) {
  const int count = static_cast<int>(faces.rows());
  boxes.resize(count);
  for (int f = 0; f < count; ++f) {
    Aabb box;
    for (int c = 0; c < 3; ++c) {
      box.expand(row3(start, faces(f, c)));
      if (&end != &start) box.expand(row3(end, faces(f, c)));
    }
    box.inflate(margin.empty() ? 0.0 : margin[f]);
    boxes[f] = box;
  }
}

void AabbTree::build(const std::vector<Aabb>& leaves) {
  nodes_.clear();
  post_order_.clear();
  if (leaves.empty()) return;
  std::vector<int> order(leaves.size());
  std::vector<Vec3> centre(leaves.size());
  for (size_t i = 0; i < leaves.size(); ++i) {
    order[i] = static_cast<int>(i);
    centre[i] = 0.5 * (leaves[i].lo + leaves[i].hi);
  }
  nodes_.reserve(2 * leaves.size());
  build_range(order, centre, 0, static_cast<int>(order.size()));
  refit(leaves);
}

int AabbTree::build_range(std::vector<int>& order, std::vector<Vec3>& centre, int begin, int end) {
  const int index = static_cast<int>(nodes_.size());
  nodes_.push_back({});
  if (end - begin == 1) {
    nodes_[index].leaf = order[begin];
    post_order_.push_back(index);
    return index;
  }
  Aabb bounds;
  for (int i = begin; i < end; ++i) bounds.expand(centre[order[i]]);
  int axis;
  (bounds.hi - bounds.lo).maxCoeff(&axis);
  const int mid = (begin + end) / 2;
  std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end,
                   [&](int a, int b) { return centre[a][axis] < centre[b][axis] || (centre[a][axis] == centre[b][axis] && a < b); });
  const int left = build_range(order, centre, begin, mid);
  const int right = build_range(order, centre, mid, end);
  nodes_[index].left = left;
  nodes_[index].right = right;
  post_order_.push_back(index);
  return index;
}

void AabbTree::refit(const std::vector<Aabb>& leaves) {
  for (int n : post_order_) {
    Node& node = nodes_[n];
    if (node.leaf >= 0) {
      node.box = leaves[node.leaf];
    } else {
      node.box = nodes_[node.left].box;
      node.box.expand(nodes_[node.right].box);
    }
  }
}

void AabbTree::self_pairs(std::vector<std::pair<int, int>>& out, const std::vector<char>* culled) const {
  if (!nodes_.empty()) self_node(0, out, culled);
}

void AabbTree::self_node(int n, std::vector<std::pair<int, int>>& out, const std::vector<char>* culled) const {
  const Node& node = nodes_[n];
  if (node.leaf >= 0 || (culled && (*culled)[n])) return;
  self_node(node.left, out, culled);
  self_node(node.right, out, culled);
  cross(node.left, *this, node.right, true, out);
}

void AabbTree::pairs(const AabbTree& other, std::vector<std::pair<int, int>>& out) const {
  if (!nodes_.empty() && !other.nodes_.empty()) cross(0, other, 0, false, out);
}

void AabbTree::cross(int a, const AabbTree& tb, int b, bool same, std::vector<std::pair<int, int>>& out) const {
  const Node& na = nodes_[a];
  const Node& nb = tb.nodes_[b];
  if (!na.box.overlaps(nb.box)) return;
  if (na.leaf >= 0 && nb.leaf >= 0) {
    if (same)
      out.emplace_back(std::min(na.leaf, nb.leaf), std::max(na.leaf, nb.leaf));
    else
      out.emplace_back(na.leaf, nb.leaf);
    return;
  }
  const bool split_a = nb.leaf >= 0 || (na.leaf < 0 && (na.box.hi - na.box.lo).sum() >= (nb.box.hi - nb.box.lo).sum());
  if (split_a) {
    cross(na.left, tb, b, same, out);
    cross(na.right, tb, b, same, out);
  } else {
    cross(a, tb, nb.left, same, out);
    cross(a, tb, nb.right, same, out);
  }
}

}  // namespace weft
