// Strain limit before CCD: a step may not stretch an edge beyond max_strain times its rest
// length (an edge that starts longer keeps half its excess); ends move by inverse mass.
#include <gtest/gtest.h>

#include "weft/collision/strain_limit.h"

#include <algorithm>
#include <array>
#include <vector>

namespace weft {
namespace {

// One triangle (0, 1, 2) with rest edges of 1 m; vertex 1 flies away along x.
struct Triangle {
  Faces faces{1, 3};
  Positions x{3, 3};
  Positions v = Positions::Zero(3, 3);
  ContactProperties props;
  CollisionStep step;
  Triangle() {
    faces << 0, 1, 2;
    x << 0, 0, 0, 1, 0, 0, 0.5, 0.8660254037844386, 0;
    props.inverse_mass = {1.0, 1.0, 1.0};
    props.thickness.assign(3, 0.002);
    props.friction.assign(3, 0.0);
  }
  StrainLimit limit(double max_strain) const { return StrainLimit(faces, {{1.0, 1.0, 1.0}}, max_strain, 50); }
};

TEST(StrainLimit, AStepCannotStretchAnEdgeBeyondTheLimit) {
  Triangle t;
  t.v.row(1) << 100.0, 0.0, 0.0;  // 1 m in a 0.01 s step: edge (0, 1) would double
  t.step.begin(t.x, t.v, 0.01);
  EXPECT_GT(t.limit(1.4).apply(t.step, t.props), 0);
  for (int c = 0; c < 3; ++c) {
    const int a = t.faces(0, c), b = t.faces(0, (c + 1) % 3);
    EXPECT_LE((t.step.x_end.row(a) - t.step.x_end.row(b)).norm(), 1.4 + 1e-9);
  }
  // Momentum kept (equal masses, internal corrections), and x_end stays x + h v.
  EXPECT_NEAR(t.v.colwise().sum()(0), 100.0, 1e-9);
  EXPECT_LT((t.step.x_end - (t.x + 0.01 * t.v)).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(StrainLimit, APinnedEndStaysAndAForcedStretchRelaxesGradually) {
  Triangle t;
  t.props.inverse_mass = {0.0, 1.0, 0.0};  // 0 and 2 pinned
  t.v.row(1) << 100.0, 0.0, 0.0;
  t.step.begin(t.x, t.v, 0.01);
  t.limit(1.4).apply(t.step, t.props);
  EXPECT_EQ(t.v.row(0).norm(), 0.0);
  EXPECT_EQ(t.v.row(2).norm(), 0.0);
  EXPECT_LE((t.step.x_end.row(1) - t.step.x_end.row(0)).norm(), 1.4 + 1e-9);
  // Already stretched to 2 m at the step's start (by a pin, say): half the excess over 1.4 m
  // is given back in one step, not all of it.
  Triangle forced;
  forced.props.inverse_mass = {0.0, 1.0, 1.0};  // 0 pinned
  forced.x.row(1) << 2.0, 0.0, 0.0;
  forced.x.row(2) << 1.2, 0.5, 0.0;  // its other edges within the limit
  forced.step.begin(forced.x, forced.v, 0.01);
  EXPECT_GT(forced.limit(1.4).apply(forced.step, forced.props), 0);
  EXPECT_NEAR((forced.step.x_end.row(1) - forced.step.x_end.row(0)).norm(),
              (1.0 - kStrainLimitSlack) * (1.4 + 0.5 * 0.6), 1e-9);
  EXPECT_EQ(forced.step.x_end.row(0).norm(), 0.0);
  // Off below a strain of 1.
  Triangle off;
  off.v.row(1) << 100.0, 0.0, 0.0;
  off.step.begin(off.x, off.v, 0.01);
  const StrainLimit none = off.limit(1.0);
  EXPECT_FALSE(none.enabled());
}

// Vertex 0 rests on a body below it (outward normal +z, the floor z = 0) and vertex 1 flies off
// down and away: the correction that pulls 0 towards 1 would take it into the body. With the
// contact's normal given, 0 slides along the body (its end stays at z = 0) and 1 takes the
// rest, until every edge is within the limit; without it, 0 sinks below the floor.
TEST(StrainLimit, AVertexHeldOnABodySlidesAlongItInsteadOfIntoIt) {
  const std::vector<Vec3> normals = {Vec3(0.0, 0.0, 1.0), Vec3::Zero(), Vec3::Zero()};
  auto pulled = [] {
    Triangle t;
    t.v.row(1) << 100.0, 0.0, -100.0;  // ends at (2, 0, -1): edge (0, 1) about 2.24 m
    t.step.begin(t.x, t.v, 0.01);
    return t;
  };
  Triangle plain = pulled();
  EXPECT_GT(plain.limit(1.4).apply(plain.step, plain.props), 0);
  EXPECT_LT(plain.step.x_end(0, 2), -0.1);  // into the body

  Triangle held = pulled();
  EXPECT_GT(held.limit(1.4).apply(held.step, held.props, &normals), 0);
  EXPECT_NEAR(held.step.x_end(0, 2), 0.0, 1e-12);
  EXPECT_GT(held.step.x_end(0, 0), 0.1);  // it slid towards 1 along the body
  for (int c = 0; c < 3; ++c) {
    const int a = held.faces(0, c), b = held.faces(0, (c + 1) % 3);
    EXPECT_LE((held.step.x_end.row(a) - held.step.x_end.row(b)).norm(), 1.4 + 1e-6) << "edge " << c;
  }
  // v follows x_end.
  EXPECT_LT((held.step.x_end - (held.x + 0.01 * held.v)).cwiseAbs().maxCoeff(), 1e-12);
  // A move out of the body is kept: vertex 1 above 0, so pulling 0 towards it lifts 0 off.
  Triangle lifted;
  lifted.v.row(0) << -100.0, 0.0, 0.0;
  lifted.x.row(1) << 1.0, 0.0, 1.0;
  lifted.step.begin(lifted.x, lifted.v, 0.01);
  EXPECT_GT(lifted.limit(1.4).apply(lifted.step, lifted.props, &normals), 0);
  EXPECT_GT(lifted.step.x_end(0, 2), 0.01);
}

// A stretch left by something after the limit (CCD impulses, say) and not renewed relaxes
// towards the limit step after step instead of staying: the excess halves every step.
TEST(StrainLimit, AnUnforcedStretchRelaxesTowardsTheLimit) {
  Triangle t;
  t.x.row(1) << 3.0, 0.0, 0.0;  // edge (0, 1) at 3 m, (1, 2) at about 2.6 m
  double excess = 3.0 - 1.4;
  for (int step = 0; step < 12; ++step) {
    t.v.setZero();
    t.step.begin(t.x, t.v, 0.01);
    t.limit(1.4).apply(t.step, t.props);
    t.x = t.step.x_end;
    const double length = (t.x.row(1) - t.x.row(0)).norm();
    EXPECT_LE(length - 1.4, 0.5 * excess + 1e-9) << "step " << step;
    excess = length - 1.4;
  }
  for (int c = 0; c < 3; ++c)
    EXPECT_LT((t.x.row(t.faces(0, c)) - t.x.row(t.faces(0, (c + 1) % 3))).norm(), 1.4 + 1e-3);
}

// A ribbon of 12 unit squares (2 x 13 vertices, numbered column by column), the first column
// pinned, the last pulled 3 m in one 0.01 s step: the whole stretch lands on the last column's
// edges, and each Gauss-Seidel pass in the fixed edge order hands it one column further along.
// Four passes (the earlier default) stop with edges far over the limit; the default passes
// converge, and a second application finds nothing left to correct.
struct Ribbon {
  static constexpr int kColumns = 13;
  Faces faces{2 * (kColumns - 1), 3};
  std::vector<std::array<double, 3>> rest;
  Positions x{2 * kColumns, 3};
  Positions v = Positions::Zero(2 * kColumns, 3);
  ContactProperties props;
  CollisionStep step;
  Ribbon() {
    for (int c = 0; c < kColumns; ++c)
      for (int r = 0; r < 2; ++r) x.row(2 * c + r) << c, r, 0.0;
    for (int c = 0; c + 1 < kColumns; ++c) {
      const int a = 2 * c, b = 2 * c + 1, d = 2 * c + 2, e = 2 * c + 3;
      faces.row(2 * c) << a, d, e;
      faces.row(2 * c + 1) << a, e, b;
    }
    for (Eigen::Index f = 0; f < faces.rows(); ++f) {
      std::array<double, 3> lengths{};
      for (int k = 0; k < 3; ++k) lengths[k] = (x.row(faces(f, k)) - x.row(faces(f, (k + 1) % 3))).norm();
      rest.push_back(lengths);
    }
    props.inverse_mass.assign(2 * kColumns, 1.0);
    props.inverse_mass[0] = props.inverse_mass[1] = 0.0;
    props.thickness.assign(2 * kColumns, 0.002);
    props.friction.assign(2 * kColumns, 0.0);
    v.row(2 * kColumns - 2) << 300.0, 0.0, 0.0;
    v.row(2 * kColumns - 1) << 300.0, 0.0, 0.0;
    step.begin(x, v, 0.01);
  }
  double worst_strain() const {
    double worst = 0.0;
    for (Eigen::Index f = 0; f < faces.rows(); ++f)
      for (int k = 0; k < 3; ++k) {
        const double length = (step.x_end.row(faces(f, k)) - step.x_end.row(faces(f, (k + 1) % 3))).norm();
        worst = std::max(worst, length / rest[f][k]);
      }
    return worst;
  }
};

TEST(StrainLimit, APullSpreadsAlongARibbonUntilEveryEdgeIsWithinTheLimit) {
  Ribbon four;
  const StrainLimit four_passes(four.faces, four.rest, 1.4, 4);
  EXPECT_GT(four_passes.apply(four.step, four.props), 0);
  EXPECT_GT(four.worst_strain(), 1.45);
  EXPECT_GT(four_passes.apply(four.step, four.props), 0);  // work left over

  Ribbon converged;
  const StrainLimit default_passes(converged.faces, converged.rest, 1.4);
  EXPECT_GT(default_passes.apply(converged.step, converged.props), 0);
  EXPECT_LE(converged.worst_strain(), 1.4 + 1e-9);
  EXPECT_EQ(default_passes.apply(converged.step, converged.props), 0);
  // The pinned column stays; the pulled one came back.
  EXPECT_EQ(converged.step.x_end.row(0).norm(), 0.0);
  EXPECT_LT(converged.step.x_end(2 * Ribbon::kColumns - 2, 0), 12.0 + 3.0);
}

}  // namespace
}  // namespace weft
