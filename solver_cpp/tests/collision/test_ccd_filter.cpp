// The CCD pre-filter (stays_apart, ccd.h): whenever it says a pair stays apart, the pair's
// distance stays above the gap at every sampled time and the conservative CCD query finds no
// contact; it settles resting and sliding contact, never a crossing.
#include <gtest/gtest.h>

#include <limits>
#include <random>

#include "weft/collision/ccd.h"
#include "weft/geometry/closest_points.h"

namespace weft {
namespace {

using Points = std::array<Vec3, 4>;

double distance_at(const Points& s, const Points& e, bool edge_edge, double t) {
  Points x;
  for (int i = 0; i < 4; ++i) x[i] = s[i] + t * (e[i] - s[i]);
  if (edge_edge) {
    double u, v;
    return segment_segment_distance(x[0], x[1], x[2], x[3], u, v);
  }
  Vec3 bary;
  return point_triangle_distance(x[0], x[1], x[2], x[3], bary);
}

TEST(CcdFilter, ApartVerdictsAreNeverWrong) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const double gap = 1e-3;
  for (bool edge_edge : {false, true}) {
    int apart = 0;
    constexpr int kQueries = 4000;
    for (int q = 0; q < kQueries; ++q) {
      Points s, e;
      const Vec3 drift(unit(rng), unit(rng), unit(rng));  // shared motion, up to 2 cm
      for (int i = 0; i < 4; ++i) {
        s[i] = 0.01 * Vec3(unit(rng), unit(rng), unit(rng));
        if (i == 0 || (edge_edge && i == 1)) s[i].z() += 0.006;  // first feature above the second
        e[i] = s[i] + 0.02 * drift + 0.004 * Vec3(unit(rng), unit(rng), unit(rng));
      }
      if (!stays_apart(s, e, edge_edge, gap)) continue;
      ++apart;
      for (int k = 0; k <= 200; ++k)
        ASSERT_GT(distance_at(s, e, edge_edge, k / 200.0), gap) << "query " << q << " t " << k / 200.0;
      // CCD's separation is an infinity-norm one (|F|_inf <= gap / 2 implies a Euclidean
      // distance below gap): it must find nothing either.
      CcdOptions options;
      options.minimum_separation = 0.5 * gap;
      const CcdResult r = edge_edge ? edge_edge_ccd(s, e, options) : vertex_triangle_ccd(s, e, options);
      EXPECT_FALSE(r.hit) << "query " << q;
    }
    // Not vacuous: a good share of these near queries is settled by the filter.
    EXPECT_GT(apart, kQueries / 10) << (edge_edge ? "edge-edge" : "vertex-triangle");
  }
}

TEST(CcdFilter, SettlesSlidingContactButNotACrossing) {
  // A vertex 3 mm above a triangle, sliding 3 cm across it during the step: the start distance
  // minus the motion bound says nothing, the plane distance stays 3 mm.
  const Points tri_s = {Vec3(0.0, 0.0, 0.003), Vec3(-0.05, -0.05, 0.0), Vec3(0.05, -0.05, 0.0), Vec3(0.0, 0.05, 0.0)};
  Points tri_e = tri_s;
  tri_e[0] += Vec3(0.03, 0.0, 0.0);
  EXPECT_TRUE(stays_apart(tri_s, tri_e, false, 3e-4));
  // The same vertex ending 1 mm below the triangle's plane.
  tri_e[0].z() = -0.001;
  EXPECT_FALSE(stays_apart(tri_s, tri_e, false, 3e-4));
  // Two edges crossing 2 mm apart, both moving together by 5 cm: apart; one moving through the
  // other's line: not.
  const Points ee_s = {Vec3(-0.02, 0.0, 0.002), Vec3(0.02, 0.0, 0.002), Vec3(0.0, -0.02, 0.0), Vec3(0.0, 0.02, 0.0)};
  Points ee_e = ee_s;
  for (Vec3& p : ee_e) p += Vec3(0.05, 0.01, 0.0);
  EXPECT_TRUE(stays_apart(ee_s, ee_e, true, 3e-4));
  ee_e[0].z() = ee_e[1].z() = -0.002;
  EXPECT_FALSE(stays_apart(ee_s, ee_e, true, 3e-4));
  // Parallel edges (no line distance to speak of) and non-finite input are left to CCD.
  const Points parallel = {Vec3(0, 0, 0.002), Vec3(1, 0, 0.002), Vec3(0, 0, 0), Vec3(1, 0, 0)};
  EXPECT_FALSE(stays_apart(parallel, parallel, true, 3e-4));
  Points bad = ee_s;
  bad[2].x() = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(stays_apart(ee_s, bad, true, 3e-4));
}

}  // namespace
}  // namespace weft
