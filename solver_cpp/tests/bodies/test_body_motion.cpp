// The step-size estimate at a frame's start: a body's thickness, and how many halvings its
// motion through the cloth it meets asks for (bodies/body_motion.h).
#include <gtest/gtest.h>

#include "weft/bodies/body_motion.h"

namespace weft {
namespace {

// A closed box (outward faces) from lo to hi.
void box(const Vec3& lo, const Vec3& hi, Positions& x, Faces& faces) {
  x.resize(8, 3);
  for (int k = 0; k < 8; ++k)
    x.row(k) << ((k & 1) ? hi.x() : lo.x()), ((k & 2) ? hi.y() : lo.y()), ((k & 4) ? hi.z() : lo.z());
  faces.resize(12, 3);
  faces << 0, 2, 1, 1, 2, 3,  // z = lo
      4, 5, 6, 5, 7, 6,       // z = hi
      0, 1, 4, 1, 5, 4,       // y = lo
      2, 6, 3, 3, 6, 7,       // y = hi
      0, 4, 2, 2, 4, 6,       // x = lo
      1, 3, 5, 3, 7, 5;       // x = hi
}

// An n x n sheet of side `width` in the z = 0 plane, centred on the origin, at rest.
Positions sheet(int n, double width) {
  Positions x(n * n, 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) x.row(i * n + j) << width * (j / (n - 1.0) - 0.5), width * (i / (n - 1.0) - 0.5), 0.0;
  return x;
}

Positions moved(const Positions& x, const Vec3& by) {
  Positions out = x;
  out.rowwise() += by.transpose();
  return out;
}

TEST(BodyMotion, ThicknessIsTwiceTheVolumeOverTheArea) {
  Positions x;
  Faces faces;
  box(Vec3(0, 0, 0), Vec3(2, 2, 2), x, faces);
  EXPECT_NEAR(body_thickness(x, faces), 2.0 / 3.0, 1e-12);  // a cube of side 2: 2 * 8 / 24
  box(Vec3(0, 0, 0), Vec3(1, 1, 0.01), x, faces);
  EXPECT_NEAR(body_thickness(x, faces), 0.01, 0.0003);  // a plate: about its thickness
  box(Vec3(0, 0, 0), Vec3(1, 0.02, 0.02), x, faces);
  EXPECT_NEAR(body_thickness(x, faces), 0.01, 0.0003);  // a bar: about half its width (a tube's radius)
  EXPECT_TRUE(closed_surface(faces));
  const Faces open = faces.topRows(11);
  EXPECT_FALSE(closed_surface(open));
}

// A 2 cm cube (thickness 2/3 cm) 10 cm behind the middle of a sheet at rest, crossing it along z.
struct Crossing {
  Positions cloth = sheet(21, 0.5);
  Positions cloth_v = Positions::Zero(21 * 21, 3);
  Positions bar_start, bar_end;
  Faces bar_faces;
  double thickness = 0.0;
  Crossing(double travel, const Vec3& offset = Vec3::Zero()) {
    box(Vec3(-0.01, -0.01, -0.11) + offset, Vec3(0.01, 0.01, -0.09) + offset, bar_start, bar_faces);
    bar_end = moved(bar_start, Vec3(0, 0, travel));
    thickness = body_thickness(bar_start, bar_faces);
  }
  int halvings(int max_halvings, int substeps = 4) const {
    const std::vector<BodyMotion> bodies{{&bar_start, &bar_end, thickness}};
    return motion_halvings(cloth, cloth_v, 0.004, 0.025, bodies, substeps, 1.0 / 24.0, max_halvings);
  }
};

TEST(BodyMotion, ABodyMovingFasterThanItsThicknessThroughClothAsksForHalvings) {
  const Crossing fast(0.2);  // 5 cm per substep: 7.5 thicknesses
  EXPECT_EQ(fast.halvings(1), 1);
  EXPECT_EQ(fast.halvings(2), 2);
  EXPECT_EQ(fast.halvings(5), 3);  // 7.5 / 2^3 < 1
  EXPECT_EQ(fast.halvings(5, 8), 2);  // twice the substeps: one halving fewer
  EXPECT_EQ(fast.halvings(0), 0);
  const Crossing slow(0.02);  // 0.5 cm per substep
  EXPECT_EQ(slow.halvings(2), 0);
}

TEST(BodyMotion, OnlyClothTheBodyMeetsAndOnlyRelativeMotionCount) {
  // Moving away from the sheet, or passing 4 cm beside its edge: it meets no cloth.
  EXPECT_EQ(Crossing(-0.2).halvings(2), 0);
  EXPECT_EQ(Crossing(0.2, Vec3(0, 0.3, 0)).halvings(2), 0);
  EXPECT_EQ(Crossing(0.2, Vec3(0, 0.25, 0)).halvings(2), 2);  // across the edge row
  // Cloth carried at the bar's speed: no relative motion.
  Crossing carried(0.2);
  carried.cloth_v.col(2).setConstant(0.2 * 24.0);
  EXPECT_EQ(carried.halvings(2), 0);
  // A still bar that cloth falls onto as fast asks as a moving bar does.
  Crossing still(0.0, Vec3(0, 0, 0.08));  // the cube 1 cm below the sheet, which moves towards -z
  still.cloth_v.col(2).setConstant(-0.2 * 24.0);
  EXPECT_EQ(still.halvings(2), 2);
  // Without a thickness (an open body) nothing is asked.
  const std::vector<BodyMotion> open{{&still.bar_start, &still.bar_end, 0.0}};
  EXPECT_EQ(motion_halvings(still.cloth, still.cloth_v, 0.004, 0.025, open, 4, 1.0 / 24.0, 2), 0);
}

}  // namespace
}  // namespace weft
