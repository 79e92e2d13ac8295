// Forward-mode dual numbers (the exact bending Hessian is built on them).
#include <gtest/gtest.h>

#include "weft/common/dual.h"

using namespace weft;

TEST(Dual, ProductQuotientAndSqrtDerivatives) {
  using D = Dual<3>;
  const D x = D::variable(2.0, 0), y = D::variable(3.0, 1), z = D::variable(4.0, 2);
  const D f = x * y / sqrt(z);  // 2*3/2 = 3
  EXPECT_DOUBLE_EQ(f.v, 3.0);
  EXPECT_DOUBLE_EQ(f.d[0], 3.0 / 2.0);            // y / sqrt(z)
  EXPECT_DOUBLE_EQ(f.d[1], 2.0 / 2.0);            // x / sqrt(z)
  EXPECT_DOUBLE_EQ(f.d[2], -0.5 * 6.0 / 8.0);     // -x y / (2 z^1.5)
}
