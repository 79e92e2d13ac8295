// Sweep frames (sweep_frame.h): the CCD broad phase sweeps a body's boxes, and the cloth's
// against it, in the frame that moves with the body and the cloth it carries; the lists still
// hold every pair that comes within CCD's gap, and a garment carried along lists about what it
// lists standing still.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>
#include <set>

#include "support/grid_faces.h"
#include "weft/collision/contact_detection.h"
#include "weft/collision/contact_impulse.h"
#include "weft/collision/sweep_frame.h"

namespace weft {
namespace {

Positions grid(int n, double spacing, const Vec3& origin) {
  Positions x(n * n, 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) x.row(i * n + j) = (origin + Vec3(spacing * i, spacing * j, 0.0)).transpose();
  return x;
}

TEST(SweepFrame, TheShiftIsTheMotionMostPointsShare) {
  SweepFrame frame;
  const Positions body = grid(4, 0.1, Vec3::Zero());
  const Positions cloth = grid(6, 0.05, Vec3(0.0, 0.0, 0.01));
  Aabb reach;
  for (int v = 0; v < body.rows(); ++v) reach.expand(row3(body, v));
  reach.inflate(0.02);
  // A body carrying its cloth: the carry.
  const Vec3 carry(0.03, -0.01, 0.002);
  const Positions body_end = body.rowwise() + carry.transpose();
  const Positions cloth_end = cloth.rowwise() + carry.transpose();
  const Vec3 carried = frame.shift(body, body_end, reach, cloth, cloth_end, 1e-4);
  EXPECT_LT((carried - carry).norm(), 1e-12);
  // Standing still with its cloth at rest: the world.
  EXPECT_EQ(frame.shift(body, body, reach, cloth, cloth, 1e-4), Vec3::Zero());
  // A still body (16 vertices) under 36 falling cloth vertices: the median follows the many.
  const Positions falling = cloth.rowwise() + Vec3(0.0, 0.0, -0.005).transpose();
  EXPECT_NEAR(frame.shift(body, body, reach, cloth, falling, 1e-4).z(), -0.005, 1e-12);
  // Cloth out of reach does not count: the still body alone.
  const Positions far = cloth.rowwise() + Vec3(0.0, 0.0, 5.0).transpose();
  const Positions far_falling = far.rowwise() + Vec3(0.0, 0.0, -0.005).transpose();
  EXPECT_EQ(frame.shift(body, body, reach, far, far_falling, 1e-4), Vec3::Zero());
  // Below `least`: the world.
  EXPECT_EQ(frame.shift(body, body, reach, cloth, falling, 0.006), Vec3::Zero());
  // Non-finite motion takes no part (a NaN shift would drop every pair): the body's broken x
  // displacements leave the cloth's carry; nothing finite at all leaves the world.
  Positions broken = body_end;
  broken.col(0).setConstant(std::numeric_limits<double>::quiet_NaN());
  EXPECT_LT((frame.shift(body, broken, reach, cloth, cloth_end, 1e-4) - carry).norm(), 1e-12);
  Positions broken_cloth = cloth_end;
  broken_cloth.col(0).setConstant(std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(frame.shift(body, broken, reach, cloth, broken_cloth, 1e-4), Vec3::Zero());
  // The cloth's own shift: every vertex.
  EXPECT_NEAR(frame.shift(cloth, falling, 1e-4).z(), -0.005, 1e-12);
}

// A 10 x 10 cloth grid (1 cm) 1-3 mm over an 8 x 8 body grid (1.5 cm), both carried along by
// `carry` over a 10 ms step, the cloth also moving with small random velocities of its own
// (many of its vertices pass through the body). Self-collision on, thickness 3 mm.
struct CarriedSheet {
  static constexpr int n = 10, m = 8;
  static constexpr double thickness = 0.003, h = 0.01;
  Faces cloth_faces = testing::grid_faces(n), body_faces = testing::grid_faces(m);
  Positions x, v, body_x, body_end;
  explicit CarriedSheet(const Vec3& carry) {
    body_x = grid(m, 0.015, Vec3(-0.01, -0.01, 0.0));
    x = grid(n, 0.01, Vec3::Zero());
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    v.resize(n * n, 3);
    for (int i = 0; i < n * n; ++i) {
      x(i, 2) = 0.001 + 0.002 * unit(rng);
      v.row(i) = (carry + Vec3(0.1 * unit(rng) - 0.05, 0.1 * unit(rng) - 0.05, -0.3 + 0.4 * unit(rng))).transpose();
    }
    body_end = body_x.rowwise() + (h * carry).transpose();
  }
  int face_count() const { return static_cast<int>(cloth_faces.rows()); }
  ContactDetection detection() const {
    return ContactDetection(cloth_faces, x, std::vector<char>(face_count(), 1), std::vector<char>(face_count(), 1),
                            std::vector<double>(face_count(), thickness), {KinematicBody(body_faces, body_x)}, {1});
  }
  // The swept CCD list of the step.
  std::vector<FeaturePair> ccd_list(ContactDetection& detection, CollisionStep& step) {
    step.begin(x, v, h);
    step.body_start = {body_x};
    step.body_end = {body_end};
    CollisionTelemetry frame;
    detection.collect(step, ContactFilter(), frame, true);
    return step.pairs;
  }
};

using Key = std::array<int, 6>;
Key key(const FeaturePair& p) { return {p.point[0], p.point[1], p.point[2], p.point[3], p.body, p.edge_edge ? 1 : 0}; }

TEST(SweepFrame, ACarriedSheetListsEveryPairThatComesWithinTheGapAndAboutWhatItListsAtRest) {
  const Vec3 carry(2.0, 0.8, 0.0);  // 2 cm and 8 mm over the step: about 150 CCD gaps
  CarriedSheet carried(carry);
  ContactDetection detection = carried.detection();
  CollisionStep step;
  const std::vector<FeaturePair> listed_pairs = carried.ccd_list(detection, step);
  EXPECT_LT((detection.body_shift(0) - CarriedSheet::h * carry).norm(), 1e-3);
  std::set<Key> listed;
  for (const FeaturePair& p : listed_pairs) listed.insert(key(p));

  // Every feature pair, cloth/body and cloth/cloth, whose points come within the gap at one of
  // 33 instants of the step (moving linearly) is listed.
  const double gap = kCcdSeparationFraction * CarriedSheet::thickness;
  auto point_at = [&](int p, int body, double t) {
    const Vec3 start = step.start_of(p, body), end = step.end_of(p, body);
    return Vec3(start + t * (end - start));
  };
  auto comes_within = [&](const FeaturePair& p) {
    for (int k = 0; k <= 32; ++k) {
      const double t = k / 32.0;
      std::array<Vec3, 4> s;
      for (int i = 0; i < 4; ++i) s[i] = point_at(p.point[i], p.body, t);
      std::array<double, 4> w;
      if (pair_weights(s, p.edge_edge, w) < gap) return true;
    }
    return false;
  };
  int close = 0;
  const int face_count = carried.face_count();
  for (int a = 0; a < face_count; ++a) {
    std::vector<FeaturePair> all;
    for (int bf = 0; bf < carried.body_faces.rows(); ++bf) detection.expand_triangle_pair(a, bf, 0, ContactFilter(), all);
    for (int b = a + 1; b < face_count; ++b) detection.expand_triangle_pair(a, b, -1, ContactFilter(), all);
    for (const FeaturePair& p : all)
      if (comes_within(p)) {
        ++close;
        EXPECT_TRUE(listed.count(key(p))) << p.point[0] << " " << p.point[1] << " " << p.point[2] << " " << p.point[3];
      }
  }
  ASSERT_GT(close, 100);

  // The same sheet not carried (the same motion relative to the body) lists about as many: a
  // world-frame sweep of 2 cm over a 1 cm grid would list many times more.
  CarriedSheet still(Vec3::Zero());
  ContactDetection still_detection = still.detection();
  CollisionStep still_step;
  const size_t at_rest = still.ccd_list(still_detection, still_step).size();
  EXPECT_EQ(still_detection.body_shift(0), Vec3::Zero());
  EXPECT_LT(listed_pairs.size(), at_rest * 3 / 2) << listed_pairs.size() << " carried, " << at_rest << " at rest";

  // An incremental pass (some velocities changed) examines the full list's pairs with a changed
  // point, in the same frames.
  for (int i = 0; i < carried.n * carried.n; i += 7) {
    carried.v.row(i) *= 0.5;
    step.moved(i);
    step.changed[i] = 1;
  }
  CollisionTelemetry frame;
  detection.collect(step, ContactFilter(), frame, true);
  auto examined = [&](const std::vector<FeaturePair>& pairs) {
    std::set<Key> out;
    for (const FeaturePair& p : pairs)
      if (std::any_of(p.point.begin(), p.point.end(), [&](int q) { return q >= 0 && step.changed[q]; }))
        out.insert(key(p));
    return out;
  };
  const std::set<Key> full = examined(step.pairs);
  ASSERT_GT(full.size(), 20u);
  detection.collect_changed(step, ContactFilter(), frame);
  EXPECT_EQ(examined(step.pairs), full);
}

}  // namespace
}  // namespace weft
