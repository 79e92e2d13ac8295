// The one bounding volume hierarchy: an axis-aligned bounding-box tree over triangles (median
// splits, one triangle per leaf). The collision broad phase builds it once from the
// connectivity's initial shape and refits it every step, so its cost is linear in the number of
// triangles; intersection counting and GIA build one per configuration.
#pragma once

#include <limits>
#include <vector>

#include "weft/common/types.h"

namespace weft {

struct Aabb {
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 hi = Vec3::Constant(-std::numeric_limits<double>::infinity());
  void expand(const Vec3& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  void expand(const Aabb& b) {
    lo = lo.cwiseMin(b.lo);
    hi = hi.cwiseMax(b.hi);
  }
  void inflate(double r) {
    lo.array() -= r;
    hi.array() += r;
  }
  bool overlaps(const Aabb& b) const {
    return (lo.array() <= b.hi.array()).all() && (b.lo.array() <= hi.array()).all();
  }
  // Whether the boxes overlap by at least `shrink` along every axis: boxes of features grown by
  // margins m_a and m_b pass when the features' boxes are within m_a + m_b - shrink.
  bool overlaps(const Aabb& b, double shrink) const {
    return (lo.array() + shrink <= b.hi.array()).all() && (b.lo.array() + shrink <= hi.array()).all();
  }
  bool contains(const Vec3& p) const { return (lo.array() <= p.array()).all() && (p.array() <= hi.array()).all(); }
  // Squared distance from p to the box (0 inside): no point of the box is nearer.
  double squared_distance(const Vec3& p) const {
    return (lo - p).cwiseMax(p - hi).cwiseMax(0.0).squaredNorm();
  }
};

// The box over a step of something whose box is `start` at its start and `end` at its end, seen
// from a frame that moves by `shift` over the step: a point moving linearly from s to e moves
// from s to e - shift there, and two points' distance at each instant is the same in either
// frame. Shift zero: the plain swept box.
inline Aabb swept_box(const Aabb& start, const Aabb& end, const Vec3& shift) {
  Aabb box = end;
  box.lo -= shift;
  box.hi -= shift;
  box.expand(start);
  return box;
}

// Boxes of triangles spanning two configurations (start and end of a step), widened by a
// per-triangle margin. end may be the same object as start (static boxes). Each box on its own:
// the same for any thread count.
void triangle_boxes(const Faces& faces, const Positions& start, const Positions& end,
                    const std::vector<double>& margin, std::vector<Aabb>& boxes, int threads = 1);
// The box of triangle f alone, as triangle_boxes computes it (margin[f], or none when empty).
Aabb triangle_box(const Faces& faces, const Positions& start, const Positions& end, const std::vector<double>& margin,
                  int f);
// Partners for AabbTree::build: each face, in order, paired with its first unpaired neighbour
// across an edge shared by exactly two faces, trying its edges from the longest at x (a grid
// cell's diagonal first, so a grid's faces pair into its cells); -1 where none is left.
std::vector<int> pair_faces_across_edges(const Faces& faces, const Positions& x);
// Groups for AabbTree::build: per face, its piece (faces connected through shared vertices),
// numbered by the piece's lowest vertex.
std::vector<int> face_components(const Faces& faces, int vertex_count);

class AabbTree {
 public:
  // Builds the hierarchy over the given leaf boxes (leaf i is box i) by median splits of their
  // centres. With `partner` (per leaf, the leaf to pair it with, mutually, or -1), paired leaves
  // are one cluster, split at the centre of their union and made siblings under a node of their
  // own: the two triangles of a grid cell share one box, so their tied centres fell to either
  // side by index, and nodes were strips of triangles that touch at corners only.
  // With `group` (per leaf, e.g. the cloth piece of a face), a range of leaves with several
  // groups of at least kGroupLeaves leaves each is split between groups before any median
  // split (at the group boundary nearest its middle, groups in id order): pieces that overlap
  // in space (a skirt over a dress) get subtrees of their own, whose nodes are patches of one
  // piece that the self-collision culling can skip, where median splits mixed both pieces'
  // faces down to small nodes. Partners must share a group.
  void build(const std::vector<Aabb>& leaves, const std::vector<int>& partner = {},
             const std::vector<int>& group = {});
  // Leaves a group needs in a range for build() to split the range between groups.
  static constexpr int kGroupLeaves = 32;
  // Same leaves, new boxes: recompute node boxes bottom-up (with threads, one height at a time,
  // each node from its children only: the same boxes for any thread count).
  void refit(const std::vector<Aabb>& leaves, int threads = 1);
  // Same leaves, moving over a step: each leaf's box at the start and at the end. Node boxes are
  // their union (the step's swept boxes, as refit(union) gives), and every node also keeps its
  // start and end boxes, so that a traversal can test the boxes swept in a frame that moves
  // with a constant velocity (pairs and query with a shift). A plain refit drops them.
  void refit(const std::vector<Aabb>& start, const std::vector<Aabb>& end, int threads = 1);
  bool moving() const { return moving_valid_; }
  // Node n's box over the step seen from a frame that moves by `shift` over it (swept_box; the
  // tree must be moving()). Shift zero: the node's box.
  Aabb shifted_box(int n, const Vec3& shift) const { return swept_box(moving_[n].start, moving_[n].end, shift); }
  bool empty() const { return nodes_.empty(); }

