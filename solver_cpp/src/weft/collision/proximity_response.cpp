#include "weft/collision/proximity_response.h"

#include "weft/collision/contact_impulse.h"
#include "weft/common/timer.h"

namespace weft {

int ProximityResponse::apply(CollisionStep& step, const ContactProperties& props, CollisionTelemetry& frame) const {
  const Timer timer;
  int count = 0;
  for (const FeaturePair& pair : step.proximity_pairs) {
    const double th = props.pair_thickness(pair);
    std::array<Vec3, 4> s;
    for (int i = 0; i < 4; ++i) s[i] = step.start_of(pair.point[i], pair.body);
    if (!boxes_within(s, s, pair.edge_edge, th)) continue;
    std::array<double, 4> w;
    const double d = pair_weights(s, pair.edge_edge, w);
    if (d >= th) continue;
    Vec3 v_rel = Vec3::Zero();
    for (int i = 0; i < 4; ++i) v_rel += w[i] * step.velocity_of(pair.point[i], pair.body);
    const Vec3 n = contact_normal(s, pair.edge_edge, combine(s, w), d, th, -v_rel);
    const double vn = n.dot(v_rel);
    const double target = kRepulsionRate * (th - d) / step.h;
    if (vn < target) {
      apply_impulse(step, props, pair, w, n, target - vn, props.pair_friction(pair));
      ++count;
    }
  }
  frame.proximity_pairs += count;
  frame.proximity_seconds += timer.seconds();
  return count;
}

}  // namespace weft
