#include "weft/collision/ccd_response.h"

#include <algorithm>
#include <array>

#include "weft/collision/ccd.h"
#include "weft/collision/contact_impulse.h"
#include "weft/common/timer.h"
#include "weft/geometry/closest_points.h"

namespace weft {

namespace {
// Whether the pair's features stay more than `gap` apart over the whole step, by a bound that
// needs no root finding: moving every point by the first point's displacement changes no
// distance, and then the second feature (vertex-triangle: the triangle; edge-edge: both
// edges) moves no point farther than its corners' relative displacements, so the distance at
// any time is at least the start distance minus those displacements. Most pairs in resting
// contact (a thickness apart, moving together) are settled here instead of by CCD.
bool apart_all_step(const std::array<Vec3, 4>& s, const std::array<Vec3, 4>& e, bool edge_edge, double gap) {
  const Vec3 d0 = e[0] - s[0];
  double r[4] = {0.0, 0.0, 0.0, 0.0};
  for (int i = 1; i < 4; ++i) r[i] = ((e[i] - s[i]) - d0).norm();
  double start, motion;
  if (edge_edge) {
    double u, v;
    start = segment_segment_distance(s[0], s[1], s[2], s[3], u, v);
    motion = r[1] + std::max(r[2], r[3]);
  } else {
    Vec3 bary;
    start = point_triangle_distance(s[0], s[1], s[2], s[3], bary);
    motion = std::max({r[1], r[2], r[3]});
  }
  return start - motion > gap * (1.0 + 1e-9);
}
}  // namespace

namespace {
// Where a pair's features actually cross: no minimum separation, a tenth of it as the
// tolerance, so features that come that close count as crossing.
CcdOptions crossing_options(double thickness) {
  CcdOptions options;
  options.absolute_tolerance = 0.1 * kCcdSeparationFraction * thickness;
  options.max_boxes = 2000;
  return options;
}
}  // namespace

int CcdResponse::pass(CollisionStep& step, const ContactProperties& props, bool apply, std::vector<int>* hits,
                      bool incremental, CollisionTelemetry& frame) const {
  Timer timer;
  const int count = static_cast<int>(step.pairs.size());
  std::vector<char> dirty(step.changed.size(), 0);
  dirty.swap(step.changed);
  std::vector<char> hit(count, 0);
  std::vector<double> toi(count, 1.0);
  auto examined = [&](int k) {
    const FeaturePair& pair = step.pairs[k];
    return pair.ccd && (!incremental || std::any_of(pair.point.begin(), pair.point.end(),
                                                     [&](int p) { return p >= 0 && dirty[p]; }));
  };
  auto run = [&](int k) {
    const FeaturePair& pair = step.pairs[k];
    if (!examined(k)) return CcdResult{};
    std::array<Vec3, 4> s, e;
    for (int i = 0; i < 4; ++i) {
      s[i] = step.start_of(pair.point[i], pair.body);
      e[i] = step.end_of(pair.point[i], pair.body);
    }
    // Pairs whose points all move by the same displacement keep their shape: nothing new can
    // happen (this is what makes rigid impact zones final).
    const Vec3 d0 = e[0] - s[0];
    double spread = 0.0;
    for (int i = 1; i < 4; ++i) spread = std::max(spread, ((e[i] - s[i]) - d0).cwiseAbs().maxCoeff());
    const double th = props.pair_thickness(pair);
    if (spread <= 1e-9 * th) return CcdResult{};
    CcdOptions options;
    options.minimum_separation = kCcdSeparationFraction * th;
    options.absolute_tolerance = 0.1 * options.minimum_separation;
    options.max_boxes = 2000;
    options.hit_time_resolution = kCcdHitTimeResolution;
    if (!boxes_within(s, e, pair.edge_edge, options.minimum_separation)) return CcdResult{};
    const double gap = options.minimum_separation + 2.0 * options.absolute_tolerance;
    if (apart_all_step(s, e, pair.edge_edge, gap) || stays_apart(s, e, pair.edge_edge, gap)) return CcdResult{};
    // Detection only (what a motion, an impact zone's, leaves colliding): only a pair that
    // crosses is a collision of the motion; one that comes within the minimum separation, or
    // starts there, and never crosses is left to the next step's proximity response. Zone
    // motions squeeze layers (a bunched skirt between two closing legs): counting such pairs
    // made the zones that held them "unresolved", their steps were halved in vain, and the
    // zones grew over cloth that was never in danger.
    if (!apply) options = crossing_options(th);
    return pair.edge_edge ? edge_edge_ccd(s, e, options) : vertex_triangle_ccd(s, e, options);
  };
  int candidates = 0;
#pragma omp parallel for schedule(dynamic, 64) num_threads(threads_) reduction(+ : candidates)
  for (int k = 0; k < count; ++k) {
    candidates += examined(k) ? 1 : 0;
    const CcdResult r = run(k);
    hit[k] = r.hit;
    toi[k] = r.toi;
  }
  frame.ccd_candidates += candidates;
  incremental = false;  // the serial pass re-tests hits with the velocities of the moment
  frame.ccd_seconds += timer.seconds();
  timer.restart();
  // Where the pair's features actually cross (crossing_options).
  auto crossing = [&](const FeaturePair& pair) {
    std::array<Vec3, 4> s, e;
    for (int i = 0; i < 4; ++i) {
      s[i] = step.start_of(pair.point[i], pair.body);
      e[i] = step.end_of(pair.point[i], pair.body);
    }
    const CcdOptions options = crossing_options(props.pair_thickness(pair));
    return pair.edge_edge ? edge_edge_ccd(s, e, options) : vertex_triangle_ccd(s, e, options);
  };
  int found = 0;
  for (int k = 0; k < count; ++k) {
    if (!hit[k]) continue;
    const FeaturePair& pair = step.pairs[k];
    double t = toi[k];
    // Earlier impulses of this pass may have changed the pair: then it is tested again with the
    // velocities of the moment. A pair none of whose points they moved keeps its answer.
    const bool moved_in_pass = std::any_of(pair.point.begin(), pair.point.end(),
                                           [&](int p) { return p >= 0 && step.changed[p]; });
    if (apply && found > 0 && moved_in_pass) {
      const CcdResult r = run(k);
      if (!r.hit) continue;
      t = r.toi;
    }
    ++found;
    if (hits) hits->push_back(k);
    if (!apply) continue;
    const double th = props.pair_thickness(pair);
    std::array<Vec3, 4> s, e;
    for (int i = 0; i < 4; ++i) {
      s[i] = step.start_of(pair.point[i], pair.body);
      e[i] = step.end_of(pair.point[i], pair.body);
    }
    // The impulse linearised at time t of the step; false when the pair already separates
    // there fast enough.
    auto impulse_at = [&](double at) {
      std::array<Vec3, 4> x_toi;
      for (int i = 0; i < 4; ++i) x_toi[i] = s[i] + at * (e[i] - s[i]);
      std::array<double, 4> w;
      const double d = pair_weights(x_toi, pair.edge_edge, w);
      const Vec3 g0 = combine(s, w);
      Vec3 v_rel = Vec3::Zero();
      for (int i = 0; i < 4; ++i) v_rel += w[i] * step.velocity_of(pair.point[i], pair.body);
      const Vec3 side = g0.squaredNorm() > 0.0 ? g0 : Vec3(-v_rel);
      const Vec3 n = contact_normal(x_toi, pair.edge_edge, combine(x_toi, w), d, th, side);
      const double vn = n.dot(v_rel);
      double target = (kTargetSeparationFraction * th - n.dot(g0)) / step.h;
      if (step.ccd_iteration >= 2) target = std::max(target, 0.0);  // plain inelastic after two passes
      if (!(vn < target)) return false;
      apply_impulse(step, props, pair, w, n, target - vn, props.pair_friction(pair));
      return true;
    };
    if (impulse_at(t)) continue;
    // Linearised at the reported time (the pair was within the minimum separation already, or
    // the time is a coarse lower bound) the pair separates, yet it collides: it turns into
    // contact later in the step. Then the impulse is taken where the features actually meet.
    const CcdResult r = crossing(pair);
    // A pair that starts within the minimum separation, separates and never crosses is left
    // as it is (every test of it reports the start).
    if (!r.hit || (r.toi > t && impulse_at(r.toi))) continue;
    // A crossing no impulse clears: its points are marked changed all the same, so the next
    // pass tests the pair again instead of taking "no change" for "no collision"; a pair that
    // impulses cannot clear ends in an impact zone.
    for (int p : pair.point)
      if (p >= 0) step.changed[p] = 1;
  }
  frame.ccd_hits += found;
  frame.response_seconds += timer.seconds();
  return found;
}

}  // namespace weft
