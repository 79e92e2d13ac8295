// Membrane element kernels: no force at rest or under rotation, Hooke's law for a stretch.
#include <gtest/gtest.h>

#include "weft/forces/forces.h"

using namespace weft;

TEST(Forces, RestStateHasNoForce) {
  Mat2 dm;
  dm << 1, 0, 0, 1;
  const MembraneResult m = membrane_element(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), dm.inverse(), 0.5, 100.0,
                                            80.0, 10.0, false);
  EXPECT_NEAR(m.energy, 0.0, 1e-15);
  EXPECT_NEAR(m.gradient.norm(), 0.0, 1e-12);
  // Rigid rotation of the triangle: still no force.
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  const MembraneResult rotated =
      membrane_element(r * Vec3(0, 0, 0), r * Vec3(1, 0, 0), r * Vec3(0, 1, 0), dm.inverse(), 0.5, 100.0, 80.0, 10.0, false);
  EXPECT_NEAR(rotated.gradient.norm(), 0.0, 1e-12);
}

TEST(Forces, StretchForceMatchesHookeanStrip) {
  // Stretch along u by 10%: energy = A k/2 (0.1)^2.
  Mat2 dm;
  dm << 1, 0, 0, 1;
  const MembraneResult m = membrane_element(Vec3(0, 0, 0), Vec3(1.1, 0, 0), Vec3(0, 1, 0), dm.inverse(), 0.5, 100.0,
                                            80.0, 0.0, false);
  EXPECT_NEAR(m.energy, 0.5 * 100.0 / 2 * 0.01, 1e-12);
}
