#include "weft/collision/collision_step.h"

#include <algorithm>
#include <stdexcept>

namespace weft {

ContactProperties ContactProperties::from_faces(const Faces& faces, const VectorX& face_thickness,
                                                const VectorX& face_friction, const std::vector<double>& vertex_mass,
                                                const std::vector<int>& pinned_vertices,
                                                const std::vector<double>& body_offset) {
  ContactProperties c;
  c.body_offset = body_offset;
  const int vertex_count = static_cast<int>(vertex_mass.size());
  c.inverse_mass.resize(vertex_count);
  for (int i = 0; i < vertex_count; ++i) c.inverse_mass[i] = 1.0 / vertex_mass[i];
  for (int p : pinned_vertices) c.inverse_mass[p] = 0.0;
  c.thickness.assign(vertex_count, 0.0);
  c.friction.assign(vertex_count, 0.0);
  for (int f = 0; f < faces.rows(); ++f) {
    const double th = face_thickness.size() ? face_thickness[f] : kDefaultThickness;
    const double mu = face_friction.size() ? face_friction[f] : kDefaultFriction;
    if (!(th > 0.0)) throw std::invalid_argument("collision thickness must be positive");
    for (int k = 0; k < 3; ++k) {
      c.thickness[faces(f, k)] = std::max(c.thickness[faces(f, k)], th);
      c.friction[faces(f, k)] = std::max(c.friction[faces(f, k)], mu);
    }
  }
  c.default_thickness = *std::max_element(c.thickness.begin(), c.thickness.end());
  return c;
}

double ContactProperties::pair_thickness(const FeaturePair& pair) const {
  double th = 0.0;
  for (int p : pair.point)
    if (p >= 0) th = std::max(th, thickness[p]);
  return (th > 0.0 ? th : default_thickness) + (pair.body >= 0 && !body_offset.empty() ? body_offset[pair.body] : 0.0);
}

double ContactProperties::pair_friction(const FeaturePair& pair) const {
  double mu = 0.0;
  for (int p : pair.point)
    if (p >= 0) mu = std::max(mu, friction[p]);
  return mu;
}

}  // namespace weft
