// CollisionSystem::abandon_when: the integrator's test of a step's end positions, asked after
// every CCD pass that found collisions; once it answers yes the step's response stops there.
// CollisionSystem::spread_friction_with: kinetic friction that would tear an edge at a held
// vertex goes through the cloth's response instead.
#include <gtest/gtest.h>

#include <Eigen/Dense>
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

// A 4 x 8 strip of cloth (2 cm cells, 10 g vertices, 5 mm thick) lying within its thickness on a plate that
// holds its first three rows (x < 0.05 m); the plate slides along -x, away from the free rows,
// at `speed` within the step.
struct StripOnASlidingPlate {
  static constexpr int kColumns = 4, kRows = 8;
  static constexpr double kCell = 0.02, kThickness = 0.005, kMass = 0.01, kStep = 0.01;
  Faces cloth = testing::grid_faces(kRows, kColumns);
  Positions x{kColumns * kRows, 3};
  std::vector<double> mass = std::vector<double>(kColumns * kRows, kMass);
  std::vector<KinematicBody> bodies;
  std::vector<std::array<double, 3>> rest;

  explicit StripOnASlidingPlate(double speed) {
    for (int i = 0; i < kRows; ++i)
      for (int j = 0; j < kColumns; ++j) x.row(i * kColumns + j) << kCell * i, 0.95 * kThickness, kCell * j;
    Faces plate(2, 3);
    plate << 0, 2, 1, 0, 3, 2;
    Positions start(4, 3), end(4, 3);
    start << -0.1, 0, -0.1, 0.05, 0, -0.1, 0.05, 0, 0.2, -0.1, 0, 0.2;
    end = start;
    end.col(0).array() -= speed * kStep;
    bodies.emplace_back(plate, start);
    bodies.back().set_keyframes(start, end);
    for (int f = 0; f < cloth.rows(); ++f)
      rest.push_back({(row3(x, cloth(f, 1)) - row3(x, cloth(f, 0))).norm(),
                      (row3(x, cloth(f, 2)) - row3(x, cloth(f, 1))).norm(),
                      (row3(x, cloth(f, 0)) - row3(x, cloth(f, 2))).norm()});
  }
  CollisionSystem system() const {
    CollisionSettings settings;
    settings.enabled = true;
    settings.count_intersections = false;
    settings.face_friction = VectorX::Constant(cloth.rows(), 0.5);
    settings.face_thickness = VectorX::Constant(cloth.rows(), kThickness);
    return CollisionSystem(cloth, x, mass, {}, bodies, settings, 1, rest);
  }
  // The largest edge length over rest length at x + h v.
  double max_strain(const Positions& v) const {
    const Positions end = x + kStep * v;
    double worst = 0.0;
    for (int f = 0; f < cloth.rows(); ++f)
      for (int c = 0; c < 3; ++c) {
        const int a = cloth(f, c), b = cloth(f, (c + 1) % 3);
        worst = std::max(worst, (row3(end, b) - row3(end, a)).norm() / (row3(x, b) - row3(x, a)).norm());
      }
    return worst;
  }
  // The response of springs along the grid's edges in one implicit step: (M + h^2 k L) y = J,
  // per coordinate (L the edges' graph Laplacian, k 200 N/m), solved exactly.
  void response(const VectorX& impulse, VectorX& change) const {
    const int n = static_cast<int>(x.rows());
    Eigen::MatrixXd a = Eigen::MatrixXd::Identity(n, n) * kMass;
    const double k = 200.0 * kStep * kStep;
    for (int f = 0; f < cloth.rows(); ++f)
      for (int c = 0; c < 3; ++c) {
        const int i = cloth(f, c), j = cloth(f, (c + 1) % 3);
        if (i > j) continue;  // interior edges appear in two faces, each way once
        a(i, i) += k, a(j, j) += k, a(i, j) -= k, a(j, i) -= k;
      }
    const Eigen::LDLT<Eigen::MatrixXd> solver(a);
    change.resize(3 * n);
    for (int d = 0; d < 3; ++d) {
      Eigen::VectorXd rhs(n);
      for (int i = 0; i < n; ++i) rhs[i] = impulse[3 * i + d];
      const Eigen::VectorXd y = solver.solve(rhs);
      for (int i = 0; i < n; ++i) change[3 * i + d] = y[i];
    }
  }
};

