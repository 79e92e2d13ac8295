#include "weft/collision/contact_impulse.h"

#include <algorithm>

#include "weft/geometry/aabb_tree.h"
#include "weft/geometry/closest_points.h"

namespace weft {

double pair_weights(const std::array<Vec3, 4>& x, bool edge_edge, std::array<double, 4>& w) {
  if (edge_edge) {
    double s, t;
    const double d = segment_segment_distance(x[0], x[1], x[2], x[3], s, t);
    w = {1.0 - s, s, -(1.0 - t), -t};
    return d;
  }
  Vec3 bary;
  const double d = point_triangle_distance(x[0], x[1], x[2], x[3], bary);
  w = {1.0, -bary[0], -bary[1], -bary[2]};
  return d;
}

bool boxes_within(const std::array<Vec3, 4>& s, const std::array<Vec3, 4>& e, bool edge_edge, double gap) {
  const int split = edge_edge ? 2 : 1;
  Aabb first, second;
  for (int i = 0; i < 4; ++i) {
    Aabb& box = i < split ? first : second;
    box.expand(s[i]);
    box.expand(e[i]);
  }
  first.inflate(gap);
  return first.overlaps(second);
}

Vec3 combine(const std::array<Vec3, 4>& x, const std::array<double, 4>& w) {
  return w[0] * x[0] + w[1] * x[1] + w[2] * x[2] + w[3] * x[3];
}

Vec3 contact_normal(const std::array<Vec3, 4>& x, bool edge_edge, const Vec3& gap, double distance, double scale,
                    const Vec3& side) {
  if (distance > 1e-9 * scale) return gap / distance;
  Vec3 n = edge_edge ? Vec3((x[1] - x[0]).cross(x[3] - x[2])) : Vec3((x[2] - x[1]).cross(x[3] - x[1]));
  const double norm = n.norm();
  if (norm > 0.0) {
    n /= norm;
    return n.dot(side) < 0.0 ? Vec3(-n) : n;
  }
  const double side_norm = side.norm();
  return side_norm > 0.0 ? Vec3(side / side_norm) : Vec3(0, 0, 1);
}

void apply_impulse(CollisionStep& step, const ContactProperties& props, const FeaturePair& pair,
                   const std::array<double, 4>& w, const Vec3& n, double delta_vn, double friction) {
  double denominator = 0.0;
  Vec3 v_rel = Vec3::Zero();
  for (int i = 0; i < 4; ++i) {
    denominator += w[i] * w[i] * props.inverse_mass_of(pair.point[i]);
    v_rel += w[i] * step.velocity_of(pair.point[i], pair.body);
  }
  if (!(denominator > 0.0)) return;
  const Vec3 v_t = v_rel - n.dot(v_rel) * n;
  const double vt_norm = v_t.norm();
  Vec3 delta = delta_vn * n;
  if (friction > 0.0 && vt_norm > 0.0) delta += (std::max(0.0, 1.0 - friction * delta_vn / vt_norm) - 1.0) * v_t;
  for (int i = 0; i < 4; ++i) {
    const int p = pair.point[i];
    if (p < 0 || props.inverse_mass[p] == 0.0) continue;
    step.v->row(p) += (props.inverse_mass[p] * w[i] / denominator) * delta.transpose();
    step.moved(p);
    step.changed[p] = 1;
  }
}

}  // namespace weft
