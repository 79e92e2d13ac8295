// AABB tree traversals: the parallel task split gives the serial pair lists, in the same order,
// and the pairs are exactly the overlapping boxes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <set>
#include <stdexcept>

#include "support/grid_faces.h"
#include "weft/geometry/aabb_tree.h"

using namespace weft;

namespace {
std::vector<Aabb> random_boxes(int count, unsigned seed, double size) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<Aabb> boxes(count);
  for (Aabb& box : boxes) {
    const Vec3 c(unit(rng), unit(rng), 0.2 * unit(rng));
    box.expand(c);
    box.inflate(size * (0.5 + unit(rng)));
  }
  return boxes;
}
}  // namespace

TEST(AabbTree, ParallelTraversalsEqualTheSerialOnes) {
  const std::vector<Aabb> a = random_boxes(3000, 1, 0.01), b = random_boxes(1200, 2, 0.015);
  AabbTree ta, tb;
  ta.build(a);
  tb.build(b);
  std::vector<std::pair<int, int>> serial, parallel;
  ta.self_pairs(serial);
  ASSERT_GT(serial.size(), 1000u);
  for (int threads : {2, 3, 8}) {
    parallel.clear();
    ta.self_pairs(parallel, nullptr, threads);
    EXPECT_EQ(parallel, serial) << threads << " threads";
  }
  // Brute force: the self pairs are exactly the overlapping ones, each once.
  std::set<std::pair<int, int>> expected;
  for (int i = 0; i < static_cast<int>(a.size()); ++i)
    for (int j = i + 1; j < static_cast<int>(a.size()); ++j)
      if (a[i].overlaps(a[j])) expected.insert({i, j});
  const std::set<std::pair<int, int>> found(serial.begin(), serial.end());
  EXPECT_EQ(found, expected);
  EXPECT_EQ(serial.size(), expected.size());

  serial.clear();
  ta.pairs(tb, serial);
  ASSERT_GT(serial.size(), 100u);
  std::set<std::pair<int, int>> expected_across;
  for (int i = 0; i < static_cast<int>(a.size()); ++i)
    for (int j = 0; j < static_cast<int>(b.size()); ++j)
      if (a[i].overlaps(b[j])) expected_across.insert({i, j});
  const std::set<std::pair<int, int>> found_across(serial.begin(), serial.end());
  EXPECT_EQ(found_across, expected_across);
  EXPECT_EQ(serial.size(), expected_across.size());
  for (int threads : {2, 5}) {
    parallel.clear();
    ta.pairs(tb, parallel, threads);
    EXPECT_EQ(parallel, serial) << threads << " threads";
  }

  // With culled nodes: every other inner node culled, same lists for any thread count.
  std::vector<char> culled(ta.node_count(), 0);
  for (int n = 0; n < ta.node_count(); n += 7)
    if (ta.leaf(n) < 0 && n != 0) culled[n] = 1;
  serial.clear();
  ta.self_pairs(serial, &culled);
  ASSERT_GT(serial.size(), 0u);
  parallel.clear();
  ta.self_pairs(parallel, &culled, 4);
  EXPECT_EQ(parallel, serial);

  // topmost_marked: an overlapping pair is skipped exactly when both leaves have the same
  // topmost culled node above them.
  std::vector<int> top;
  ta.topmost_marked(culled, top);
  ASSERT_EQ(top.size(), a.size());
  std::set<std::pair<int, int>> kept;
  for (const auto& [i, j] : expected)
    if (top[i] < 0 || top[i] != top[j]) kept.insert({i, j});
  const std::set<std::pair<int, int>> culled_found(serial.begin(), serial.end());
  EXPECT_EQ(culled_found, kept);
  EXPECT_LT(kept.size(), expected.size());
}

