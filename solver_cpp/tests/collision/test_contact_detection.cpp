// Contact detection: one triangle pair expands into its vertex-triangle and edge-edge pairs
// exactly once; the filter's membrane and pinch rules drop or mark them.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "weft/collision/contact_detection.h"

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

TEST(ContactDetection, EachListLooksAsFarAsItsTestNeeds) {
  const TwoTriangles t;
  ContactDetection detection = t.detection();
  Positions v = Positions::Zero(6, 3);
  CollisionStep step;
  step.begin(t.x, v, 0.01);
  CollisionTelemetry frame;
  // 1 mm apart, thickness 2 mm: a proximity pair, expanded once.
  detection.collect(step, ContactFilter(), frame, false);
  EXPECT_EQ(step.proximity_pairs.size(), 15u);
  // At rest, 1 mm apart, CCD looks only within its minimum separation (0.1 mm): no candidate.
  detection.collect(step, ContactFilter(), frame, true);
  EXPECT_TRUE(step.pairs.empty());
  // Moving through each other over the step: CCD candidates.
  v.bottomRows(3).col(2).setConstant(-0.2);
  step.begin(t.x, v, 0.01);
  detection.collect(step, ContactFilter(), frame, true);
  EXPECT_EQ(step.pairs.size(), 15u);
  EXPECT_EQ(frame.broad_phase_pairs, 30);
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

}  // namespace
}  // namespace weft