  // The hierarchy (node 0 is the root), for per-node data kept outside the tree.
  // The surface-area cost of the hierarchy: the summed half surface areas of its inner nodes'
  // boxes (what a traversal's expected work grows with; the measure of build heuristics).
  double surface_cost() const;
  int node_count() const { return static_cast<int>(nodes_.size()); }
  int left(int n) const { return nodes_[n].left; }
  int right(int n) const { return nodes_[n].right; }
  int leaf(int n) const { return nodes_[n].leaf; }  // -1 for inner nodes
  const std::vector<int>& post_order() const { return post_order_; }

  // Every pair (i, j), i < j, of leaves whose boxes overlap (by at least `shrink` along every
  // axis: Aabb::overlaps), except pairs inside a node n with (*culled)[n] != 0 when culled is
  // given (self-collision culling, collision/self_culling.h). threads > 1 splits the traversal
  // into subtree tasks run in parallel and joined in order: the same list, in the same order,
  // for any thread count.
  void self_pairs(std::vector<std::pair<int, int>>& out, const std::vector<char>* culled = nullptr,
                  int threads = 1, double shrink = 0.0) const;
  // The same in the frame moving by `shift` (shifted_box; the tree must be moving()).
  void self_pairs(const Vec3& shift, std::vector<std::pair<int, int>>& out, const std::vector<char>* culled = nullptr,
                  int threads = 1, double shrink = 0.0) const;
  // Per leaf, the topmost node above it (or itself) with marked[node] != 0, -1 where none. Two
  // leaves share a marked node exactly when their entries are equal and not -1, so a pair
  // that self_pairs(out, &marked) skips is one whose leaves have the same entry.
  void topmost_marked(const std::vector<char>& marked, std::vector<int>& leaf_top) const;
  // Every pair (i of this tree, j of other) whose boxes overlap.
  void pairs(const AabbTree& other, std::vector<std::pair<int, int>>& out, int threads = 1) const;
  // Every pair whose boxes overlap in the frame moving by `shift` (shifted_box; both trees
  // moving()): a pair listed by pairs() whose leaves' relative motion keeps them apart is not.
  // The same list for any thread count.
  void pairs(const AabbTree& other, const Vec3& shift, std::vector<std::pair<int, int>>& out, int threads = 1) const;
  // Box of all leaves (the tree must not be empty).
  const Aabb& bounds() const { return nodes_[0].box; }
  // Nearest-first search around point p: visit(leaf) is called for leaves in an order that
  // tends to bring near leaves first, skipping every subtree whose box is farther from p than
  // `radius` (strictly), and may lower `radius` (the distance of the best leaf so far). Every
  // leaf whose box is within the final radius of p is visited, so a search that keeps the
  // nearest leaf (and the lowest index among equally near ones) finds it as a full scan would.
  // pruned (optional): lowered to the smallest squared box distance of a subtree the search
  // skipped for lying beyond the radius, so every leaf not visited lies at least that far.
  template <class Visit>
  void nearest(const Vec3& p, double& radius, Visit&& visit, double* pruned = nullptr) const {
    if (nodes_.empty()) return;
    // Each stacked node with its box's squared distance, computed once (when its parent ordered
    // it): radius only shrinks, so a node beyond it when stacked stays beyond it.
    struct Stacked {
      int node;
      double squared_distance;
    };
    Stacked stack[64];
    int top = 0;
    // A little slack keeps a leaf exactly as near as the best (a tie) despite rounding.
    auto beyond = [&radius, pruned](double squared) {
      const bool skip = squared > radius * radius * (1.0 + 1e-9);
      if (skip && pruned && squared < *pruned) *pruned = squared;
      return skip;
    };
    stack[top++] = {0, nodes_[0].box.squared_distance(p)};
    while (top > 0) {
      const Stacked entry = stack[--top];
      if (beyond(entry.squared_distance)) continue;
      const Node& node = nodes_[entry.node];
      if (node.leaf >= 0) {
        visit(node.leaf);
        continue;
      }
      // The nearer child on top of the stack: visited first.
      const double left = nodes_[node.left].box.squared_distance(p);
      const double right = nodes_[node.right].box.squared_distance(p);
      const bool left_nearer = left <= right;
      const Stacked nearer = left_nearer ? Stacked{node.left, left} : Stacked{node.right, right};
      const Stacked farther = left_nearer ? Stacked{node.right, right} : Stacked{node.left, left};
      if (!beyond(farther.squared_distance)) stack[top++] = farther;
      if (!beyond(nearer.squared_distance)) stack[top++] = nearer;
    }
  }
  // visit(leaf) for every leaf whose box overlaps `box` (closed boxes).
  template <class Visit>
  void query(const Aabb& box, Visit&& visit) const {
    query_with([this](int n) -> const Aabb& { return nodes_[n].box; }, box, visit);
  }
  // The same in the frame moving by `shift` (shifted_box; the tree must be moving()), `box`
  // being the query's box in that frame.
  template <class Visit>
  void query(const Aabb& box, const Vec3& shift, Visit&& visit) const {
    query_with([this, &shift](int n) { return shifted_box(n, shift); }, box, visit);
  }

