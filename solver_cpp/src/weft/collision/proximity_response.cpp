#include "weft/collision/proximity_response.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include "weft/collision/contact_impulse.h"
#include "weft/common/timer.h"

namespace weft {

int ProximityResponse::apply(CollisionStep& step, const ContactProperties& props, CollisionTelemetry& frame,
                             int threads) const {
  const Timer timer;
  const std::int64_t n = static_cast<std::int64_t>(step.proximity_pairs.size());
  // Closest points of every pair at the step's start: they do not depend on the impulses.
  std::vector<double> distance(n, std::numeric_limits<double>::infinity());
  std::vector<std::array<double, 4>> weights(n);
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1 && n > 2048)
  for (std::int64_t k = 0; k < n; ++k) {
    const FeaturePair& pair = step.proximity_pairs[k];
    const double th = props.pair_thickness(pair);
    std::array<Vec3, 4> s;
    for (int i = 0; i < 4; ++i) s[i] = step.start_of(pair.point[i], pair.body);
    if (!boxes_within(s, s, pair.edge_edge, th)) continue;
    distance[k] = pair_weights(s, pair.edge_edge, weights[k]);
    // A cloth edge GIA's recovery moves out of a body's corner (CollisionStep::corner_cuts).
    if (pair.edge_edge && pair.body >= 0 && !step.corner_cuts.empty() &&
        std::binary_search(step.corner_cuts.begin(), step.corner_cuts.end(),
                           std::array<int, 3>{std::min(pair.point[0], pair.point[1]),
                                              std::max(pair.point[0], pair.point[1]), pair.body}))
      distance[k] = std::numeric_limits<double>::infinity();
  }
  // Gauss-Seidel sweeps over the pairs within the thickness: a pair's impulse changes the
  // velocities of its points, and so the normal velocities of the pairs that share them (friction
  // too), after those pairs were pushed; layers stacked on a body are pushed by both sides. One
  // sweep left about a thousand pairs per step of a skirt over a dress coming within CCD's
  // separation (found, and resolved far more slowly, by CCD); the sweeps stop when one pushes
  // nothing.
  std::vector<std::int64_t> within;
  for (std::int64_t k = 0; k < n; ++k)
    if (distance[k] < props.pair_thickness(step.proximity_pairs[k])) within.push_back(k);
  std::vector<char> pushed(within.size(), 0);
  // A pair's normal is the one its first sweep chose: for features touching (no distance to
  // take a direction from) it is oriented against the relative velocity, which that sweep's
  // push reverses.
  std::vector<Vec3> normal(within.size());
  for (int sweep = 0; sweep < sweeps_; ++sweep) {
    int pushes = 0;
    for (size_t j = 0; j < within.size(); ++j) {
      const std::int64_t k = within[j];
      const FeaturePair& pair = step.proximity_pairs[k];
      const double th = props.pair_thickness(pair);
      const double d = distance[k];
      const std::array<double, 4>& w = weights[k];
      Vec3 v_rel = Vec3::Zero();
      for (int i = 0; i < 4; ++i) v_rel += w[i] * step.velocity_of(pair.point[i], pair.body);
      if (sweep == 0) {
        std::array<Vec3, 4> s;
        for (int i = 0; i < 4; ++i) s[i] = step.start_of(pair.point[i], pair.body);
        normal[j] = contact_normal(s, pair.edge_edge, combine(s, w), d, th, -v_rel);
      }
      const Vec3& n_contact = normal[j];
      const double vn = n_contact.dot(v_rel);
      const double target = kRepulsionRate * (th - d) / step.h;
      if (vn < target) {
        apply_impulse(step, props, pair, w, n_contact, target - vn, props.pair_friction(pair));
        pushed[j] = 1;
        ++pushes;
      }
    }
    if (pushes == 0) break;
  }
  const int count = static_cast<int>(std::count(pushed.begin(), pushed.end(), 1));
  frame.proximity_pairs += count;
  frame.proximity_seconds += timer.seconds();
  return count;
}

}  // namespace weft
