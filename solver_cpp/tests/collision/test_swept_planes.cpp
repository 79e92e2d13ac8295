// The broad phase's plane test (swept_planes.h) keeps every pair CCD can report: CCD's minimum
// separation is in the infinity norm of the gap vector, so a vertex 1.5 gaps from a triangle
// whose normal is the diagonal (1, 1, 1) is a CCD contact (0.87 gaps in that norm) and must not
// be kept out by the triangle's plane, while one 2 gaps away (1.15 gaps) is.
#include <gtest/gtest.h>

#include <cmath>

#include "weft/collision/ccd.h"
#include "weft/collision/swept_planes.h"

namespace weft {
namespace {

TEST(SweptPlanes, CcdListsKeepThePairsWithinTheGapInCcdsNorm) {
  const double gap = 1e-4;
  const Vec3 n = Vec3(1, 1, 1).normalized();
  // Triangle A in the plane through the origin with normal n; B a small triangle above A's
  // centroid whose corners all sit `height` along n (B's own plane is parallel).
  const Vec3 u = Vec3(1, -1, 0).normalized(), w = n.cross(u);
  Faces faces(2, 3);
  faces << 0, 1, 2, 3, 4, 5;
  auto positions = [&](double height) {
    Positions x(6, 3);
    const Vec3 a[3] = {-0.01 * u - 0.01 * w, 0.01 * u - 0.01 * w, 0.01 * w};
    for (int k = 0; k < 3; ++k) {
      x.row(k) = a[k].transpose();
      x.row(3 + k) = (0.001 * a[k] + height * n).transpose();
    }
    return x;
  };
  for (const auto& [height, contact] : {std::pair{1.5 * gap, true}, std::pair{2.0 * gap, false}}) {
    const Positions x = positions(height);
    SweptPlanes planes;
    planes.compute(faces, x, x, 1);
    PlaneSides sides;
    // CCD itself: B's corner 3 against A, still over the step.
    const std::array<Vec3, 4> s = {row3(x, 3), row3(x, 0), row3(x, 1), row3(x, 2)};
    CcdOptions options;
    options.minimum_separation = gap;
    EXPECT_EQ(vertex_triangle_ccd(s, s, options).hit, contact) << height;
    // The CCD lists' plane test keeps the pair exactly when CCD can report it.
    EXPECT_EQ(triangles_apart(planes, 0, faces, x, x, planes, 1, faces, x, x, gap, false, sides), !contact) << height;
    // The proximity list's test (Euclidean, its response's distance) keeps both out.
    EXPECT_TRUE(triangles_apart(planes, 0, faces, x, x, planes, 1, faces, x, x, gap, true, sides)) << height;
  }
}

}  // namespace
}  // namespace weft