 private:
  struct Node {
    Aabb box;
    int left = -1, right = -1;  // children, -1 for leaves
    int leaf = -1;              // leaf index for leaves
  };
  struct Moving {
    Aabb start, end;
  };
  template <class NodeBox, class Visit>
  void query_with(NodeBox&& node_box, const Aabb& box, Visit& visit) const {
    if (nodes_.empty()) return;
    int stack[64];  // depth of a median-split tree over < 2^62 leaves
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const int n = stack[--top];
      if (!node_box(n).overlaps(box)) continue;
      const Node& node = nodes_[n];
      if (node.leaf >= 0) {
        visit(node.leaf);
      } else {
        stack[top++] = node.left;
        stack[top++] = node.right;
      }
    }
  }
  // Node n's box as a traversal sees it: its own, or shifted_box when shift is given.
  Aabb box_of(int n, const Vec3* shift) const { return shift ? shifted_box(n, *shift) : nodes_[n].box; }
  // A split of order[begin, end) between groups (see build), or -1 when the range is not split so.
  static int group_split(std::vector<int>& order, const std::vector<int>& group, int begin, int end);
  int build_range(std::vector<int>& order, std::vector<Vec3>& centre, const std::vector<int>& partner,
                  const std::vector<int>& group, int begin,
                  int end);
  // fit(n) for every node, children before parents (with threads, one height at a time).
  template <class Fit>
  void fit_bottom_up(Fit&& fit, int threads);
  template <class BoxA, class BoxB>
  void cross_with(int a, const AabbTree& tb, int b, bool same, std::vector<std::pair<int, int>>& out, BoxA&& box_a,
                  BoxB&& box_b, double shrink) const;
  void self_node(int n, std::vector<std::pair<int, int>>& out, const std::vector<char>* culled,
                 const Vec3* shift = nullptr, double shrink = 0.0) const;
  void cross(int a, const AabbTree& tb, int b, bool same, std::vector<std::pair<int, int>>& out,
             const Vec3* shift = nullptr, double shrink = 0.0) const;
  // A piece of the traversal: the self-pairs of node a (self) or the pairs across (a, b).
  struct Task {
    int a, b;
    bool self;
  };
  // Tasks whose results, concatenated in order, are the whole traversal's.
  std::vector<Task> split_tasks(std::vector<Task> tasks, const AabbTree& tb, bool same,
                                const std::vector<char>* culled, int wanted, const Vec3* shift = nullptr) const;
  void run_tasks(const std::vector<Task>& tasks, const AabbTree& tb, bool same, const std::vector<char>* culled,
                 int threads, std::vector<std::pair<int, int>>& out, const Vec3* shift = nullptr,
                 double shrink = 0.0) const;

  std::vector<Node> nodes_;
  std::vector<Moving> moving_;  // per node, valid after refit(start, end) until a plain refit
  bool moving_valid_ = false;
  std::vector<int> post_order_;  // children before parents, for refitting
  std::vector<std::vector<int>> by_height_;  // nodes by height above the leaves (leaves: 0), for refitting
};

}  // namespace weft
