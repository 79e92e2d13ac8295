// CollisionSystem::abandon_when: the integrator's test of a step's end positions, asked after
// every CCD pass that found collisions; once it answers yes the step's response stops there.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <vector>

#include "support/grid_faces.h"
#include "weft/collision_system.h"

namespace weft {
namespace {

// A resting 6 x 6 sheet (10 cm cells) in the plane y = 0 and a 1 m square plate 2 cm below it
// that rises 8 cm within the step: the first CCD pass finds the plate hitting the sheet.
struct PlateThroughSheet {
  static constexpr int kSide = 6;
  Faces cloth = testing::grid_faces(kSide);
  Positions x{kSide * kSide, 3};
  Positions v = Positions::Zero(kSide * kSide, 3);
  std::vector<double> mass = std::vector<double>(kSide * kSide, 0.01);
  std::vector<KinematicBody> bodies;

  PlateThroughSheet() {
    for (int i = 0; i < kSide; ++i)
      for (int j = 0; j < kSide; ++j) x.row(i * kSide + j) << 0.1 * j, 0.0, 0.1 * i;
    Faces plate(2, 3);
    plate << 0, 1, 2, 0, 2, 3;
    Positions below(4, 3), above(4, 3);
    below << -0.2, -0.02, -0.2, 0.7, -0.02, -0.2, 0.7, -0.02, 0.7, -0.2, -0.02, 0.7;
    above = below;
    above.col(1).array() += 0.08;
    bodies.emplace_back(plate, below);
    bodies.back().set_keyframes(below, above);
  }
  CollisionSystem system() const {
    CollisionSettings settings;
    settings.enabled = true;
    settings.contact_constraints = false;
    settings.count_intersections = false;
    return CollisionSystem(cloth, x, mass, {}, bodies, settings, 1);
  }
};

TEST(CollisionSystem, AnAbandonedStepStopsAtTheCcdPassThatAbandonedIt) {
  const PlateThroughSheet scene;
  const double h = 1.0 / 24.0;

  CollisionSystem full = scene.system();
  Positions v_full = scene.v;
  full.begin_frame();
  full.respond(scene.x, v_full, h, scene.bodies, 0.0, 1.0);
  const CollisionTelemetry all_passes = full.end_frame(scene.x + h * v_full, scene.bodies);
  EXPECT_FALSE(full.abandoned());
  ASSERT_GE(all_passes.iterations, 2);  // a pass with hits, then one that checks they are gone
  ASSERT_GT(all_passes.ccd_hits, 0);

  // A test that never says yes changes nothing: asked after every pass that had hits.
  CollisionSystem asked = scene.system();
  Positions v_asked = scene.v;
  int calls = 0;
  asked.abandon_when([&](const Positions&) {
    ++calls;
    return false;
  });
  asked.begin_frame();
  asked.respond(scene.x, v_asked, h, scene.bodies, 0.0, 1.0);
  const CollisionTelemetry asked_passes = asked.end_frame(scene.x + h * v_asked, scene.bodies);
  EXPECT_FALSE(asked.abandoned());
  EXPECT_EQ(asked_passes.iterations, all_passes.iterations);
  EXPECT_EQ(calls, all_passes.iterations - 1);
  EXPECT_EQ(v_asked, v_full);

  // One that says yes at once: one pass, and the step is marked abandoned until the next one.
  CollisionSystem stopped = scene.system();
  Positions v_stopped = scene.v;
  stopped.abandon_when([](const Positions& x_end) { return x_end.rows() > 0; });
  stopped.begin_frame();
  stopped.respond(scene.x, v_stopped, h, scene.bodies, 0.0, 1.0);
  EXPECT_TRUE(stopped.abandoned());
  const CollisionTelemetry one_pass = stopped.end_frame(scene.x + h * v_stopped, scene.bodies);
  EXPECT_EQ(one_pass.iterations, 1);
  EXPECT_EQ(one_pass.impact_zones, 0);
  stopped.abandon_when(nullptr);
  Positions v_next = scene.v;
  stopped.begin_frame();
  stopped.respond(scene.x, v_next, h, scene.bodies, 0.0, 1.0);
  EXPECT_FALSE(stopped.abandoned());
}

// A 6 x 6 sheet (10 cm cells) falling at 30 m/s, half of it over a static plate 2 cm below: in
// one step CCD stops the half over the plate at its thickness while the other half falls on
// 31 cm. Before CCD the whole sheet moves as one (nothing for the strain limit to do); the
// round after CCD drags the free half's edges back towards the limit and leaves the cloth CCD
// stopped where CCD left it.
TEST(CollisionSystem, ClothStoppedByCcdDragsItsNeighboursInsteadOfTearingFromThem) {
  constexpr int kSide = 6;
  const Faces cloth = testing::grid_faces(kSide);
  Positions x(kSide * kSide, 3);
  for (int i = 0; i < kSide; ++i)
    for (int j = 0; j < kSide; ++j) x.row(i * kSide + j) << 0.1 * j, 0.0, 0.1 * i;
  Faces plate(2, 3);
  plate << 0, 1, 2, 0, 2, 3;
  Positions top(4, 3);
  top << -0.2, -0.02, -0.2, 0.25, -0.02, -0.2, 0.25, -0.02, 0.7, -0.2, -0.02, 0.7;  // under columns 0-2
  const std::vector<KinematicBody> bodies{KinematicBody(plate, top)};
  CollisionSettings settings;
  settings.enabled = true;
  settings.contact_constraints = false;
  settings.count_intersections = false;
  std::vector<std::array<double, 3>> rest(static_cast<size_t>(cloth.rows()));
  for (Eigen::Index f = 0; f < cloth.rows(); ++f)
    for (int c = 0; c < 3; ++c)
      rest[f][c] = (x.row(cloth(f, c)) - x.row(cloth(f, (c + 1) % 3))).norm();
  CollisionSystem system(cloth, x, std::vector<double>(kSide * kSide, 0.01), {}, bodies, settings, 1, rest);
  Positions v = Positions::Zero(kSide * kSide, 3);
  v.col(1).setConstant(-30.0);
  const double h = 1.0 / 96.0;
  system.begin_frame();
  system.respond(x, v, h, bodies, 0.0, 1.0);
  const Positions end = x + h * v;
  double worst = 0.0;
  for (Eigen::Index f = 0; f < cloth.rows(); ++f)
    for (int c = 0; c < 3; ++c)
      worst = std::max(worst, (end.row(cloth(f, c)) - end.row(cloth(f, (c + 1) % 3))).norm() / rest[f][c]);
  // Without the round the worst edge across the plate's edge ends at 3.9x its rest length; with
  // it near the limit (1.4), the round's four Gauss-Seidel passes short of the whole chain.
  EXPECT_LT(worst, 1.5);
  double lowest_over_plate = 1.0, lowest_beyond = 1.0;
  for (int i = 0; i < kSide; ++i)
    for (int j = 0; j < kSide; ++j) {
      const double y = end(i * kSide + j, 1);
      if (j <= 2) lowest_over_plate = std::min(lowest_over_plate, y);
      else lowest_beyond = std::min(lowest_beyond, y);
    }
  EXPECT_GT(lowest_over_plate, -0.02);  // still above the plate
  EXPECT_LT(lowest_beyond, -0.1);       // the free half hangs down past the plate's edge
  const CollisionTelemetry frame = system.end_frame(end, bodies);
  EXPECT_GT(frame.ccd_hits, 0);
  EXPECT_GT(frame.strain_limited_edges, 0);
}

}  // namespace
}  // namespace weft