// One step of the strip: contacts constrained, pressed by 0.1 N s each (a residual along -n),
// then the collision stage. Returns the step's telemetry; v is the velocity it leaves.
CollisionTelemetry strip_step(const StripOnASlidingPlate& scene, CollisionSystem& system, Positions& v) {
  const double h = StripOnASlidingPlate::kStep;
  ConstraintFilter filter;
  filter.reset(static_cast<int>(scene.x.rows()));
  system.begin_frame();
  system.constrain_contacts(scene.x, v, h, scene.bodies, 0.0, 1.0, filter);
  VectorX residual = VectorX::Zero(3 * scene.x.rows());
  for (int i = 0; i < scene.x.rows(); ++i)
    if (filter.projection[i] != Mat3::Identity()) residual[3 * i + 1] = -0.1;
  system.contact_impulses(residual);
  system.respond(scene.x, v, h, scene.bodies, 0.0, 1.0);
  return system.end_frame(scene.x + h * v, scene.bodies);
}

TEST(CollisionSystem, KineticFrictionThatWouldTearAnEdgeGoesThroughTheClothsResponse) {
  // 1.2 m/s: friction stops the held rows on the plate (0.5 x 0.1 N s over 10 g is 5 m/s), 1.2
  // cm in the step (under kSpreadSlide thicknesses): alone, their edges to the free rows would
  // end 1.6x their rest.
  const StripOnASlidingPlate fast(1.2);
  int calls = 0;
  auto response = [&](const VectorX& impulse, VectorX& change) {
    ++calls;
    fast.response(impulse, change);
  };
  CollisionSystem alone = fast.system();
  Positions v_alone = Positions::Zero(fast.x.rows(), 3);
  const CollisionTelemetry alone_step = strip_step(fast, alone, v_alone);
  ASSERT_EQ(alone_step.contact_constraints, 3 * StripOnASlidingPlate::kColumns);
  EXPECT_EQ(alone_step.friction_spreads, 0);
  EXPECT_GT(alone_step.strain_limited_edges, 0);  // the strain limit had to pull them back

  CollisionSystem spread = fast.system();
  spread.spread_friction_with(response);
  Positions v_spread = Positions::Zero(fast.x.rows(), 3);
  const CollisionTelemetry spread_step = strip_step(fast, spread, v_spread);
  EXPECT_EQ(calls, 1);
  EXPECT_EQ(spread_step.friction_spreads, 1);
  EXPECT_EQ(spread_step.strain_limited_edges, 0);  // the free rows came along
  EXPECT_LT(fast.max_strain(v_spread), 1.4);
  // The same momentum either way (the limit's corrections and the springs' response keep it;
  // the proximity response's friction on the rows within the thickness, which slide a little
  // more after the spread, adds 0.1%): friction's impulse, now carried by the whole strip.
  const double momentum_alone = v_alone.col(0).sum(), momentum_spread = v_spread.col(0).sum();
  EXPECT_NEAR(momentum_spread, momentum_alone, 2e-3 * std::abs(momentum_alone));
  EXPECT_LT(v_spread(StripOnASlidingPlate::kRows * StripOnASlidingPlate::kColumns - 1, 0), 0.0);
  EXPECT_EQ(v_alone(StripOnASlidingPlate::kRows * StripOnASlidingPlate::kColumns - 1, 0), 0.0);

  // 0.2 m/s: 2 mm of drag stretches nothing past the limit; 3 m/s: the plate sweeps 3 cm past
  // the cloth (a body sweeping past: its friction stays on the vertices, which slide). Neither
  // asks the response, and each step is the same as without it.
  for (const double speed : {0.2, 3.0}) {
    const StripOnASlidingPlate other(speed);
    CollisionSystem other_alone = other.system(), other_spread = other.system();
    other_spread.spread_friction_with(response);
    Positions v_other_alone = Positions::Zero(other.x.rows(), 3), v_other_spread = v_other_alone;
    strip_step(other, other_alone, v_other_alone);
    EXPECT_EQ(strip_step(other, other_spread, v_other_spread).friction_spreads, 0) << speed;
    EXPECT_EQ(v_other_spread, v_other_alone) << speed;
    EXPECT_LT(v_other_alone(0, 0), 0.0) << speed;  // friction dragged the held rows
  }
  EXPECT_EQ(calls, 1);
}

}  // namespace
}  // namespace weft