// A self traversal with a shrink lists exactly the pairs whose boxes overlap by that much along
// every axis (Aabb::overlaps(b, shrink)), fewer than without, in the same order for any thread
// count, shifted too.
TEST(AabbTree, SelfPairsWithAShrinkListThePairsOverlappingByIt) {
  const std::vector<Aabb> a = random_boxes(2000, 3, 0.01);
  AabbTree tree;
  tree.build(a);
  const double shrink = 0.008;
  std::vector<std::pair<int, int>> serial, parallel, plain;
  tree.self_pairs(serial, nullptr, 1, shrink);
  tree.self_pairs(plain);
  std::set<std::pair<int, int>> expected;
  for (int i = 0; i < static_cast<int>(a.size()); ++i)
    for (int j = i + 1; j < static_cast<int>(a.size()); ++j)
      if (a[i].overlaps(a[j], shrink)) expected.insert({i, j});
  const std::set<std::pair<int, int>> found(serial.begin(), serial.end());
  EXPECT_EQ(found, expected);
  EXPECT_EQ(serial.size(), expected.size());
  EXPECT_GT(serial.size(), 100u);
  EXPECT_LT(serial.size(), plain.size() * 3 / 4);
  tree.self_pairs(parallel, nullptr, 4, shrink);
  EXPECT_EQ(parallel, serial);
  // A box grown by m overlaps another grown by m by at least m exactly when the ungrown boxes
  // are within m of each other.
  Aabb p, q;
  p.expand(Vec3(0, 0, 0));
  q.expand(Vec3(0.006, 0, 0));
  p.inflate(0.004);
  q.inflate(0.004);
  EXPECT_TRUE(p.overlaps(q));
  EXPECT_FALSE(p.overlaps(q, 0.004));  // 6 mm apart, more than the 4 mm margin
  EXPECT_TRUE(p.overlaps(q, 0.0019));  // within 8 - 1.9 mm
}

// The nearest-first search keeps what a full scan keeps: with "distance" the box's own distance
// to the point (ties on purpose: boxes repeated), the nearest leaf within the radius and the
// lowest index among equally near ones. It visits far fewer leaves than there are.
TEST(AabbTree, TheNearestFirstSearchFindsWhatAFullScanFinds) {
  std::vector<Aabb> boxes = random_boxes(2000, 3, 0.01);
  for (int k = 0; k < 200; ++k) boxes[1000 + 5 * k] = boxes[7 * k];  // equally near leaves
  AabbTree tree;
  tree.build(boxes);
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  long visited = 0;
  for (int q = 0; q < 500; ++q) {
    const Vec3 p(unit(rng), unit(rng), 0.3 * unit(rng) - 0.05);
    const double band = 0.05;
    int scan = -1;
    double scan_d = band;
    for (int k = 0; k < static_cast<int>(boxes.size()); ++k) {
      const double d = std::sqrt(boxes[k].squared_distance(p));
      if (d < scan_d || (d == scan_d && scan >= 0 && k < scan)) {
        scan_d = d;
        scan = k;
      }
    }
    int found = -1;
    double found_d = band, radius = band;
    tree.nearest(p, radius, [&](int k) {
      ++visited;
      const double d = std::sqrt(boxes[k].squared_distance(p));
      if (d < found_d || (d == found_d && found >= 0 && k < found)) {
        found_d = d;
        found = k;
        radius = d;
      }
    });
    ASSERT_EQ(found, scan) << "query " << q;
  }
  EXPECT_LT(visited, 500L * 2000 / 20);
}

