// The GIA drivers of the collision stage: a cloth vertex inside a closed body is coloured
// (its membrane queries answer) and pushed back out; two intersecting boxes make a pinch that
// takes CCD away from the cloth between them.
#include <gtest/gtest.h>

#include <memory>

#include "weft/gia/gia_body_driver.h"
#include "weft/gia/pinch_driver.h"

namespace weft {
namespace {

// Closed unit-ish box [lo, hi]^3, outward faces.
KinematicBody box(const Vec3& lo, const Vec3& hi) {
  Positions x(8, 3);
  for (int i = 0; i < 8; ++i)
    x.row(i) << ((i & 1) ? hi.x() : lo.x()), ((i & 2) ? hi.y() : lo.y()), ((i & 4) ? hi.z() : lo.z());
  Faces f(12, 3);
  f << 0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5;
  return KinematicBody(f, x);
}

// A small cloth triangle whose first vertex dips into the box top (z = 0) by 1 cm.
struct DippedCloth {
  Faces faces{1, 3};
  Positions x{3, 3};
  Positions v = Positions::Zero(3, 3);
  std::vector<KinematicBody> bodies = {box(Vec3(-1, -1, -1), Vec3(1, 1, 0))};
  ContactProperties props;
  DippedCloth() {
    faces << 0, 1, 2;
    x << 0.1, 0.1, -0.01, 0.3, 0.1, 0.05, 0.1, 0.3, 0.05;
    props.inverse_mass = {1.0, 1.0, 1.0};
    props.thickness.assign(3, 0.002);
    props.friction.assign(3, 0.0);
  }
  ContactDetection detection() const { return ContactDetection(faces, x, {1}, {0}, {0.002}, bodies, {1}); }
};

void body_step(CollisionStep& step, const std::vector<KinematicBody>& bodies) {
  step.body_start.resize(bodies.size());
  step.body_end.resize(bodies.size());
  for (size_t b = 0; b < bodies.size(); ++b) {
    bodies[b].positions_at(0.0, step.body_start[b]);
    bodies[b].positions_at(1.0, step.body_end[b]);
  }
}

TEST(GiaBodyDriver, ColoursAVertexInsideAClosedBodyAndPushesItOut) {
  DippedCloth c;
  const ContactDetection detection = c.detection();
  GiaBodyDriver driver(detection, 3);
  CollisionStep step;
  const double h = 0.01;
  step.begin(c.x, c.v, h);
  body_step(step, c.bodies);
  CollisionTelemetry frame;
  EXPECT_TRUE(driver.colour(step, 1, frame));
  EXPECT_TRUE(driver.coloured(0, 0));
  EXPECT_FALSE(driver.coloured(1, 0));
  EXPECT_TRUE(driver.cloth_face_contour(0, 0));
  EXPECT_EQ(frame.gia_coloured_vertices, 1);
  driver.recover(step, c.props, nullptr, frame);
  EXPECT_EQ(frame.gia_pushed_vertices, 1);
  // Out through the top within the step, along the region's exit direction (towards its
  // uncoloured neighbours): the ray distance plus one thickness.
  EXPECT_GT(step.x_end(0, 2), 0.0);
  EXPECT_LT(step.x_end(0, 2), 0.002);
  EXPECT_GT(c.v(0, 0), 0.0);
  EXPECT_EQ(c.v.bottomRows(2).norm(), 0.0);
  driver.clear();
  EXPECT_FALSE(driver.coloured(0, 0));
}

// One colouring of the cloth at its positions (a 10 ms step), against the bodies `only` marks.
bool colour_once(GiaBodyDriver& driver, DippedCloth& c, CollisionTelemetry& frame,
                 const std::vector<char>* only = nullptr) {
  CollisionStep step;
  step.begin(c.x, c.v, 0.01);
  body_step(step, c.bodies);
  return driver.colour(step, 1, frame, only);
}

// The dipped cloth against its box and a second box 10 m away, with a driver for both.
struct WithFarBox {
  DippedCloth c = with_far_box();
  ContactDetection detection{c.faces, c.x, {1}, {0}, {0.002}, c.bodies, {1, 1}};
  GiaBodyDriver driver{detection, 3};
  static DippedCloth with_far_box() {
    DippedCloth cloth;
    cloth.bodies.push_back(box(Vec3(10, 10, 10), Vec3(11, 11, 11)));
    return cloth;
  }
};

TEST(GiaBodyDriver, ColoursNothingOnCleanCloth) {
  DippedCloth c;
  c.x.col(2).array() += 0.02;
  const ContactDetection detection = c.detection();
  GiaBodyDriver driver(detection, 3);
  CollisionTelemetry frame;
  EXPECT_FALSE(colour_once(driver, c, frame));
  EXPECT_FALSE(driver.coloured(0, 0));
  EXPECT_EQ(frame.gia_coloured_vertices, 0);
}

TEST(GiaBodyDriver, ABodyAwayFromTheClothIsLeftClean) {
  // The first box is coloured as when alone, the second is skipped (its box misses the
  // cloth's) and answers as clean.
  WithFarBox t;
  GiaBodyDriver& driver = t.driver;
  CollisionTelemetry frame;
  EXPECT_TRUE(colour_once(driver, t.c, frame));
  EXPECT_TRUE(driver.coloured(0, 0));
  EXPECT_TRUE(driver.cloth_face_contour(0, 0));
  EXPECT_FALSE(driver.clean(0));
  EXPECT_TRUE(driver.clean(1));
  EXPECT_EQ(frame.gia_coloured_vertices, 1);
}

TEST(GiaBodyDriver, ABodyLeftOutAnswersAsAnalysedWithNothingFound) {
  // The collision stage leaves out bodies whose pairs CCD guarded over the last step. Such a
  // body answers as one analysed that found nothing (not as one never looked at, whose filter
  // takes another detection path); a body away from the cloth stays clean either way.
  WithFarBox t;
  GiaBodyDriver& driver = t.driver;
  const std::vector<char> all{1, 1}, none{0, 0};
  CollisionTelemetry frame;
  EXPECT_TRUE(colour_once(driver, t.c, frame, &all));
  EXPECT_TRUE(driver.intersects(0));
  EXPECT_FALSE(driver.intersects(1));
  CollisionTelemetry left_out;
  EXPECT_FALSE(colour_once(driver, t.c, left_out, &none));
  EXPECT_FALSE(driver.intersects(0));
  EXPECT_FALSE(driver.coloured(0, 0));
  EXPECT_FALSE(driver.cloth_face_contour(0, 0));
  EXPECT_FALSE(driver.clean(0));
  EXPECT_TRUE(driver.clean(1));
  EXPECT_EQ(left_out.gia_coloured_vertices, 0);
  EXPECT_EQ(left_out.gia_paths, 0);
}

// The dipped cloth with a second box; the pinch state after one step's update.
struct TwoBoxes {
  DippedCloth c;
  std::unique_ptr<ContactDetection> detection;
  PinchDriver pinch{{0, 1}, 2, 3, 1};
  CollisionStep step;
  CollisionTelemetry frame;
  explicit TwoBoxes(const KinematicBody& second) {
    c.bodies.push_back(second);
    detection = std::make_unique<ContactDetection>(c.faces, c.x, std::vector<char>{1}, std::vector<char>{0},
                                                   std::vector<double>{0.002}, c.bodies, std::vector<char>{1, 1});
    step.begin(c.x, c.v, 0.01);
    body_step(step, c.bodies);
    pinch.update(step, *detection, 0.002, true, frame);
  }
};

TEST(PinchDriver, ClothBetweenIntersectingBoxesGetsNoCcd) {
  TwoBoxes t(box(Vec3(-0.5, -0.5, -0.01), Vec3(0.5, 0.5, 1)));  // into the lower box
  EXPECT_EQ(t.pinch.engaged_pairs(), 1);
  EXPECT_EQ(t.frame.gia_pinched_body_pairs, 1);
  EXPECT_TRUE(t.pinch.face_in_region(0, 0));
  EXPECT_TRUE(t.pinch.face_in_region(0, 1));
  // Grip: a vertex moves with the closest point of the (resting) body.
  t.c.v.row(0) << 1, 2, 3;
  t.pinch.grip(0, t.detection->bodies()[0].faces, t.step.body_start[0], t.step.body_end[0], t.step, t.frame);
  EXPECT_EQ(t.c.v.row(0).norm(), 0.0);
  EXPECT_EQ(t.frame.gia_gripped_vertices, 1);
}

TEST(PinchDriver, SeparateBoxesAreFree) {
  TwoBoxes t(box(Vec3(2, 2, 2), Vec3(3, 3, 3)));
  EXPECT_EQ(t.pinch.engaged_pairs(), 0);
  EXPECT_FALSE(t.pinch.face_in_region(0, 1));
  EXPECT_FALSE(t.pinch.marks_faces(1));
  // The dipped triangle is through the lower box: found in an unclean step, unless the caller
  // says that box was guarded by CCD (then it is not looked for).
  EXPECT_TRUE(t.pinch.face_in_region(0, 0));
  EXPECT_TRUE(t.pinch.marks_faces(0));
  const std::vector<char> only_second{0, 1};
  t.pinch.update(t.step, *t.detection, 0.002, true, t.frame, &only_second);
  EXPECT_FALSE(t.pinch.face_in_region(0, 0));
  EXPECT_FALSE(t.pinch.marks_faces(0));
}

TEST(PinchDriver, EngagedBoxesMarkTheFacesInTheirRegion) {
  TwoBoxes t(box(Vec3(-0.5, -0.5, -0.01), Vec3(0.5, 0.5, 1)));
  EXPECT_TRUE(t.pinch.marks_faces(0));
  EXPECT_TRUE(t.pinch.marks_faces(1));
}

}  // namespace
}  // namespace weft
