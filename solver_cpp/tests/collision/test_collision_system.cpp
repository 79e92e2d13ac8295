// CollisionSystem::abandon_when: the integrator's test of a step's end positions, asked after
// every CCD pass that found collisions; once it answers yes the step's response stops there.
#include <gtest/gtest.h>

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

}  // namespace
}  // namespace weft