// The search's pruned bound: every leaf it did not visit lies at least that far from the point
// (the bound a caller takes for "nothing nearer"), and a search that visits nothing reports the
// nearest box's distance or more.
TEST(AabbTree, EveryLeafTheSearchSkipsLiesBeyondItsPrunedBound) {
  const std::vector<Aabb> boxes = random_boxes(2000, 8, 0.01);
  AabbTree tree;
  tree.build(boxes);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> unit(-0.5, 1.5);
  int skipped_some = 0;
  for (int q = 0; q < 300; ++q) {
    const Vec3 p(unit(rng), unit(rng), unit(rng));
    double radius = 0.02;
    double pruned = std::numeric_limits<double>::infinity();
    std::vector<char> visited(boxes.size(), 0);
    tree.nearest(p, radius, [&](int k) { visited[k] = 1; }, &pruned);
    double nearest_skipped = std::numeric_limits<double>::infinity();
    for (size_t k = 0; k < boxes.size(); ++k)
      if (!visited[k]) nearest_skipped = std::min(nearest_skipped, boxes[k].squared_distance(p));
    ASSERT_LE(pruned, nearest_skipped) << "query " << q;
    ASSERT_GT(pruned, radius * radius) << "query " << q;  // only subtrees beyond the radius are pruned
    if (std::isfinite(nearest_skipped)) ++skipped_some;
  }
  EXPECT_EQ(skipped_some, 300);
}

// Boxes and refits on two threads give the trees of one thread: the same pairs, in order.
TEST(AabbTree, ParallelRefitsEqualTheSerialOnes) {
  const std::vector<Aabb> a = random_boxes(6000, 5, 0.01), moved = random_boxes(6000, 6, 0.012);
  AabbTree serial, parallel;
  serial.build(a);
  parallel.build(a);
  serial.refit(moved, 1);
  parallel.refit(moved, 2);
  EXPECT_EQ(serial.bounds().lo, parallel.bounds().lo);
  EXPECT_EQ(serial.bounds().hi, parallel.bounds().hi);
  std::vector<std::pair<int, int>> one, two;
  serial.self_pairs(one);
  parallel.self_pairs(two);
  ASSERT_GT(one.size(), 1000u);
  EXPECT_EQ(one, two);
  // The boxes of a refit with moved leaves: the pairs are those of the moved boxes.
  int overlapping = 0;
  for (size_t i = 0; i < moved.size(); ++i)
    for (size_t j = i + 1; j < moved.size(); ++j) overlapping += moved[i].overlaps(moved[j]);
  EXPECT_EQ(static_cast<int>(two.size()), overlapping);
}

// Boxes moving over a step (start and end boxes), most of them carried along by one motion:
// traversals in the frame moving with it list exactly the leaves whose boxes overlap there
// (start box joined with the end box less the shift), the same for any thread count, and far
// fewer than the world-frame boxes overlap.
TEST(AabbTree, ShiftedTraversalsListTheBoxesOverlappingInTheMovingFrame) {
  const Vec3 carry(0.05, 0.02, 0.0);
  auto moving = [&](int count, unsigned seed, std::vector<Aabb>& start, std::vector<Aabb>& end,
                    std::vector<Aabb>& swept) {
    start = random_boxes(count, seed, 0.008);
    std::mt19937 rng(seed + 100);
    std::uniform_real_distribution<double> jitter(-0.002, 0.002);
    end = start;
    swept = start;
    for (int i = 0; i < count; ++i) {
      const Vec3 d = carry + Vec3(jitter(rng), jitter(rng), jitter(rng));
      end[i].lo += d;
      end[i].hi += d;
      swept[i].expand(end[i]);
    }
  };
  std::vector<Aabb> as, ae, a, bs, be, b;
  moving(2000, 5, as, ae, a);
  moving(800, 6, bs, be, b);
  AabbTree ta, tb;
  ta.build(a);
  tb.build(b);
  ta.refit(as, ae);
  tb.refit(bs, be);
  ASSERT_TRUE(ta.moving() && tb.moving());
  auto shifted = [&](const std::vector<Aabb>& s, const std::vector<Aabb>& e, int i) {
    Aabb box = e[i];
    box.lo -= carry;
    box.hi -= carry;
    box.expand(s[i]);
    return box;
  };
  std::set<std::pair<int, int>> expected_self, expected_across;
  size_t world_self = 0;
  for (int i = 0; i < static_cast<int>(a.size()); ++i) {
    for (int j = i + 1; j < static_cast<int>(a.size()); ++j) {
      if (shifted(as, ae, i).overlaps(shifted(as, ae, j))) expected_self.insert({i, j});
      world_self += a[i].overlaps(a[j]);
    }
    for (int j = 0; j < static_cast<int>(b.size()); ++j)
      if (shifted(as, ae, i).overlaps(shifted(bs, be, j))) expected_across.insert({i, j});
  }
  std::vector<std::pair<int, int>> self, across;
  ta.self_pairs(carry, self);
  ta.pairs(tb, carry, across);
  ASSERT_GT(self.size(), 100u);
  ASSERT_GT(across.size(), 50u);
  using PairSet = std::set<std::pair<int, int>>;
  EXPECT_EQ(PairSet(self.begin(), self.end()), expected_self);
  EXPECT_EQ(self.size(), expected_self.size());
  EXPECT_EQ(PairSet(across.begin(), across.end()), expected_across);
  EXPECT_EQ(across.size(), expected_across.size());
  EXPECT_LT(4 * self.size(), world_self) << self.size() << " shifted, " << world_self << " in the world";
  for (int threads : {2, 5}) {
    std::vector<std::pair<int, int>> parallel_self, parallel_across;
    ta.self_pairs(carry, parallel_self, nullptr, threads);
    ta.pairs(tb, carry, parallel_across, threads);
    EXPECT_EQ(parallel_self, self) << threads << " threads";
    EXPECT_EQ(parallel_across, across) << threads << " threads";
  }
  // A query in the moving frame: the leaves whose shifted boxes overlap the query box.
  const Aabb probe = shifted(bs, be, 17);
  std::set<int> hits, expected_hits;
  ta.query(probe, carry, [&](int leaf) { hits.insert(leaf); });
  for (int i = 0; i < static_cast<int>(a.size()); ++i)
    if (shifted(as, ae, i).overlaps(probe)) expected_hits.insert(i);
  EXPECT_EQ(hits, expected_hits);
  // A plain refit leaves the tree not moving.
  ta.refit(a);
  EXPECT_FALSE(ta.moving());
}

