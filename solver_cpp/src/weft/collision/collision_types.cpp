#include "weft/collision/collision_types.h"

#include <algorithm>

namespace weft {

void CollisionTelemetry::add(const CollisionTelemetry& o) {
  broad_phase_seconds += o.broad_phase_seconds;
  broad_phase_pairs += o.broad_phase_pairs;
  contact_constraints += o.contact_constraints;
  released_contacts += o.released_contacts;
  strain_limited_edges += o.strain_limited_edges;
  friction_spreads += o.friction_spreads;
  proximity_seconds += o.proximity_seconds;
  ccd_seconds += o.ccd_seconds;
  response_seconds += o.response_seconds;
  intersection_seconds += o.intersection_seconds;
  self_collision_seconds += o.self_collision_seconds;
  contact_constraints_seconds += o.contact_constraints_seconds;
  gia_seconds += o.gia_seconds;
  gia_coloured_vertices = std::max(gia_coloured_vertices, o.gia_coloured_vertices);
  gia_pushed_vertices += o.gia_pushed_vertices;
  gia_paths = std::max(gia_paths, o.gia_paths);
  gia_body_coloured_faces = std::max(gia_body_coloured_faces, o.gia_body_coloured_faces);
  gia_pinched_body_pairs = std::max(gia_pinched_body_pairs, o.gia_pinched_body_pairs);
  gia_pinched_part_pairs = std::max(gia_pinched_part_pairs, o.gia_pinched_part_pairs);
  gia_gripped_vertices += o.gia_gripped_vertices;
  gia_self_coloured_vertices = std::max(gia_self_coloured_vertices, o.gia_self_coloured_vertices);
  gia_self_paths = std::max(gia_self_paths, o.gia_self_paths);
  proximity_pairs += o.proximity_pairs;
  ccd_candidates += o.ccd_candidates;
  ccd_hits += o.ccd_hits;
  impact_zones += o.impact_zones;
  iterations += o.iterations;
  unresolved += o.unresolved;
}

}  // namespace weft
