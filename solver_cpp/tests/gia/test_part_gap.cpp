// Pinches between parts of one character (part_gap.h, body_pinch.h): two parts whose surfaces,
// each outside the other, face each other closer than the gap make a region; overlapping parts
// (a joint), a wide crease and parts farther apart do not. Such a pair engages the collision
// stage (CCD off for the cloth there against the smaller part) only while cloth is in its region.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "weft/gia/body_pinch.h"
#include "weft/gia/part_gap.h"
#include "weft/gia/pinch_driver.h"

namespace weft {
namespace {

// Closed box [lo, hi], outward faces; `inward` winds every face the other way.
struct Box {
  Positions x{8, 3};
  Faces f{12, 3};
  Box(const Vec3& lo, const Vec3& hi, bool inward = false) {
    for (int i = 0; i < 8; ++i)
      x.row(i) << ((i & 1) ? hi.x() : lo.x()), ((i & 2) ? hi.y() : lo.y()), ((i & 4) ? hi.z() : lo.z());
    f << 0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5;
    if (inward) f.col(1).swap(f.col(2));
  }
};

Aabb region(const Box& a, const Box& b, double gap) {
  PartSurface sa, sb;
  sa.fit(a.x, a.f, 0.5 * gap);
  sb.fit(b.x, b.f, 0.5 * gap);
  return facing_gap_region(sa, a.x, a.f, sb, b.x, b.f, gap);
}

bool empty(const Aabb& box) { return !(box.lo.array() <= box.hi.array()).all(); }

TEST(PartGap, FacingSurfacesCloserThanTheGapMakeTheRegionBetweenThem) {
  const Box a(Vec3(0, 0, 0), Vec3(1, 1, 1));
  const Box b(Vec3(1.004, 0.2, 0.3), Vec3(2, 0.8, 0.6));  // 4 mm beside a's +x face
  const Aabb r = region(a, b, 0.006);
  ASSERT_FALSE(empty(r));
  // Between the two faces, over the smaller face's extent.
  EXPECT_NEAR(r.lo.x(), 1.0, 1e-12);
  EXPECT_NEAR(r.hi.x(), 1.004, 1e-12);
  EXPECT_NEAR(r.lo.y(), 0.2, 1e-12);
  EXPECT_NEAR(r.hi.y(), 0.8, 1e-12);
  EXPECT_NEAR(r.lo.z(), 0.3, 1e-12);
  EXPECT_NEAR(r.hi.z(), 0.6, 1e-12);
  // Wound inward, the closed parts are read outward all the same.
  EXPECT_TRUE(empty(region(a, b, 0.003)));  // farther apart than the gap
  const Box ai(Vec3(0, 0, 0), Vec3(1, 1, 1), true), bi(Vec3(1.004, 0.2, 0.3), Vec3(2, 0.8, 0.6), true);
  const Aabb ri = region(ai, bi, 0.006);
  ASSERT_FALSE(empty(ri));
  EXPECT_LT((ri.lo - r.lo).norm(), 1e-12);  // the same up to rounding (other corner orders)
  EXPECT_LT((ri.hi - r.hi).norm(), 1e-12);
}

TEST(PartGap, OverlappingPartsAreAJointNotAGap) {
  // b's -x face 3 mm inside a, a's +x face inside b: faces opposed and 3 mm apart, but each
  // behind the other's face (the parts overlap there), so no gap.
  const Box a(Vec3(0, 0, 0), Vec3(1, 1, 1));
  const Box b(Vec3(0.997, 0.2, 0.3), Vec3(2, 0.8, 0.6));
  EXPECT_TRUE(empty(region(a, b, 0.006)));
}

// A thin slab tilted by `degrees` about the y axis over a's top face (z = 1), its lowest edge
// 2 mm above it at x = 0.5: the crease between them opens by that angle.
Box tilted_slab(double degrees) {
  Box s(Vec3(0, 0.2, 0), Vec3(0.4, 0.8, 0.05));
  const double t = degrees * M_PI / 180.0;
  for (int i = 0; i < 8; ++i) {
    const double x = s.x(i, 0), z = s.x(i, 2);
    s.x(i, 0) = 0.5 + x * std::cos(t) - z * std::sin(t);
    s.x(i, 2) = 1.002 + x * std::sin(t) + z * std::cos(t);
  }
  return s;
}

TEST(PartGap, ANarrowWedgePinchesAWideCreaseDoesNot) {
  const Box a(Vec3(0, 0, 0), Vec3(1, 1, 1));
  EXPECT_FALSE(empty(region(a, tilted_slab(10.0), 0.006)));  // normals 170 degrees apart
  EXPECT_TRUE(empty(region(a, tilted_slab(45.0), 0.006)));   // 135 degrees: cloth fits farther out
}

// Two parts of one character (group 0) and a cloth triangle; body 1 moves in x over a step.
struct TwoParts {
  Box a{Vec3(0, 0, 0), Vec3(1, 1, 1)};
  Box b;
  PinchTracking tracking;
  explicit TwoParts(double gap_x) : b(Vec3(1 + gap_x, 0.2, 0.3), Vec3(2, 0.8, 0.6)) {
    tracking.group = {0, 0};
    tracking.part_gap = 0.006;
    tracking.body_pairs = false;
  }
};

TEST(BodyPinchTracker, PartsCloseOnEachOtherAndOpenAgain) {
  TwoParts far(0.02), near(0.004);
  BodyPinchTracker tracker({0, 1}, 1, far.tracking);
  ASSERT_EQ(tracker.pairs().size(), 1u);
  EXPECT_TRUE(tracker.pairs()[0].parts);
  auto step = [&](const Box& b0, const Box& b1) {
    return tracker.update({&far.a.x, &b0.x}, {&far.a.x, &b1.x}, {&far.a.f, &b0.f});
  };
  EXPECT_EQ(step(far.b, far.b), 0);
  EXPECT_EQ(step(far.b, near.b), 1);
  EXPECT_EQ(tracker.pairs()[0].state(), PinchState::kBecomingPinched);
  EXPECT_EQ(step(near.b, near.b), 1);
  EXPECT_EQ(tracker.pairs()[0].state(), PinchState::kPinched);
  EXPECT_EQ(step(near.b, far.b), 1);
  EXPECT_EQ(tracker.pairs()[0].state(), PinchState::kBecomingUnpinched);
  EXPECT_EQ(step(far.b, far.b), 0);
  // Without a part gap, parts of one character are not tracked at all; nor, with body_pairs
  // off, are bodies of no character.
  PinchTracking none = far.tracking;
  none.part_gap = 0.0;
  EXPECT_TRUE(BodyPinchTracker({0, 1}, 1, none).pairs().empty());
  PinchTracking loose = far.tracking;
  loose.group = {-1, -1};
  EXPECT_TRUE(BodyPinchTracker({0, 1}, 1, loose).pairs().empty());
}

// The parts 4 mm apart, and a cloth triangle either between them or 0.5 m away.
struct PartsWithCloth {
  TwoParts parts{0.004};
  std::vector<KinematicBody> bodies;
  Faces faces{1, 3};
  Positions x{3, 3};
  Positions v = Positions::Zero(3, 3);
  std::unique_ptr<ContactDetection> detection;
  CollisionStep step;
  CollisionTelemetry frame;
  PinchDriver driver{{0, 1}, 2, 3, 1, parts.tracking};
  explicit PartsWithCloth(double cloth_x) {
    bodies = {KinematicBody(parts.a.f, parts.a.x), KinematicBody(parts.b.f, parts.b.x)};
    faces << 0, 1, 2;
    x << cloth_x, 0.4, 0.4, cloth_x, 0.6, 0.4, cloth_x, 0.5, 0.5;
    detection = std::make_unique<ContactDetection>(faces, x, std::vector<char>{1}, std::vector<char>{0},
                                                   std::vector<double>{0.003}, bodies, std::vector<char>{1, 1});
    step.begin(x, v, 0.01);
    step.body_start.resize(2);
    step.body_end.resize(2);
    for (int b = 0; b < 2; ++b) {
      bodies[b].positions_at(0.0, step.body_start[b]);
      bodies[b].positions_at(1.0, step.body_end[b]);
    }
    driver.update(step, *detection, 0.003, false, frame);
  }
};

TEST(PinchDriver, PartsClosingOnClothEngageOnlyWithClothThere) {
  PartsWithCloth between(1.002);
  EXPECT_EQ(between.driver.tracker().active_pairs(), 1);
  EXPECT_EQ(between.driver.engaged_pairs(), 1);
  EXPECT_EQ(between.frame.gia_pinched_part_pairs, 1);
  EXPECT_EQ(between.frame.gia_pinched_body_pairs, 0);
  // The smaller part gives way: CCD off against it only, so the cloth stays out of the larger.
  EXPECT_EQ(between.driver.tracker().pairs()[0].yields, 1);
  EXPECT_FALSE(between.driver.face_in_region(0, 0));
  EXPECT_TRUE(between.driver.face_in_region(0, 1));
  // Not held (gripped) but squeezed: recovery leaves it to the part passing over it.
  EXPECT_FALSE(between.driver.held(0, 0));
  EXPECT_FALSE(between.driver.held(0, 1));
  EXPECT_FALSE(between.driver.squeezed(0, 0));
  EXPECT_TRUE(between.driver.squeezed(0, 1));

  PartsWithCloth away(-0.5);
  EXPECT_EQ(away.driver.tracker().active_pairs(), 1);  // the parts still face each other closely ...
  EXPECT_EQ(away.driver.engaged_pairs(), 0);           // ... but with no cloth there, nothing changes
  EXPECT_EQ(away.frame.gia_pinched_part_pairs, 0);
  EXPECT_TRUE(away.driver.no_region(0));
  EXPECT_TRUE(away.driver.no_region(1));
  EXPECT_FALSE(away.driver.held(0, 1));
  EXPECT_FALSE(away.driver.squeezed(0, 1));
}

}  // namespace
}  // namespace weft
