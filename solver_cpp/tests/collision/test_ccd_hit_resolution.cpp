// CcdOptions::hit_time_resolution (ccd.h): a box no longer than the resolution with a corner
// certainly within the minimum separation ends the search. It changes no verdict (such a corner
// is a true contact, which the full search reports too), the time of impact stays a lower bound
// and is at most one resolution earlier than the full search's, and contacts cost far fewer
// boxes.
#include <gtest/gtest.h>

#include <random>

#include "weft/collision/ccd.h"

namespace weft {
namespace {

using Points = std::array<Vec3, 4>;

TEST(CcdHitResolution, SameVerdictsEarlierBoundedTimesFewerBoxes) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  constexpr double kResolution = 1.0 / 16.0;
  for (bool edge_edge : {false, true}) {
    int hits = 0;
    long exact_boxes = 0, coarse_boxes = 0;
    constexpr int kQueries = 3000;
    for (int q = 0; q < kQueries; ++q) {
      // Features 1 cm across; the first one starts 2 mm above the second and moves down by 1
      // to 5 mm, so many of the queries come into contact.
      // For vertex-triangle the triangle is the larger one, so the vertex is mostly above it.
      const Vec3 corner[4] = {Vec3(0, 0, 0), Vec3(-1, -1, 0), Vec3(1.5, -1, 0), Vec3(-1, 1.5, 0)};
      Points s, e;
      for (int i = 0; i < 4; ++i) {
        const Vec3 jitter(unit(rng), unit(rng), 0.1 * unit(rng));
        s[i] = 0.01 * (edge_edge ? jitter : Vec3(corner[i] + 0.3 * jitter));
        const bool first = i == 0 || (edge_edge && i == 1);
        if (first) s[i].z() += 0.002;
        e[i] = s[i] + 0.002 * Vec3(unit(rng), unit(rng), first ? unit(rng) - 1.5 : 0.5 * unit(rng));
      }
      CcdOptions exact;
      exact.minimum_separation = 1e-4;
      exact.absolute_tolerance = 1e-5;
      CcdOptions coarse = exact;
      coarse.hit_time_resolution = kResolution;
      const CcdResult a = edge_edge ? edge_edge_ccd(s, e, exact) : vertex_triangle_ccd(s, e, exact);
      const CcdResult b = edge_edge ? edge_edge_ccd(s, e, coarse) : vertex_triangle_ccd(s, e, coarse);
      ASSERT_EQ(a.hit, b.hit) << "query " << q;
      EXPECT_LE(b.boxes, a.boxes) << "query " << q;
      if (!a.hit) continue;
      ++hits;
      exact_boxes += a.boxes;
      coarse_boxes += b.boxes;
      EXPECT_LE(b.toi, a.toi) << "query " << q;  // boxes are examined earliest first
      EXPECT_GE(b.toi, a.toi - kResolution) << "query " << q;
    }
    // Not vacuous: many contacts, and they got much cheaper.
    EXPECT_GT(hits, kQueries / 10) << (edge_edge ? "edge-edge" : "vertex-triangle");
    EXPECT_LT(2 * coarse_boxes, exact_boxes) << (edge_edge ? "edge-edge" : "vertex-triangle");
  }
}

TEST(CcdHitResolution, ContactAtTheStartIsReportedAtOnce) {
  // A vertex already within the minimum separation of a triangle at the start: a contact at
  // t = 0 whatever the motion, found as soon as a box corner lands near it, where the full
  // search narrows the box to the tolerance first.
  const Points s = {Vec3(0.2, 0.2, 5e-5), Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)};
  Points e = s;
  e[0].z() = 0.5;  // leaving
  CcdOptions options;
  options.minimum_separation = 1e-4;
  options.hit_time_resolution = 1.0;
  const CcdResult r = vertex_triangle_ccd(s, e, options);
  EXPECT_TRUE(r.hit);
  EXPECT_EQ(r.toi, 0.0);
  CcdOptions exact = options;
  exact.hit_time_resolution = 0.0;
  const CcdResult full = vertex_triangle_ccd(s, e, exact);
  EXPECT_TRUE(full.hit);
  EXPECT_EQ(full.toi, 0.0);
  EXPECT_LT(r.boxes, full.boxes);
  // A corner outside the triangle (u + v > 1) is no evidence: the same vertex beside the
  // hypotenuse's far side, 1 cm out, is no contact.
  Points outside = s;
  outside[0] = Vec3(0.51, 0.51, 5e-5);
  Points outside_end = outside;
  outside_end[0].z() = 0.5;
  EXPECT_FALSE(vertex_triangle_ccd(outside, outside_end, options).hit);
}

}  // namespace
}  // namespace weft
