// Contact detection: one triangle pair expands into its vertex-triangle and edge-edge pairs
// exactly once; the filter's membrane and pinch rules drop or mark them.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>

#include "support/grid_faces.h"
#include "weft/collision/ccd.h"
#include "weft/collision/contact_detection.h"
#include "weft/collision/contact_impulse.h"
#include "weft/collision/sharp_edges.h"

namespace weft {
namespace {

// Two disjoint cloth triangles (vertices 0-2 and 3-5), the second 1 mm above the first.
struct TwoTriangles {
  Faces faces;
  Positions x;
  TwoTriangles() : faces(2, 3), x(6, 3) {
    faces << 0, 1, 2, 3, 4, 5;
    x << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0.1, 0.1, 0.001, 1.1, 0.1, 0.001, 0.1, 1.1, 0.001;
  }
  ContactDetection detection() const {
    return ContactDetection(faces, x, {1, 1}, {1, 1}, {0.002, 0.002}, {}, {});
  }
};

struct SkipAll : ContactFilter {
  bool skip_cloth_pair(int, int) const override { return true; }
};

TEST(ContactDetection, OneTrianglePairExpandsIntoEachFeaturePairOnce) {
  const TwoTriangles t;
  const ContactDetection detection = t.detection();
  std::vector<FeaturePair> pairs;
  detection.expand_triangle_pair(0, 1, -1, ContactFilter(), pairs);
  // 3 + 3 vertex-triangle pairs and 3 x 3 edge-edge pairs, no two alike.
  std::set<std::array<int, 4>> vt, ee;
  for (const FeaturePair& p : pairs) (p.edge_edge ? ee : vt).insert(p.point);
  EXPECT_EQ(pairs.size(), 15u);
  EXPECT_EQ(vt.size(), 6u);
  EXPECT_EQ(ee.size(), 9u);
  EXPECT_TRUE(vt.count({0, 3, 4, 5}) && vt.count({5, 0, 1, 2}));
  EXPECT_TRUE(ee.count({0, 1, 3, 4}));
  for (const FeaturePair& p : pairs) EXPECT_EQ(p.body, -1);
  pairs.clear();
  detection.expand_triangle_pair(0, 1, -1, SkipAll(), pairs);
  EXPECT_TRUE(pairs.empty());
}

TEST(ContactDetection, ASweepListsOnlyTheFeaturePairsWhoseBoxesComeWithinItsGap) {
  // Triangle B overlaps the corner (1, 0) of triangle A from the side, 1 mm above it.
  Faces faces(2, 3);
  faces << 0, 1, 2, 3, 4, 5;
  Positions x(6, 3);
  x << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0.9, 0, 0.001, 1.9, 0, 0.001, 0.9, 1, 0.001;
  const ContactDetection detection(faces, x, {1, 1}, {1, 1}, {0.002, 0.002}, {}, {});
  std::vector<FeaturePair> all, near;
  detection.expand_triangle_pair(0, 1, -1, ContactFilter(), all);
  const double gap = 0.002;
  const ContactDetection::Sweep sweep{&x, &x, &x, &x, gap};
  detection.expand_triangle_pair(0, 1, -1, ContactFilter(), near, &sweep);
  ASSERT_EQ(all.size(), 15u);
  // Vertex 1 against B, vertices 3 and 5 against A; A's edges (0,1) and (1,2) against B's three.
  EXPECT_EQ(near.size(), 9u);
  // Exactly the pairs that the proximity test's first check (the same boxes) lets through,
  // in the same order.
  std::vector<FeaturePair> expected;
  for (const FeaturePair& p : all) {
    std::array<Vec3, 4> s;
    for (int i = 0; i < 4; ++i) s[i] = row3(x, p.point[i]);
    if (boxes_within(s, s, p.edge_edge, gap)) expected.push_back(p);
  }
  ASSERT_EQ(near.size(), expected.size());
  for (size_t k = 0; k < near.size(); ++k) EXPECT_EQ(near[k].point, expected[k].point);
}

TEST(ContactDetection, EachListLooksAsFarAsItsTestNeeds) {
  const TwoTriangles t;
  ContactDetection detection = t.detection();
  Positions v = Positions::Zero(6, 3);
  CollisionStep step;
  step.begin(t.x, v, 0.01);
  CollisionTelemetry frame;
  // 1 mm apart, thickness 2 mm: a proximity triangle pair, expanded once into the feature
  // pairs whose boxes come within the thickness: B's vertex 3 against A, A's edge (1, 2)
  // against B's three edges (B is shifted 0.1 m sideways: A's other features are farther).
  detection.collect(step, ContactFilter(), frame, false);
  EXPECT_EQ(step.proximity_pairs.size(), 4u);
  // At rest, 1 mm apart, CCD looks only within its minimum separation (0.1 mm): no candidate.
  detection.collect(step, ContactFilter(), frame, true);
  EXPECT_TRUE(step.pairs.empty());
  // Moving through each other over the step: CCD candidates.
  v.bottomRows(3).col(2).setConstant(-0.2);
  step.begin(t.x, v, 0.01);
  detection.collect(step, ContactFilter(), frame, true);
  EXPECT_EQ(step.pairs.size(), 4u);  // straight down: the same four come within 0.1 mm
  EXPECT_EQ(frame.broad_phase_pairs, 8);
  // Far apart: nothing.
  Positions far = t.x;
  far.col(2).tail(3).setConstant(1.0);
  step.begin(far, v, 0.01);
  detection.collect(step, ContactFilter(), frame, false);
  EXPECT_TRUE(step.proximity_pairs.empty());
}

TEST(ContactDetection, SharedVerticesAndEdgesAreNotPaired) {
  // Two triangles sharing edge (1, 2): no pair with a shared vertex.
  Faces faces(2, 3);
  faces << 0, 1, 2, 1, 3, 2;
  Positions x(4, 3);
  x << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0;
  const ContactDetection detection(faces, x, {1, 1}, {1, 1}, {0.002, 0.002}, {}, {});
  std::vector<FeaturePair> pairs;
  detection.expand_triangle_pair(0, 1, -1, ContactFilter(), pairs);
  for (const FeaturePair& p : pairs) {
    std::set<int> points(p.point.begin(), p.point.end());
    EXPECT_EQ(points.size(), 4u);
  }
  // Vertex 0 against face 1, vertex 3 against face 0; edges (0,1)x(3,2) and (2,0)x(1,3).
  EXPECT_EQ(std::count_if(pairs.begin(), pairs.end(), [](const FeaturePair& p) { return !p.edge_edge; }), 2);
  EXPECT_EQ(std::count_if(pairs.begin(), pairs.end(), [](const FeaturePair& p) { return p.edge_edge; }), 2);
}

// A 10 x 10 cloth grid (1 cm) parallel to a 7 x 7 body grid (1.5 cm) tilted 45 degrees (so
// that boxes are fat), each cloth vertex `height(i, j)` above it along the normal.
struct ClothOverTiltedGrid {
  static constexpr int n = 10, m = 7;
  Faces cloth_faces = testing::grid_faces(n), body_faces = testing::grid_faces(m);
  Positions x{n * n, 3}, body_x{m * m, 3};
  template <class Height>
  explicit ClothOverTiltedGrid(Height&& height) {
    const Vec3 normal = Vec3(-1.0, 0.0, 1.0).normalized(), along = Vec3(1.0, 0.0, 1.0).normalized();
    for (int i = 0; i < m; ++i)
      for (int j = 0; j < m; ++j) body_x.row(i * m + j) = (0.015 * i * along + Vec3(0.0, 0.015 * j, 0.0)).transpose();
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        x.row(i * n + j) = (0.01 * i * along + Vec3(0.0, 0.01 * j, 0.0) + height(i, j) * normal).transpose();
  }
  int face_count() const { return static_cast<int>(cloth_faces.rows()); }
  // Every cloth face collides, none with itself, margins `gap`.
  ContactDetection detection(double gap) const {
    return ContactDetection(cloth_faces, x, std::vector<char>(face_count(), 1), std::vector<char>(face_count(), 0),
                            std::vector<double>(face_count(), gap), {KinematicBody(body_faces, body_x)}, {1});
  }
};

// A feature pair as a set key: its four points and its kind.
using PairKey = std::array<int, 5>;
PairKey key(const FeaturePair& p) { return {p.point[0], p.point[1], p.point[2], p.point[3], p.edge_edge ? 1 : 0}; }
// The keys of a list, which must hold each pair once.
std::set<PairKey> distinct_keys(const std::vector<FeaturePair>& pairs) {
  std::set<PairKey> keys;
  for (const FeaturePair& p : pairs) keys.insert(key(p));
  EXPECT_EQ(keys.size(), pairs.size());
  return keys;
}

// A cloth grid parallel to a body grid tilted 45 degrees (so that boxes are fat), 1.5 gaps
// above it along the normal, with one corner of each cell pushed down to half a gap: the
// proximity list holds every feature pair within the gap, and the planes keep out most of the
// pairs whose boxes alone would be listed (features of the raised cloth). Measured: 602 listed
// of 1,191 that pass the boxes, 380 within the gap; 853 without the per-feature plane test.
TEST(ContactDetection, TheProximityListHoldsEveryPairWithinTheGapAndFewOthers) {
  const double gap = 0.003;
  const ClothOverTiltedGrid g([&](int i, int j) { return i % 2 == 0 && j % 2 == 0 ? 0.5 * gap : 1.5 * gap; });
  const int n = g.n, face_count = g.face_count();
  const Faces& body_faces = g.body_faces;
  const Positions &x = g.x, &body_x = g.body_x;
  ContactDetection detection = g.detection(gap);
  CollisionStep step;
  Positions v = Positions::Zero(n * n, 3);
  step.begin(x, v, 0.01);
  step.body_start = {body_x};
  step.body_end = {body_x};
  CollisionTelemetry frame;
  detection.collect(step, ContactFilter(), frame, false);
  const std::set<PairKey> listed = distinct_keys(step.proximity_pairs);
  std::set<PairKey> within, boxed;
  // Every triangle pair, expanded in full (distances) and by boxes alone.
  const ContactDetection::Sweep boxes_only{&x, &x, &body_x, &body_x, gap};
  for (int cf = 0; cf < face_count; ++cf)
    for (int bf = 0; bf < body_faces.rows(); ++bf) {
      std::vector<FeaturePair> all, near;
      detection.expand_triangle_pair(cf, bf, 0, ContactFilter(), all);
      detection.expand_triangle_pair(cf, bf, 0, ContactFilter(), near, &boxes_only);
      for (const FeaturePair& p : near) boxed.insert(key(p));
      for (const FeaturePair& p : all) {
        std::array<Vec3, 4> s;
        for (int i = 0; i < 4; ++i) s[i] = p.point[i] >= 0 ? Vec3(row3(x, p.point[i])) : Vec3(row3(body_x, -1 - p.point[i]));
        std::array<double, 4> w;
        if (pair_weights(s, p.edge_edge, w) < gap) within.insert(key(p));
      }
    }
  ASSERT_GT(within.size(), 100u);
  for (const auto& p : within) EXPECT_TRUE(listed.count(p)) << p[0] << " " << p[1] << " " << p[2] << " " << p[3];
  for (const auto& p : listed) EXPECT_TRUE(boxed.count(p));
  EXPECT_LT(listed.size() * 5, boxed.size() * 3) << listed.size() << " of " << boxed.size();
}

// CCD's lists through the planes too, feature by feature: cloth over the tilted body grid,
// between 0 and 4 margins above it, moving toward it by up to 3 margins over the step (some
// points pass through) while the body rises by half a margin. Every feature pair that CCD
// reports within the swept list's gap (in CCD's infinity norm) is listed, and fewer pairs are
// listed than pass the boxes in the world frame (measured: 426 CCD hits; 1,468 listed, 1,599
// without the per-feature plane test; 1,641 pass the world boxes).
TEST(ContactDetection, TheCcdListHoldsEveryPairCcdReportsAndFewOthers) {
  const double margin = 0.004, gap = kCcdSeparationFraction * margin;
  std::mt19937 random(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<double> heights(ClothOverTiltedGrid::n * ClothOverTiltedGrid::n);
  for (double& h : heights) h = 4.0 * margin * unit(random);
  const ClothOverTiltedGrid g([&](int i, int j) { return heights[i * ClothOverTiltedGrid::n + j]; });
  const int face_count = g.face_count();
  const Positions &x = g.x, &body_x = g.body_x;
  const Vec3 normal = Vec3(-1.0, 0.0, 1.0).normalized();
  const double h = 0.01;
  Positions v(x.rows(), 3);
  for (int i = 0; i < x.rows(); ++i)
    v.row(i) = ((-3.0 * margin * unit(random)) * normal + 0.5 * margin * Vec3(unit(random), unit(random), 0.0)).transpose() / h;
  Positions body_end = body_x;
  for (int i = 0; i < body_x.rows(); ++i) body_end.row(i) += 0.5 * margin * normal.transpose();
  ContactDetection detection = g.detection(margin);
  CollisionStep step;
  step.begin(x, v, h);
  step.body_start = {body_x};
  step.body_end = {body_end};
  CollisionTelemetry frame;
  detection.collect(step, ContactFilter(), frame, true);
  const std::set<PairKey> listed = distinct_keys(step.pairs);
  std::set<PairKey> boxed, hits;
  // CCD as the response runs it (a tenth of the separation as its tolerance), at 0.8 of the
  // gap: what it reports is then within 0.88 gaps in its norm, never a near miss it reports
  // only by its tolerance (those the triangle pairs' own plane test may already keep out).
  CcdOptions options;
  options.minimum_separation = 0.8 * gap;
  options.absolute_tolerance = 0.1 * options.minimum_separation;
  const ContactDetection::Sweep boxes_only{&x, &step.x_end, &body_x, &body_end, gap};
  for (int cf = 0; cf < face_count; ++cf)
    for (int bf = 0; bf < g.body_faces.rows(); ++bf) {
      std::vector<FeaturePair> all, near;
      detection.expand_triangle_pair(cf, bf, 0, ContactFilter(), all);
      detection.expand_triangle_pair(cf, bf, 0, ContactFilter(), near, &boxes_only);
      for (const FeaturePair& p : near) boxed.insert(key(p));
      for (const FeaturePair& p : all) {
        std::array<Vec3, 4> s, e;
        for (int i = 0; i < 4; ++i) {
          const int q = p.point[i];
          s[i] = q >= 0 ? Vec3(row3(x, q)) : Vec3(row3(body_x, -1 - q));
          e[i] = q >= 0 ? Vec3(row3(step.x_end, q)) : Vec3(row3(body_end, -1 - q));
        }
        const CcdResult r = p.edge_edge ? edge_edge_ccd(s, e, options) : vertex_triangle_ccd(s, e, options);
        if (r.hit && !r.budget_exhausted) hits.insert(key(p));
      }
    }
  ASSERT_GT(hits.size(), 50u);
  for (const auto& p : hits) EXPECT_TRUE(listed.count(p)) << p[0] << " " << p[1] << " " << p[2] << " " << p[3];
  EXPECT_LT(listed.size(), boxed.size()) << listed.size() << " listed, " << boxed.size() << " boxed, " << hits.size()
                                         << " hits";
}

// No GIA at work: what the collision system's filter says in a clean state.
struct SkipNothing : ContactFilter {
  bool skips_nothing(int) const override { return true; }
};

// Against a body the contact constraints looked at (CollisionStep::sharp_edges) the proximity
// list is found point by point: every cloth vertex/body face and body corner/cloth face pair
// within the gap, as the triangle pairs' expansion lists them, and edge pairs only with the
// body edges that can reach a cloth edge between two vertices kept off: its sharp edges, and
// its blunt ones pushing into the cloth by more than half a separation this step.
TEST(ContactDetection, ProximityPairsPointByPointHaveEdgePairsOnlyWithEdgesThatReach) {
  const double gap = 0.003;
  const ClothOverTiltedGrid g([&](int i, int j) { return (i + j) % 3 == 0 ? 0.4 * gap : 1.6 * gap; });
  const int n = g.n;
  const Positions &x = g.x, &body_x = g.body_x;
  auto collect = [&](const std::vector<SharpEdges>* sharp_edges, const Positions& body_end, int threads) {
    ContactDetection detection = g.detection(gap);
    detection.set_threads(threads);
    CollisionStep step;
    Positions v = Positions::Zero(n * n, 3);
    step.begin(x, v, 0.01);
    step.body_start = {body_x};
    step.body_end = {body_end};
    step.sharp_edges = sharp_edges;
    CollisionTelemetry frame;
    detection.collect(step, SkipNothing(), frame, false);
    return step.proximity_pairs;
  };
  // A smooth body (no sharp edge for these cloth edges, the grid standing in for a closed
  // body's patch) and a sharp one (the grid's border a knife edge for longer cloth edges).
  std::vector<SharpEdges> smooth = {SharpEdges(g.body_faces)}, sharp = smooth;
  ASSERT_EQ(smooth[0].update(g.body_faces, body_x, 0.0015, gap), 0);
  ASSERT_GT(sharp[0].update(g.body_faces, body_x, 0.015, gap), 0);
  const std::vector<FeaturePair> full = collect(nullptr, body_x, 1), by_vertex = collect(&smooth, body_x, 1);
  auto within = [&](const FeaturePair& p) {
    std::array<Vec3, 4> s;
    for (int i = 0; i < 4; ++i) s[i] = p.point[i] >= 0 ? Vec3(row3(x, p.point[i])) : Vec3(row3(body_x, -1 - p.point[i]));
    std::array<double, 4> w;
    return pair_weights(s, p.edge_edge, w) < gap;
  };
  std::set<std::array<int, 4>> listed, wanted;
  for (const FeaturePair& p : by_vertex) {
    EXPECT_FALSE(p.edge_edge);
    EXPECT_EQ(p.body, 0);
    listed.insert(p.point);
  }
  EXPECT_EQ(listed.size(), by_vertex.size()) << "a pair listed twice";
  int body_corners = 0;
  for (const FeaturePair& p : full)
    if (!p.edge_edge && within(p)) {
      wanted.insert(p.point);
      body_corners += p.point[0] < 0;
    }
  ASSERT_GT(wanted.size(), 50u);
  ASSERT_GT(body_corners, 5);
  for (const auto& p : wanted) EXPECT_TRUE(listed.count(p)) << p[0] << " " << p[1] << " " << p[2] << " " << p[3];
  // Few pairs beyond the gap, far fewer than the triangle pairs' expansion lists.
  int beyond = 0;
  for (const FeaturePair& p : by_vertex) beyond += !within(p);
  EXPECT_LT(beyond, static_cast<int>(wanted.size()));
  EXPECT_LT(by_vertex.size() * 2, full.size());
  // The same list, in the same order, on two threads.
  const std::vector<FeaturePair> two_threads = collect(&smooth, body_x, 2);
  ASSERT_EQ(two_threads.size(), by_vertex.size());
  for (size_t k = 0; k < by_vertex.size(); ++k) EXPECT_EQ(two_threads[k].point, by_vertex[k].point);

  // The edge pairs a list adds to the vertex pairs, and those within the gap the expansion has
  // with the body edges `reach` accepts.
  // Edge pairs keyed with each edge's ends in increasing order.
  auto edge_key = [](std::array<int, 4> p) {
    if (p[0] > p[1]) std::swap(p[0], p[1]);
    if (p[2] > p[3]) std::swap(p[2], p[3]);
    return p;
  };
  auto edge_pairs = [&](const std::vector<FeaturePair>& pairs) {
    std::set<std::array<int, 4>> out;
    for (const FeaturePair& p : pairs)
      if (p.edge_edge) out.insert(edge_key(p.point));
      else EXPECT_TRUE(listed.count(p.point));
    EXPECT_EQ(out.size() + listed.size(), pairs.size());
    return out;
  };
  auto wanted_edge_pairs = [&](auto&& reach) {
    std::set<std::array<int, 4>> out;
    for (const FeaturePair& p : full)
      if (p.edge_edge && within(p) && reach(-1 - p.point[2], -1 - p.point[3])) out.insert(edge_key(p.point));
    return out;
  };
  auto on_border = [&](int a, int b) {
    auto border = [&](int k) { return k / g.m == 0 || k / g.m == g.m - 1 || k % g.m == 0 || k % g.m == g.m - 1; };
    return border(a) && border(b) && (a / g.m == b / g.m ? a / g.m == 0 || a / g.m == g.m - 1 : a % g.m == b % g.m && (a % g.m == 0 || a % g.m == g.m - 1));
  };
  const std::set<std::array<int, 4>> with_sharp = edge_pairs(collect(&sharp, body_x, 1));
  const std::set<std::array<int, 4>> border_wanted = wanted_edge_pairs(on_border);
  ASSERT_GT(border_wanted.size(), 5u);
  for (const auto& p : border_wanted) EXPECT_TRUE(with_sharp.count(p)) << p[0] << " " << p[1] << " " << p[2] << " " << p[3];
  for (const auto& p : with_sharp) EXPECT_TRUE(on_border(-1 - p[2], -1 - p[3])) << p[2] << " " << p[3];
  // The body moving along its faces' normal by 0.6 separations this step: every edge pushes
  // and gets its edge pairs (found at the step's start); moving the other way, sideways, or by
  // less than half a separation, none but the sharp ones.
  const Vec3 a = row3(body_x, g.body_faces(0, 0));
  const Vec3 normal = (row3(body_x, g.body_faces(0, 1)) - a).cross(row3(body_x, g.body_faces(0, 2)) - a).normalized();
  auto moved = [&](const Vec3& by) {
    Positions out = body_x;
    out.rowwise() += by.transpose();
    return out;
  };
  const std::vector<FeaturePair> pushed = collect(&smooth, moved(0.6 * gap * normal), 1);
  const std::set<std::array<int, 4>> pushing = edge_pairs(pushed);
  const std::vector<FeaturePair> pushed_two_threads = collect(&smooth, moved(0.6 * gap * normal), 2);
  ASSERT_EQ(pushed_two_threads.size(), pushed.size());
  for (size_t k = 0; k < pushed.size(); ++k) EXPECT_EQ(pushed_two_threads[k].point, pushed[k].point);
  const std::set<std::array<int, 4>> all_wanted = wanted_edge_pairs([](int, int) { return true; });
  ASSERT_GT(all_wanted.size(), border_wanted.size());
  for (const auto& p : all_wanted) EXPECT_TRUE(pushing.count(p)) << p[0] << " " << p[1] << " " << p[2] << " " << p[3];
  EXPECT_TRUE(edge_pairs(collect(&smooth, moved(-0.6 * gap * normal), 1)).empty());
  EXPECT_TRUE(edge_pairs(collect(&smooth, moved(0.4 * gap * normal), 1)).empty());
  EXPECT_TRUE(edge_pairs(collect(&smooth, moved(Vec3(0.0, 5.0 * gap, 0.0)), 1)).empty());
  EXPECT_EQ(edge_pairs(collect(&sharp, moved(-0.6 * gap * normal), 1)), with_sharp);
}

// An n x n grid in the xz plane (spacing 1 cm) folded about x = 5.5 cm so that its far half
// lies 2 mm above the near half: pairs across the fold survive self-culling, those inside
// each flat half are culled.
struct FoldedGrid {
  Faces faces;
  Positions x;
  explicit FoldedGrid(int n) : faces(testing::grid_faces(n)), x(n * n, 3) {
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        const double u = 0.01 * i;
        x.row(i * n + j) << (u <= 0.055 ? u : 0.11 - u), (u <= 0.055 ? 0.0 : 0.002), 0.01 * j;
      }
  }
};

std::set<std::array<int, 6>> examined(const std::vector<FeaturePair>& pairs, const std::vector<char>& changed) {
  std::set<std::array<int, 6>> out;
  for (const FeaturePair& p : pairs)
    if (std::any_of(p.point.begin(), p.point.end(), [&](int q) { return q >= 0 && changed[q]; }))
      out.insert({p.point[0], p.point[1], p.point[2], p.point[3], p.body * 2 + (p.ccd ? 1 : 0), p.edge_edge ? 1 : 0});
  return out;
}

TEST(ContactDetection, ChangedFacesGiveTheIncrementalPassTheFullListsPairs) {
  const FoldedGrid grid(12);
  const int n = static_cast<int>(grid.x.rows());
  // A body: two large triangles 1 mm below the sheet.
  Faces body_faces(2, 3);
  body_faces << 0, 1, 2, 0, 2, 3;
  Positions body_x(4, 3);
  body_x << -0.05, -0.001, -0.05, 0.2, -0.001, -0.05, 0.2, -0.001, 0.2, -0.05, -0.001, 0.2;
  const std::vector<KinematicBody> bodies = {KinematicBody(body_faces, body_x)};
  const int face_count = static_cast<int>(grid.faces.rows());
  for (int threads : {1, 2}) {
    ContactDetection detection(grid.faces, grid.x, std::vector<char>(face_count, 1), std::vector<char>(face_count, 1),
                               std::vector<double>(face_count, 0.003), bodies, {1});
    detection.set_threads(threads);
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    Positions v(n, 3);
    for (int i = 0; i < n; ++i) v.row(i) << 0.1 * unit(rng), 0.2 * unit(rng), 0.1 * unit(rng);
    CollisionStep step;
    step.begin(grid.x, v, 0.01);
    step.body_start = {body_x};
    step.body_end = {body_x};
    CollisionTelemetry frame;
    // Some vertices change velocity (as after a pass's impulses).
    for (int i = 0; i < n; i += 5) {
      v.row(i) *= -2.0;
      step.moved(i);
      step.changed[i] = 1;
    }
    detection.collect(step, ContactFilter(), frame, true);
    const auto full = examined(step.pairs, step.changed);
    ASSERT_GT(full.size(), 50u);
    const size_t full_size = step.pairs.size();
    detection.collect_changed(step, ContactFilter(), frame);
    EXPECT_EQ(examined(step.pairs, step.changed), full);
    EXPECT_LT(step.pairs.size(), full_size);  // fewer pairs than the whole list
    // Each pair once (a vertex-triangle and an edge-edge pair may share their four indices).
    std::set<std::array<int, 6>> unique;
    for (const FeaturePair& p : step.pairs)
      unique.insert({p.point[0], p.point[1], p.point[2], p.point[3], p.body, p.edge_edge ? 1 : 0});
    EXPECT_EQ(unique.size(), step.pairs.size());
  }
}

// A body's boxes, tree and planes are not recomputed when it stands where it stood (the same
// start and end, compared bit for bit), and are whenever it moved, even in the same buffer.
TEST(ContactDetection, ABodyIsRefittedWhenItMovedAndOnlyThen) {
  const int n = 6, m = 4;
  const Faces cloth_faces = testing::grid_faces(n), body_faces = testing::grid_faces(m);
  Positions x(n * n, 3), body_x(m * m, 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) x.row(i * n + j) << 0.02 * i, 0.02 * j, 0.0;
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j) body_x.row(i * m + j) << 0.03 * i, 0.03 * j, -0.001;
  const std::vector<KinematicBody> bodies = {KinematicBody(body_faces, body_x)};
  const int face_count = static_cast<int>(cloth_faces.rows());
  ContactDetection detection(cloth_faces, x, std::vector<char>(face_count, 1), std::vector<char>(face_count, 0),
                             std::vector<double>(face_count, 0.002), bodies, {1});
  detection.refit_cloth(x, x);
  Positions where = body_x;  // one buffer, moved in place
  const auto near = detection.body_pairs(0, where, where);
  ASSERT_FALSE(near.empty());
  EXPECT_EQ(detection.body_pairs(0, where, where), near);  // unchanged: the same pairs
  where.col(2).array() -= 1.0;                              // a metre below the cloth
  EXPECT_TRUE(detection.body_pairs(0, where, where).empty());
  auto sorted = [](std::vector<std::pair<int, int>> pairs) {
    std::sort(pairs.begin(), pairs.end());
    return pairs;
  };
  EXPECT_EQ(sorted(detection.body_pairs(0, where, body_x)), sorted(near));  // swept back up: the end overlaps
  where = body_x;
  EXPECT_EQ(detection.body_pairs(0, where, where), near);
  const Aabb root = detection.bodies()[0].tree.bounds();
  EXPECT_DOUBLE_EQ(root.lo.z(), -0.001);
  EXPECT_DOUBLE_EQ(root.hi.x(), 0.09);
}

// A character of many small parts (each fewer corners than one parallel chunk): the body
// corners and reaching body edges of all parts are listed in one parallel pass, body after
// body, as one pass per body lists them, and the same on one thread as on two.
TEST(ContactDetection, PointPairsOfManySmallBodiesComeBodyAfterBodyOnAnyThreadCount) {
  const double gap = 0.003;
  const ClothOverTiltedGrid g([&](int i, int j) { return (i + j) % 3 == 0 ? 0.4 * gap : 1.6 * gap; });
  const int n = g.n, parts = 12;  // 12 x 49 corners: more than one chunk in all, under one per part
  const Vec3 normal = Vec3(-1.0, 0.0, 1.0).normalized();
  std::vector<Positions> part_x;
  std::vector<KinematicBody> bodies;
  std::vector<SharpEdges> sharp;
  for (int k = 0; k < parts; ++k) {
    Positions p = g.body_x;
    for (int r = 0; r < p.rows(); ++r) p.row(r) -= (0.05 * gap * k) * normal.transpose();
    part_x.push_back(p);
    bodies.emplace_back(g.body_faces, p);
    sharp.emplace_back(g.body_faces);
    sharp.back().update(g.body_faces, p, 0.015, gap);  // the border a knife edge: edge pairs too
  }
  auto collect = [&](const std::vector<int>& which, int threads) {
    std::vector<KinematicBody> some;
    std::vector<SharpEdges> some_sharp;
    std::vector<Positions> some_x;
    for (int k : which) {
      some.push_back(bodies[k]);
      some_sharp.push_back(sharp[k]);
      some_x.push_back(part_x[k]);
    }
    ContactDetection detection(g.cloth_faces, g.x, std::vector<char>(g.face_count(), 1),
                               std::vector<char>(g.face_count(), 0), std::vector<double>(g.face_count(), gap), some,
                               std::vector<char>(some.size(), 1));
    detection.set_threads(threads);
    CollisionStep step;
    Positions v = Positions::Zero(n * n, 3);
    step.begin(g.x, v, 0.01);
    step.body_start = some_x;
    step.body_end = some_x;
    step.sharp_edges = &some_sharp;
    CollisionTelemetry frame;
    detection.collect(step, SkipNothing(), frame, false);
    return step.proximity_pairs;
  };
  std::vector<int> all(parts);
  for (int k = 0; k < parts; ++k) all[k] = k;
  const std::vector<FeaturePair> one = collect(all, 1), two = collect(all, 2);
  ASSERT_EQ(one.size(), two.size());
  for (size_t k = 0; k < one.size(); ++k) {
    EXPECT_EQ(one[k].point, two[k].point);
    EXPECT_EQ(one[k].body, two[k].body);
  }
  // Body corners, then body edges, each body after body and as each body alone lists them.
  std::vector<FeaturePair> corners, edges, alone_corners, alone_edges;
  for (const FeaturePair& p : one) {
    if (p.point[0] < 0) corners.push_back(p);
    if (p.edge_edge) edges.push_back(p);
  }
  for (int k = 0; k < parts; ++k)
    for (FeaturePair p : collect({k}, 1)) {
      p.body = k;
      if (p.point[0] < 0) alone_corners.push_back(p);
      if (p.edge_edge) alone_edges.push_back(p);
    }
  ASSERT_GT(corners.size(), static_cast<size_t>(parts));
  ASSERT_GT(edges.size(), static_cast<size_t>(parts));
  ASSERT_EQ(corners.size(), alone_corners.size());
  ASSERT_EQ(edges.size(), alone_edges.size());
  for (size_t k = 0; k < corners.size(); ++k) {
    EXPECT_EQ(corners[k].point, alone_corners[k].point);
    EXPECT_EQ(corners[k].body, alone_corners[k].body);
  }
  for (size_t k = 0; k < edges.size(); ++k) {
    EXPECT_EQ(edges[k].point, alone_edges[k].point);
    EXPECT_EQ(edges[k].body, alone_edges[k].body);
  }
}

}  // namespace
}  // namespace weft