// A grid's faces pair into its cells (across each cell's diagonal, its longest edge), and a tree
// built with those partners has each pair under a node of its own and lists exactly the
// overlapping boxes, as one without them does. Partners that do not pair mutually are refused.
TEST(AabbTree, PairedLeavesAreSiblingsAndTraversalsStayExact) {
  const int n = 9;
  const Faces faces = weft::testing::grid_faces(n);
  Positions x(n * n, 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) x.row(i * n + j) << 0.01 * i, 0.002 * std::sin(1.3 * i + 0.7 * j), 0.01 * j;
  const std::vector<int> partner = pair_faces_across_edges(faces, x);
  ASSERT_EQ(partner.size(), static_cast<size_t>(faces.rows()));
  for (int f = 0; f < faces.rows(); ++f) EXPECT_EQ(partner[f], f ^ 1) << f;  // the cell's other face
  std::vector<Aabb> boxes;
  triangle_boxes(faces, x, x, std::vector<double>(faces.rows(), 0.004), boxes);
  AabbTree paired, plain;
  paired.build(boxes, partner);
  plain.build(boxes);
  std::vector<int> parent(paired.node_count(), -1);
  for (int node = 0; node < paired.node_count(); ++node)
    if (paired.leaf(node) < 0) parent[paired.left(node)] = parent[paired.right(node)] = node;
  std::vector<int> leaf_parent(faces.rows(), -1);
  for (int node = 0; node < paired.node_count(); ++node)
    if (paired.leaf(node) >= 0) leaf_parent[paired.leaf(node)] = parent[node];
  for (int f = 0; f < faces.rows(); ++f) EXPECT_EQ(leaf_parent[f], leaf_parent[partner[f]]) << f;
  std::vector<std::pair<int, int>> a, b;
  paired.self_pairs(a);
  plain.self_pairs(b);
  auto normalised = [](std::vector<std::pair<int, int>> v) {
    for (auto& p : v)
      if (p.first > p.second) std::swap(p.first, p.second);
    std::sort(v.begin(), v.end());
    return v;
  };
  ASSERT_GT(a.size(), 100u);
  EXPECT_EQ(normalised(a), normalised(b));
  std::vector<int> one_sided(faces.rows(), -1);
  one_sided[0] = 1;
  EXPECT_THROW(paired.build(boxes, one_sided), std::invalid_argument);
}

