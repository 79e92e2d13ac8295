// Contact constraints (contact_constraints.h): every free cloth vertex within two thicknesses of a
// collidable body face gets the closest one (lowest body, then face, on ties) as its contact,
// found vertex by vertex in the body trees; checked against every vertex measured against every
// face of every body.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>

#include "support/grid_faces.h"
#include "weft/collision/contact_constraints.h"
#include "weft/geometry/closest_points.h"

namespace weft {
namespace {

constexpr double kThickness = 0.002;
constexpr double kBand = 2.0 * kThickness;  // contact_constraints.cpp's band

// A bumpy floor (body 0) and a tilted plate over part of it (body 1), and a 14 x 14 cloth grid
// whose vertices hover 0.2-7 mm over the floor, some of them near the plate too.
struct Scene {
  Faces cloth_faces = testing::grid_faces(14);
  Positions x{14 * 14, 3};
  std::vector<KinematicBody> bodies;
  ContactProperties props;

  explicit Scene(unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    auto floor_height = [](double px, double py) { return 0.002 * std::sin(90.0 * px) * std::cos(70.0 * py); };
    const int m = 12;
    Positions floor(m * m, 3);
    for (int i = 0; i < m; ++i)
      for (int j = 0; j < m; ++j) {
        const double px = -0.01 + 0.015 * j, py = -0.01 + 0.015 * i;
        floor.row(i * m + j) << px, py, floor_height(px, py);
      }
    bodies.emplace_back(testing::grid_faces(m), floor);
    const int k = 5;
    Positions plate(k * k, 3);
    for (int i = 0; i < k; ++i)
      for (int j = 0; j < k; ++j) {
        const double px = 0.04 + 0.012 * j, py = 0.04 + 0.012 * i;
        plate.row(i * k + j) << px, py, 0.004 + 0.05 * (px - 0.04);
      }
    bodies.emplace_back(testing::grid_faces(k), plate);
    for (int i = 0; i < 14; ++i)
      for (int j = 0; j < 14; ++j) {
        const double px = 0.01 * j + 0.002 * unit(rng), py = 0.01 * i + 0.002 * unit(rng);
        x.row(i * 14 + j) << px, py, floor_height(px, py) + 0.0002 + 0.0068 * unit(rng);
      }
    const int n = static_cast<int>(x.rows());
    props.inverse_mass.assign(n, 1.0);
    props.inverse_mass[0] = props.inverse_mass[17] = 0.0;  // pinned: never constrained
    props.thickness.assign(n, kThickness);
    props.friction.assign(n, 0.3);
  }
};

struct Closest {
  double distance = std::numeric_limits<double>::infinity();
  Vec3 normal = Vec3::Zero();
};

// Every free vertex against every face of every body, in order: the first of equal distances.
std::vector<Closest> brute_force(const Scene& s) {
  std::vector<Closest> out(s.x.rows());
  for (Eigen::Index i = 0; i < s.x.rows(); ++i) {
    if (s.props.inverse_mass[i] == 0.0) continue;
    const Vec3 p = row3(s.x, static_cast<int>(i));
    for (const KinematicBody& body : s.bodies) {
      const Positions& y = body.frame_start();
      for (Eigen::Index f = 0; f < body.faces().rows(); ++f) {
        const Vec3 a = row3(y, body.faces()(f, 0)), b = row3(y, body.faces()(f, 1)), c = row3(y, body.faces()(f, 2));
        Vec3 bary;
        const double d = point_triangle_distance(p, a, b, c, bary);
        if (d >= kBand || d <= 1e-12 * kThickness || d >= out[i].distance) continue;
        out[i].distance = d;
        out[i].normal = (p - (bary[0] * a + bary[1] * b + bary[2] * c)) / d;
      }
    }
  }
  return out;
}

// One step of s with cloth velocities v (kept by the caller) and still bodies, and its filter.
struct StillStep {
  CollisionStep step;
  ConstraintFilter filter;
  StillStep(const Scene& s, Positions& v) {
    step.begin(s.x, v, 0.01);
    for (const KinematicBody& body : s.bodies) {
      step.body_start.push_back(body.frame_start());
      step.body_end.push_back(body.frame_start());
    }
    filter.reset(static_cast<int>(s.x.rows()));
  }
};

// Every vertex moves at 10 m/s towards its closest face (brute force), or falls where it has
// none: each one within the band approaches its contact faster than the target, so each gets
// a constraint along the normal the search chose.
ConstraintFilter constrain(const Scene& s, const std::vector<Closest>& closest, int threads,
                           CollisionTelemetry& frame) {
  const int faces = static_cast<int>(s.cloth_faces.rows());
  ContactDetection detection(s.cloth_faces, s.x, std::vector<char>(faces, 1), std::vector<char>(faces, 0),
                             std::vector<double>(faces, kThickness), s.bodies, {1, 1});
  detection.set_threads(threads);
  Positions v = Positions::Zero(s.x.rows(), 3);
  for (Eigen::Index i = 0; i < v.rows(); ++i)
    v.row(i) = std::isfinite(closest[i].distance) ? Vec3(-10.0 * closest[i].normal).transpose() : Vec3(0, 0, -10).transpose();
  StillStep still(s, v);
  ContactConstraints().constrain(s.x, v, 0.01, still.step, detection, s.props, still.filter, frame);
  return still.filter;
}

TEST(ContactConstraints, EachFreeVertexGetsItsClosestBodyFaceWithinTheBand) {
  for (unsigned seed : {1u, 2u, 3u}) {
    const Scene s(seed);
    const std::vector<Closest> expected = brute_force(s);
    CollisionTelemetry frame;
    const ConstraintFilter filter = constrain(s, expected, 2, frame);
    int contacts = 0, near_plate = 0;
    for (size_t i = 0; i < expected.size(); ++i) {
      if (!std::isfinite(expected[i].distance)) {
        EXPECT_EQ(filter.projection[i], Mat3::Identity()) << "vertex " << i << ", seed " << seed;
        continue;
      }
      ++contacts;
      const Vec3& n = expected[i].normal;
      near_plate += n.x() < -0.01;  // the tilted plate's normals lean towards -x
      EXPECT_LT((filter.projection[i] - (Mat3::Identity() - n * n.transpose())).cwiseAbs().maxCoeff(), 1e-12)
          << "vertex " << i << ", seed " << seed;
    }
    EXPECT_EQ(frame.contact_constraints, contacts);
    // Not vacuous: most vertices are within the band, a few beyond it, some closest to the plate.
    EXPECT_GT(contacts, 100) << "seed " << seed;
    EXPECT_LT(contacts, 14 * 14 - 2) << "seed " << seed;
    EXPECT_GT(near_plate, 0) << "seed " << seed;
  }
}

// clear_vertices(): the free vertices with no body face nearer than their thickness, which the
// proximity list skips; brute force over every face of every body, a vertex lying exactly on a
// floor corner (distance 0, which the nearest face search passes over) included.
TEST(ContactConstraints, ClearVerticesHaveNoBodyFaceWithinTheirThickness) {
  for (unsigned seed : {5u, 6u}) {
    Scene s(seed);
    s.x.row(5) = s.bodies[0].frame_start().row(13);
    const int faces = static_cast<int>(s.cloth_faces.rows());
    ContactDetection detection(s.cloth_faces, s.x, std::vector<char>(faces, 1), std::vector<char>(faces, 0),
                               std::vector<double>(faces, kThickness), s.bodies, {1, 1});
    detection.set_threads(2);
    Positions v = Positions::Zero(s.x.rows(), 3);
    StillStep still(s, v);
    ContactConstraints constraints;
    EXPECT_EQ(constraints.clear_vertices(), nullptr);  // before constrain(): nothing to go by
    CollisionTelemetry frame;
    constraints.constrain(s.x, v, 0.01, still.step, detection, s.props, still.filter, frame);
    ASSERT_NE(constraints.clear_vertices(), nullptr);
    const std::vector<char>& clear = *constraints.clear_vertices();
    int clear_count = 0, near_count = 0;
    for (Eigen::Index i = 0; i < s.x.rows(); ++i) {
      double nearest = std::numeric_limits<double>::infinity();
      for (const KinematicBody& body : s.bodies)
        for (Eigen::Index f = 0; f < body.faces().rows(); ++f) {
          const Positions& y = body.frame_start();
          Vec3 bary;
          nearest = std::min(nearest, point_triangle_distance(row3(s.x, static_cast<int>(i)), row3(y, body.faces()(f, 0)),
                                                              row3(y, body.faces()(f, 1)), row3(y, body.faces()(f, 2)), bary));
        }
      const bool expected = s.props.inverse_mass[i] != 0.0 && nearest >= kThickness;
      EXPECT_EQ(clear[i] != 0, expected) << "vertex " << i << " at " << nearest << ", seed " << seed;
      clear_count += expected;
      near_count += !expected;
    }
    EXPECT_GT(clear_count, 20) << "seed " << seed;
    EXPECT_GT(near_count, 20) << "seed " << seed;
    EXPECT_EQ(clear[5], 0);
    constraints.clear();
    EXPECT_EQ(constraints.clear_vertices(), nullptr);
  }
}

TEST(ContactConstraints, TheSameContactsOnAnyThreadCount) {
  const Scene s(4);
  const std::vector<Closest> closest = brute_force(s);
  CollisionTelemetry one, two;
  const ConstraintFilter a = constrain(s, closest, 1, one), b = constrain(s, closest, 2, two);
  EXPECT_EQ(one.contact_constraints, two.contact_constraints);
  for (size_t i = 0; i < a.projection.size(); ++i) {
    EXPECT_EQ(a.projection[i], b.projection[i]) << "vertex " << i;
    EXPECT_EQ(a.prescribed.segment<3>(3 * i), b.prescribed.segment<3>(3 * i)) << "vertex " << i;
  }
}

// The searches a vertex skips while it and the bodies stay far apart (contact_constraints.h,
// far_margin_) change nothing: a ContactConstraints used over a sequence of steps gives, at each,
// the filter and the clear vertices of a new one (with the same held and released flags). The
// cloth is lifted far above the bodies for some steps (their searches skipped), jiggled, dropped
// back into the band in one step, and the plate moves towards it.
TEST(ContactConstraints, SkippedSearchesGiveTheContactsOfAFullSearch) {
  const Scene s(7);
  const int faces = static_cast<int>(s.cloth_faces.rows());
  const int n = static_cast<int>(s.x.rows());
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> jiggle(-0.0005, 0.0005);
  const std::vector<double> lift{0.0, 0.05, 0.0502, 0.0499, 0.05, 0.0, 0.0003, 0.02, 0.0, 0.0};
  const std::vector<double> plate_drop{0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.002, 0.003};
  ContactConstraints cached;
  int contacts = 0, clear_count = 0;
  for (size_t k = 0; k < lift.size(); ++k) {
    Positions x = s.x;
    for (int i = 0; i < n; ++i) x.row(i) += Vec3(jiggle(rng), jiggle(rng), lift[k] + jiggle(rng)).transpose();
    Positions v = Positions::Zero(n, 3);
    v.col(2).setConstant(-1.0);  // approaching: every vertex within the band is constrained
    CollisionStep step;
    step.begin(x, v, 0.01);
    for (size_t b = 0; b < s.bodies.size(); ++b) {
      Positions y = s.bodies[b].frame_start();
      if (b == 1) y.col(2).array() -= plate_drop[k];
      step.body_start.push_back(y);
      step.body_end.push_back(y);
    }
    ContactDetection detection(s.cloth_faces, x, std::vector<char>(faces, 1), std::vector<char>(faces, 0),
                               std::vector<double>(faces, kThickness), s.bodies, {1, 1});
    detection.set_threads(2);
    cached.clear();  // as the collision system does after each step
    ContactConstraints fresh;
    fresh.set_flags(cached.flags(), n);
    ConstraintFilter with_cache, without;
    with_cache.reset(n);
    without.reset(n);
    CollisionTelemetry a, b;
    cached.constrain(x, v, 0.01, step, detection, s.props, with_cache, a);
    fresh.constrain(x, v, 0.01, step, detection, s.props, without, b);
    ASSERT_EQ(a.contact_constraints, b.contact_constraints) << "step " << k;
    for (int i = 0; i < n; ++i) {
      ASSERT_EQ(with_cache.projection[i], without.projection[i]) << "vertex " << i << ", step " << k;
      ASSERT_EQ(with_cache.prescribed.segment<3>(3 * i), without.prescribed.segment<3>(3 * i))
          << "vertex " << i << ", step " << k;
    }
    ASSERT_EQ(*cached.clear_vertices(), *fresh.clear_vertices()) << "step " << k;
    ASSERT_EQ(cached.flags(), fresh.flags()) << "step " << k;
    contacts += a.contact_constraints;
    clear_count += static_cast<int>(std::count(cached.clear_vertices()->begin(), cached.clear_vertices()->end(), 1));
  }
  // Not vacuous: contacts where the cloth is down, clear vertices where it is lifted.
  EXPECT_GT(contacts, 400);
  EXPECT_GT(clear_count, 4 * (n - 2));
}

// Friction of a contact's first step: its normal impulse stops the vertex's approach (an
// impact), and that share neither bounds its friction nor makes it stick; once held, the impulse
// that presses it on the body does, and a stop makes it stick only when it slid less than its
// thickness in the step. A 2 x 2 cloth patch 1.5 thicknesses over a flat floor, unit
// masses, A = I (no forces): the solve's dv is the filter's prescribed value, so each contact's
// normal impulse is exactly its prescribed normal velocity change (plus b's normal part).
TEST(ContactConstraints, FrictionFromThePressingImpulseAndStickingOnlyFromRest) {
  Positions floor(4, 3);
  floor << -1, -1, 0, 1, -1, 0, -1, 1, 0, 1, 1, 0;
  const std::vector<KinematicBody> bodies{KinematicBody(testing::grid_faces(2), floor)};
  const Faces cloth = testing::grid_faces(2);
  Positions x(4, 3);
  x << 0, 0, 1.5 * kThickness, 0.01, 0, 1.5 * kThickness, 0, 0.01, 1.5 * kThickness, 0.01, 0.01, 1.5 * kThickness;
  ContactProperties props;
  props.inverse_mass.assign(4, 1.0);
  props.thickness.assign(4, kThickness);
  props.friction.assign(4, 0.3);
  ContactDetection detection(cloth, x, std::vector<char>(2, 1), std::vector<char>(2, 0),
                             std::vector<double>(2, kThickness), bodies, {1});
  const double h = 0.01;
  // Target normal speed 1.5 thicknesses out: the speed that ends the step at the thickness.
  const double target = (kThickness - 1.5 * kThickness) / h;
  ContactConstraints contacts;
  // One step: constrain, solve A dv = b with A = I, impulses from the residual, friction.
  auto step = [&](Positions& v, const Vec3& b) {
    CollisionStep cs;
    cs.begin(x, v, h);
    cs.body_start.push_back(floor);
    cs.body_end.push_back(floor);
    ConstraintFilter filter;
    filter.reset(4);
    CollisionTelemetry frame;
    contacts.clear();
    contacts.constrain(x, v, h, cs, detection, props, filter, frame);
    VectorX rhs(12), dv(12);
    for (int i = 0; i < 4; ++i) rhs.segment<3>(3 * i) = b;
    for (int i = 0; i < 4; ++i)
      dv.segment<3>(3 * i) = filter.projection[i] * rhs.segment<3>(3 * i) + filter.prescribed.segment<3>(3 * i);
    contacts.impulses(rhs - dv);
    for (int i = 0; i < 4; ++i) v.row(i) += dv.segment<3>(3 * i).transpose();
    contacts.friction(cs, props);
    cs.end();
    return frame.contact_constraints;
  };
  // Step 1: every vertex arrives at 3 m/s with 0.5 m/s along the floor. The constraint's impulse
  // (target + 3 per unit mass) times 0.3 would stop the sliding (0.87 > 0.5); without the
  // impact's share it presses with target < 0: no friction, and nothing sticks.
  Positions v(4, 3);
  for (int i = 0; i < 4; ++i) v.row(i) << 0.5, 0.0, -3.0;
  ASSERT_EQ(step(v, Vec3::Zero()), 4);
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(v(i, 0), 0.5, 1e-12) << "vertex " << i;
    EXPECT_NEAR(v(i, 2), target, 1e-12) << "vertex " << i;
  }
  EXPECT_EQ(contacts.flags(), std::vector<std::uint8_t>(4, ContactConstraints::kHeld));
  // Step 2, the same positions, pressed by b = -0.1 along the normal (gravity's h g, say): held
  // now, its whole normal impulse 0.1 presses, and friction takes 0.3 x 0.1 off the sliding.
  ASSERT_EQ(step(v, Vec3(0.0, 0.0, -0.1)), 4);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(v(i, 0), 0.5 - 0.3 * 0.1, 1e-12) << "vertex " << i;
  EXPECT_EQ(contacts.flags(), std::vector<std::uint8_t>(4, ContactConstraints::kHeld));
  // Step 3: pressed a hundred times harder, friction stops it; but it slid 4.7 mm (0.47 m/s for
  // 0.01 s), more than its thickness: it stays held and does not stick.
  ASSERT_EQ(step(v, Vec3(0.0, 0.0, -10.0)), 4);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(v(i, 0), 0.0, 1e-12) << "vertex " << i;
  EXPECT_EQ(contacts.flags(), std::vector<std::uint8_t>(4, ContactConstraints::kHeld));
  // Step 4: sliding at 0.1 m/s (1 mm in the step), the same pressure stops it, and it sticks in
  // the next solve.
  for (int i = 0; i < 4; ++i) v(i, 0) = 0.1;
  ASSERT_EQ(step(v, Vec3(0.0, 0.0, -10.0)), 4);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(v(i, 0), 0.0, 1e-12) << "vertex " << i;
  EXPECT_EQ(contacts.flags(), std::vector<std::uint8_t>(4, ContactConstraints::kStuck));
}

}  // namespace
}  // namespace weft
