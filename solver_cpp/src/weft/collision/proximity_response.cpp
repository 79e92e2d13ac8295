#include "weft/collision/proximity_response.h"

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
  }
  int count = 0;
  for (std::int64_t k = 0; k < n; ++k) {
    const FeaturePair& pair = step.proximity_pairs[k];
    const double th = props.pair_thickness(pair);
    const double d = distance[k];
    if (!(d < th)) continue;
    const std::array<double, 4>& w = weights[k];
    std::array<Vec3, 4> s;
    for (int i = 0; i < 4; ++i) s[i] = step.start_of(pair.point[i], pair.body);
    Vec3 v_rel = Vec3::Zero();
    for (int i = 0; i < 4; ++i) v_rel += w[i] * step.velocity_of(pair.point[i], pair.body);
    const Vec3 n_contact = contact_normal(s, pair.edge_edge, combine(s, w), d, th, -v_rel);
    const double vn = n_contact.dot(v_rel);
    const double target = kRepulsionRate * (th - d) / step.h;
    if (vn < target) {
      apply_impulse(step, props, pair, w, n_contact, target - vn, props.pair_friction(pair));
      ++count;
    }
  }
  frame.proximity_pairs += count;
  frame.proximity_seconds += timer.seconds();
  return count;
}

}  // namespace weft