// Two interleaved pieces (a grid and a copy 3 mm above it, their faces listed alternately): with
// their components as groups the root splits them apart and every node below holds one piece,
// so that the self-collision culling can take whole patches; the pairs stay those of the
// ungrouped tree. A piece below kGroupLeaves is not split off.
TEST(AabbTree, GroupsGetSubtreesOfTheirOwn) {
  const int n = 9;
  const Faces grid = weft::testing::grid_faces(n);
  const int grid_faces_count = static_cast<int>(grid.rows()), grid_vertices = n * n;
  Faces faces(2 * grid_faces_count, 3);
  Positions x(2 * grid_vertices, 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      x.row(i * n + j) << 0.01 * i, 0.0, 0.01 * j;
      x.row(grid_vertices + i * n + j) << 0.01 * i, 0.003, 0.01 * j;
    }
  for (int f = 0; f < grid_faces_count; ++f) {
    faces.row(2 * f) = grid.row(f);
    faces.row(2 * f + 1) = grid.row(f).array() + grid_vertices;
  }
  const std::vector<int> group = face_components(faces, static_cast<int>(x.rows()));
  for (int f = 0; f < faces.rows(); ++f) EXPECT_EQ(group[f], f % 2 == 0 ? 0 : grid_vertices) << f;
  std::vector<Aabb> boxes;
  triangle_boxes(faces, x, x, std::vector<double>(faces.rows(), 0.004), boxes);
  AabbTree grouped, plain;
  grouped.build(boxes, pair_faces_across_edges(faces, x), group);
  plain.build(boxes, pair_faces_across_edges(faces, x));
  // The groups under every node of a tree, bottom-up.
  auto groups_under = [&group](const AabbTree& tree) {
    std::vector<std::set<int>> under(tree.node_count());
    for (int node : tree.post_order()) {
      if (tree.leaf(node) >= 0)
        under[node] = {group[tree.leaf(node)]};
      else
        for (int child : {tree.left(node), tree.right(node)}) under[node].insert(under[child].begin(), under[child].end());
    }
    return under;
  };
  const std::vector<std::set<int>> grouped_under = groups_under(grouped), plain_under = groups_under(plain);
  EXPECT_EQ(grouped_under[0].size(), 2u);
  EXPECT_EQ(grouped_under[grouped.left(0)].size(), 1u);
  EXPECT_EQ(grouped_under[grouped.right(0)].size(), 1u);
  // Without groups, median splits mix both pieces far down.
  const auto mixed_plain = std::count_if(plain_under.begin(), plain_under.end(), [](const std::set<int>& s) { return s.size() > 1; });
  EXPECT_GT(mixed_plain, 10);
  std::vector<std::pair<int, int>> a, b;
  grouped.self_pairs(a);
  plain.self_pairs(b);
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  EXPECT_EQ(a, b);
  // A piece of a single cell is too small to be split off.
  std::vector<int> tiny(faces.rows(), 0);
  tiny[0] = tiny[1] = 7;
  AabbTree with_tiny;
  with_tiny.build(boxes, {}, tiny);
  std::vector<int> leaves_under(with_tiny.node_count(), 0);
  for (int node : with_tiny.post_order())
    leaves_under[node] = with_tiny.leaf(node) >= 0
                             ? 1
                             : leaves_under[with_tiny.left(node)] + leaves_under[with_tiny.right(node)];
  EXPECT_EQ(leaves_under[with_tiny.left(0)], leaves_under[with_tiny.right(0)]);  // a median split
  EXPECT_THROW(grouped.build(boxes, pair_faces_across_edges(faces, x), std::vector<int>(3, 0)), std::invalid_argument);
}
