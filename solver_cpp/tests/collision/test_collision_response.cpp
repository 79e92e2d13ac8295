// Proximity, CCD and impact-zone response on a single vertex/triangle pair.
#include <gtest/gtest.h>

#include "weft/collision/ccd_response.h"
#include "weft/collision/contact_impulse.h"
#include "weft/collision/impact_zones.h"
#include "weft/collision/proximity_response.h"

namespace weft {
namespace {

constexpr double kThickness = 0.01;

// Vertex 0 above triangle (1, 2, 3) in the plane z = 0; the triangle's vertices pinned (infinite
// mass) unless `free_triangle`.
struct VertexOverTriangle {
  Positions x{4, 3};
  Positions v = Positions::Zero(4, 3);
  ContactProperties props;
  CollisionStep step;
  explicit VertexOverTriangle(double height, bool free_triangle = false) {
    x << 0.2, 0.2, height, 0, 0, 0, 1, 0, 0, 0, 1, 0;
    props.inverse_mass = {1.0, free_triangle ? 1.0 : 0.0, free_triangle ? 1.0 : 0.0, free_triangle ? 1.0 : 0.0};
    props.thickness.assign(4, kThickness);
    props.friction.assign(4, 0.5);
    props.default_thickness = kThickness;
  }
  void begin(double h) {
    step.begin(x, v, h);
    step.pairs = {FeaturePair{{0, 1, 2, 3}, -1, false}};
    step.proximity_pairs = step.pairs;
  }
};

TEST(ProximityResponse, PushesARestingVertexTowardsTheThicknessWithFriction) {
  VertexOverTriangle t(0.2 * kThickness);
  t.v.row(0) << 1.0, 0.0, 0.0;  // sliding along the triangle
  const double h = 0.01;
  t.begin(h);
  CollisionTelemetry frame;
  EXPECT_EQ(ProximityResponse().apply(t.step, t.props, frame), 1);
  // Normal speed: kRepulsionRate of the missing separation per step.
  EXPECT_NEAR(t.v(0, 2), kRepulsionRate * 0.8 * kThickness / h, 1e-12);
  // Coulomb friction: tangential speed reduced by mu times the normal impulse.
  EXPECT_NEAR(t.v(0, 0), 1.0 - 0.5 * t.v(0, 2), 1e-12);
  EXPECT_DOUBLE_EQ(t.step.x_end(0, 2), t.x(0, 2) + h * t.v(0, 2));
  EXPECT_EQ(t.v.bottomRows(3).norm(), 0.0);  // the pinned triangle did not move
  // Already leaving fast enough: untouched.
  EXPECT_EQ(ProximityResponse().apply(t.step, t.props, frame), 0);
}

TEST(ProximityResponse, ATouchingPairKeepsTheNormalItsFirstSweepChose) {
  // A vertex in the triangle's plane (no distance to take a direction from) sliding into it:
  // the normal is oriented against its approach once; later sweeps do not flip it back and
  // forth (each flip a push of twice the target, with friction).
  VertexOverTriangle t(0.0);
  t.v.row(0) << 1.0, 0.0, -1.0;
  const double h = 0.01;
  t.begin(h);
  CollisionTelemetry frame;
  EXPECT_EQ(ProximityResponse().apply(t.step, t.props, frame), 1);
  const double target = kRepulsionRate * kThickness / h;
  EXPECT_NEAR(t.v(0, 2), target, 1e-12);
  EXPECT_NEAR(t.v(0, 0), 1.0 - 0.5 * (target + 1.0), 1e-12);  // one push's friction
}

TEST(ProximityResponse, SweepsBringStackedLayersToTheirTargets) {
  // Three layers 0.4 thickness apart: a large pinned triangle (0-2) at z = 0, a free triangle
  // (3-5) above it, a free vertex 6 above that falling onto the stack. A sweep in list order
  // pushes the middle layer down on the vertex's pair, then back up on its pairs with the
  // pinned triangle, into the vertex again: each further sweep leaves less of that.
  const double z = 0.4 * kThickness, h = 0.01;
  Positions x(7, 3);
  x << -1, -1, 0, 3, -1, 0, -1, 3, 0,  // pinned
      0, 0, z, 1, 0, z, 0, 1, z,       // free
      0.2, 0.2, 2.0 * z;
  ContactProperties props;
  props.inverse_mass = {0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0};
  props.thickness.assign(7, kThickness);
  props.friction.assign(7, 0.0);
  props.default_thickness = kThickness;
  const std::vector<FeaturePair> pairs = {FeaturePair{{6, 3, 4, 5}, -1, false}, FeaturePair{{3, 0, 1, 2}, -1, false},
                                          FeaturePair{{4, 0, 1, 2}, -1, false}, FeaturePair{{5, 0, 1, 2}, -1, false}};
  // The largest shortfall of a pair's normal velocity below its repulsion target after `sweeps`.
  auto shortfall_after = [&](int sweeps) {
    Positions v = Positions::Zero(7, 3);
    v.row(6) << 0.0, 0.0, -2.0;
    CollisionStep step;
    step.begin(x, v, h);
    step.proximity_pairs = pairs;
    CollisionTelemetry frame;
    EXPECT_EQ(ProximityResponse(sweeps).apply(step, props, frame), 4);
    double worst = 0.0;
    for (const FeaturePair& pair : pairs) {
      std::array<Vec3, 4> s;
      std::array<double, 4> w;
      for (int i = 0; i < 4; ++i) s[i] = row3(x, pair.point[i]);
      const double d = pair_weights(s, false, w);
      Vec3 v_rel = Vec3::Zero();
      for (int i = 0; i < 4; ++i) v_rel += w[i] * row3(v, pair.point[i]);
      worst = std::max(worst, kRepulsionRate * (kThickness - d) / h - (combine(s, w) / d).dot(v_rel));
    }
    return worst;
  };
  const double one = shortfall_after(1), default_sweeps = shortfall_after(kProximitySweeps);
  EXPECT_GT(one, 0.5 * kRepulsionRate * kThickness / h);  // one sweep: the vertex still falls
  EXPECT_LT(default_sweeps, 0.5 * one);
  EXPECT_LT(shortfall_after(200), 1e-9);  // converged: every pair at its target
}

TEST(CcdResponse, StopsAVertexFallingThroughATriangle) {
  VertexOverTriangle t(0.5);
  t.v.row(0) << 0.0, 0.0, -100.0;  // through the triangle within the step
  t.begin(0.01);
  CollisionTelemetry frame;
  const CcdResponse ccd(1);
  std::vector<int> hits;
  EXPECT_EQ(ccd.pass(t.step, t.props, false, &hits, false, frame), 1);
  EXPECT_EQ(hits, std::vector<int>{0});
  EXPECT_EQ(t.v(0, 2), -100.0);  // detection only
  EXPECT_EQ(ccd.pass(t.step, t.props, true, nullptr, false, frame), 1);
  EXPECT_GT(t.step.x_end(0, 2), 0.0);  // ends above the triangle
  EXPECT_EQ(ccd.pass(t.step, t.props, false, nullptr, false, frame), 0);
}

// Detection only (the impact zones' re-detection): a pair that starts within CCD's minimum
// separation is a hit when it crosses within the step and not when it only stays close (a
// squeezed pair that a zone's motion keeps as close as it was). Passes with impulses still
// push it apart.
// Detection only (what a zone's motion leaves colliding), a pair that comes within the minimum
// separation during the step without crossing is no collision either; with impulses it is.
TEST(CcdResponse, DetectionOnlyReportsAnApproachingPairOnlyWhenItCrosses) {
  const double separation = kCcdSeparationFraction * kThickness;
  const double h = 0.01;
  CollisionTelemetry frame;
  const CcdResponse ccd(1);
  VertexOverTriangle t(2.0 * separation, true);  // beyond the separation at the start
  t.v(0, 2) = -1.5 * separation / h;             // ends at half of it, above the triangle
  t.begin(h);
  std::vector<int> hits;
  EXPECT_EQ(ccd.pass(t.step, t.props, false, &hits, false, frame), 0);
  EXPECT_TRUE(hits.empty());
  t.v(0, 2) = -3.0 * separation / h;  // through the triangle
  t.begin(h);
  EXPECT_EQ(ccd.pass(t.step, t.props, false, &hits, false, frame), 1);
  t.v(0, 2) = -1.5 * separation / h;
  t.begin(h);
  EXPECT_EQ(ccd.pass(t.step, t.props, true, nullptr, false, frame), 1);
  EXPECT_GE(t.v(0, 2), t.v(1, 2));  // pushed apart
}

TEST(CcdResponse, DetectionOnlyReportsAPairWithinTheSeparationOnlyWhenItCrosses) {
  const double start = 0.5 * kCcdSeparationFraction * kThickness;  // within the separation
  const double h = 0.01;
  CollisionTelemetry frame;
  const CcdResponse ccd(1);
  auto detected = [&](double vertex_speed, double triangle_speed) {
    VertexOverTriangle t(start, true);
    t.v.col(2) << vertex_speed, triangle_speed, triangle_speed, triangle_speed;
    t.begin(h);
    std::vector<int> hits;
    ccd.pass(t.step, t.props, false, &hits, false, frame);
    return hits.size();
  };
  EXPECT_EQ(detected(0.0, 0.0), 0u);                  // at rest
  EXPECT_EQ(detected(-1.0, -1.0), 0u);                // carried together
  EXPECT_EQ(detected(-0.4 * start / h, 0.0), 0u);     // closer, never crossing
  EXPECT_EQ(detected(-2.0 * start / h, 0.0), 1u);     // through the triangle within the step
  EXPECT_EQ(detected(0.0, 2.0 * start / h), 1u);      // the triangle rising through the vertex
  // With impulses the approaching close pair is pushed apart: its relative normal velocity
  // becomes positive.
  VertexOverTriangle t(start, true);
  t.v(0, 2) = -0.4 * start / h;
  t.begin(h);
  EXPECT_EQ(ccd.pass(t.step, t.props, true, nullptr, false, frame), 1);
  EXPECT_GT(t.v(0, 2), t.v(1, 2));
}

TEST(ImpactZones, MakeAConvergingPairCollisionFree) {
  VertexOverTriangle t(0.5, true);
  t.v.row(0) << 0.0, 0.0, -100.0;
  t.v.bottomRows(3).col(2).setConstant(20.0);  // the triangle rises to meet it
  t.begin(0.01);
  CollisionTelemetry frame;
  const CcdResponse ccd(1);
  std::vector<int> hits;
  ccd.pass(t.step, t.props, false, &hits, false, frame);
  ASSERT_EQ(hits.size(), 1u);
  const Vec3 momentum = t.v.colwise().sum().transpose();
  int redetections = 0;
  const int zones = ImpactZones().resolve(
      t.step, t.props, hits, 10,
      [&](std::vector<int>& found) {
        ++redetections;
        ccd.pass(t.step, t.props, false, &found, false, frame);
      },
      frame);
  EXPECT_EQ(zones, 1);
  EXPECT_EQ(redetections, 1);
  EXPECT_TRUE(hits.empty());
  EXPECT_EQ(frame.unresolved, 0);
  // One rigid zone: a common velocity keeping the momentum (equal masses).
  for (int i = 1; i < 4; ++i) EXPECT_EQ(t.v.row(i), t.v.row(0));
  EXPECT_NEAR((t.v.colwise().sum().transpose() - momentum).norm(), 0.0, 1e-12);
}

TEST(ImpactZones, AZoneTouchingAPinnedVertexMovesWithIt) {
  VertexOverTriangle t(0.5);  // pinned triangle at rest
  t.v.row(0) << 0.0, 0.0, -100.0;
  t.begin(0.01);
  CollisionTelemetry frame;
  std::vector<int> hits = {0};
  ImpactZones().resolve(t.step, t.props, hits, 10, [](std::vector<int>&) {}, frame);
  EXPECT_EQ(t.v.row(0).norm(), 0.0);
}

// Cloth points along x at y = z = 0.1 between a still body face in the plane x = 0 and a body
// edge at x = 5 mm moving at 1 m/s along z; pairs 0 (point 0 against the face) and 1 (edge
// 0-1 against the moving edge) are colliding, and `extra` too.
struct ZoneBetweenTwoBodies {
  static constexpr double h = 0.01;
  Positions x, v;
  ContactProperties props;
  CollisionStep step;
  CollisionTelemetry frame;
  ZoneBetweenTwoBodies(const std::vector<double>& along_x, const std::vector<FeaturePair>& extra = {}) {
    const auto n = static_cast<Eigen::Index>(along_x.size());
    x = Positions(n, 3);
    v = Positions::Zero(n, 3);
    for (Eigen::Index i = 0; i < n; ++i) x.row(i) << along_x[static_cast<size_t>(i)], 0.1, 0.1;
    Positions still(3, 3), moving(2, 3);
    still << 0.0, 0.0, 0.0, 0.0, 0.2, 0.0, 0.0, 0.0, 0.2;
    moving << 0.005, 0.1, 0.0, 0.005, 0.1, 0.2;
    props.inverse_mass.assign(along_x.size(), 1.0);
    props.thickness.assign(along_x.size(), kThickness);
    props.friction.assign(along_x.size(), 0.0);
    step.begin(x, v, h);
    step.body_start = {still, moving};
    step.body_end = {still, moving};
    step.body_end[1].col(2).array() += 1.0 * h;
    step.pairs = {FeaturePair{{0, -1, -2, -3}, 0, false}, FeaturePair{{0, 1, -1, -2}, 1, true}};
    step.pairs.insert(step.pairs.end(), extra.begin(), extra.end());
  }
  int resolve() {
    std::vector<int> hits(step.pairs.size());
    for (size_t k = 0; k < hits.size(); ++k) hits[k] = static_cast<int>(k);
    return ImpactZones().resolve(step, props, hits, 1, [](std::vector<int>&) {}, frame);
  }
};

// A zone caught between two bodies a few millimetres apart, one still, one moving (a strap
// between the torso and a closing arm), with a cloth vertex 3 cm beyond them: the affine field
// fitted to the body points is not extrapolated past their own velocities (it would move the far
// vertex at 6 m/s and tear its edges).
TEST(ImpactZones, AZoneBetweenTwoBodiesMovesNoFasterThanTheirPoints) {
  ZoneBetweenTwoBodies t({0.002, 0.03});  // cloth edge 0-1 running off along x
  EXPECT_EQ(t.resolve(), 1);
  // References: three still points and two at 1 m/s; their mean 0.4 m/s, widest spread 0.6.
  const Vec3 mean(0.0, 0.0, 0.4);
  for (int i = 0; i < 2; ++i) EXPECT_LE((row3(t.v, i) - mean).norm(), 0.6 + 1e-12) << "vertex " << i;
  // Between the bodies the field is the fit's own: the vertex 2 mm off the still face moves slower
  // than the one beyond the moving edge.
  EXPECT_LT(t.v(0, 2), t.v(1, 2));
  EXPECT_GT(t.v(1, 2), 0.9);
}

// A zone's velocity field stays affine when it is bounded: four points of a zone caught between
// the two bodies, spread 3 cm beyond them, all get velocities on one affine field (so no two of
// them can move through each other), none faster than the references' spread about their mean,
// and h |G| <= 1/2.
TEST(ImpactZones, ABoundedZoneFieldStaysAffine) {
  ZoneBetweenTwoBodies t({0.002, 0.01, 0.02, 0.03}, {FeaturePair{{2, 0, 1, 3}, -1, false}});
  EXPECT_EQ(t.resolve(), 1);
  const Vec3 mean(0.0, 0.0, 0.4);
  for (int i = 0; i < 4; ++i) EXPECT_LE((row3(t.v, i) - mean).norm(), 0.6 + 1e-12) << "vertex " << i;
  // Collinear points: equal velocity differences per metre along the line.
  const Vec3 slope = (row3(t.v, 1) - row3(t.v, 0)) / (t.x(1, 0) - t.x(0, 0));
  for (int i = 2; i < 4; ++i)
    EXPECT_LT((row3(t.v, i) - row3(t.v, 0) - slope * (t.x(i, 0) - t.x(0, 0))).norm(), 1e-12) << "vertex " << i;
  EXPECT_LE(ZoneBetweenTwoBodies::h * slope.norm(), 0.5 + 1e-12);
  EXPECT_LT(t.v(0, 2), t.v(3, 2));  // the field rises from the still body towards the moving one
}

// A zone caught between two bodies moving apart (cloth between scissoring legs): two cloth points
// between a face moving -x and one moving +x at 1 m/s, 2 cm apart. The references' fit stretches
// along x at 100/s, h |G| = 1; halved to h |G| = 1/2 it would still stretch the cloth between
// them by half in one step. The step's map stretches no direction by more than
// ImpactZones::kMaxZoneStretch: the edge between the two points neither, and the field still
// pulls them apart.
TEST(ImpactZones, AZoneFieldStretchesItsClothByATenthAtMost) {
  constexpr double h = 0.01;
  Positions x(2, 3), v = Positions::Zero(2, 3);
  x << 0.005, 0.1, 0.1, 0.015, 0.1, 0.1;
  Positions left(3, 3), right(3, 3);
  left << 0.0, 0.0, 0.0, 0.0, 0.2, 0.0, 0.0, 0.0, 0.2;
  right = left;
  right.col(0).array() += 0.02;
  ContactProperties props;
  props.inverse_mass.assign(2, 1.0);
  props.thickness.assign(2, kThickness);
  props.friction.assign(2, 0.0);
  CollisionStep step;
  step.begin(x, v, h);
  step.body_start = {left, right};
  step.body_end = {left, right};
  step.body_end[0].col(0).array() -= 1.0 * h;
  step.body_end[1].col(0).array() += 1.0 * h;
  step.pairs = {FeaturePair{{0, -1, -2, -3}, 0, false}, FeaturePair{{1, -1, -2, -3}, 1, false},
                FeaturePair{{0, 1, -1, -2}, 1, true}};
  std::vector<int> hits = {0, 1, 2};
  CollisionTelemetry frame;
  EXPECT_EQ(ImpactZones().resolve(step, props, hits, 1, [](std::vector<int>&) {}, frame), 1);
  const double before = (row3(x, 1) - row3(x, 0)).norm();
  const double after = (row3(x, 1) + h * row3(v, 1) - row3(x, 0) - h * row3(v, 0)).norm();
  EXPECT_LE(after, (1.0 + ImpactZones::kMaxZoneStretch) * before * (1.0 + 1e-9));
  EXPECT_GT(after, 1.05 * before);
}

// A zone that no motion frees (the re-detection finds the same pair every pass, as between two
// bodies moving apart) stops after ImpactZones::kStallPasses passes, not the whole budget, and
// its pair counts as unresolved.
TEST(ImpactZones, StopsWhenPassesFindNoFewerCollisions) {
  VertexOverTriangle t(0.5, true);
  t.v.row(0) << 0.0, 0.0, -100.0;
  t.begin(0.01);
  CollisionTelemetry frame;
  std::vector<int> hits = {0};
  int redetections = 0;
  ImpactZones().resolve(
      t.step, t.props, hits, 100,
      [&](std::vector<int>& found) {
        ++redetections;
        found = {0};
      },
      frame);
  EXPECT_EQ(redetections, ImpactZones::kStallPasses);
  EXPECT_EQ(frame.unresolved, 1);
  // Passes that keep finding fewer pairs run on (up to the budget).
  std::vector<int> many = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
  redetections = 0;
  ImpactZones().resolve(
      t.step, t.props, many, 100,
      [&](std::vector<int>& found) {
        ++redetections;
        found.assign(19 - std::min(redetections, 19), 0);
      },
      frame);
  EXPECT_EQ(redetections, 19);
  EXPECT_TRUE(many.empty());
}

// Only points whose velocity a pass changed, or that were in a colliding pair, are marked for
// re-detection: a zone whose velocity stays the same is not queried again.
TEST(ImpactZones, MarksOnlyChangedVelocitiesAndCollidingPoints) {
  // Two free vertex-over-triangle quads far apart: points 0-3 and 4-7.
  Positions x(8, 3), v = Positions::Zero(8, 3);
  x << 0.2, 0.2, 0.5, 0, 0, 0, 1, 0, 0, 0, 1, 0, 5.2, 0.2, 0.5, 5, 0, 0, 6, 0, 0, 5, 1, 0;
  v(0, 2) = -100.0;
  v(4, 2) = -100.0;
  ContactProperties props;
  props.inverse_mass.assign(8, 1.0);
  props.thickness.assign(8, kThickness);
  props.friction.assign(8, 0.5);
  CollisionStep step;
  step.begin(x, v, 0.01);
  step.pairs = {FeaturePair{{0, 1, 2, 3}, -1, false}, FeaturePair{{4, 5, 6, 7}, -1, false}};
  std::vector<int> hits = {0};
  std::vector<std::vector<char>> marked;
  CollisionTelemetry frame;
  ImpactZones().resolve(
      step, props, hits, 3,
      [&](std::vector<int>& found) {
        marked.push_back(step.changed);
        std::fill(step.changed.begin(), step.changed.end(), 0);  // as a CCD pass resets it
        found = marked.size() == 1 ? std::vector<int>{1} : std::vector<int>{};
      },
      frame);
  ASSERT_EQ(marked.size(), 2u);
  EXPECT_EQ(marked[0], std::vector<char>({1, 1, 1, 1, 0, 0, 0, 0}));
  // Second pass: the first zone keeps its common velocity (not marked); the new one is marked.
  EXPECT_EQ(marked[1], std::vector<char>({0, 0, 0, 0, 1, 1, 1, 1}));
  for (int i = 0; i < 8; ++i) EXPECT_EQ(v(i, 2), -25.0) << "point " << i;
}

}  // namespace
}  // namespace weft
