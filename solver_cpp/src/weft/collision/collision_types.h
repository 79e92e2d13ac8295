// Settings, telemetry and feature pairs of the collision stage (collision_system.h).
#pragma once

#include <array>
#include <vector>

#include "weft/common/types.h"

namespace weft {

struct CollisionSettings {
  bool enabled = false;                 // master switch: no collision stage at all when false
  bool ccd = true;                      // continuous detection and the fail-safe
  std::vector<char> face_collide;       // per cloth face: collides with bodies (empty: all)
  std::vector<char> face_self_collide;  // per cloth face: cloth/cloth (empty: none)
  std::vector<char> body_collide;       // per body (empty: all)
  // Per body: the articulated character it is a part of (-1 or empty: its own). Parts of one
  // character may overlap at joints; their overlap is never a body/body pinch (body_pinch.h),
  // their surfaces closing on cloth are (part_pinch).
  std::vector<int> body_group;
  VectorX face_thickness;               // per cloth face, m (empty: 0.002)
  // Per body: extra separation the cloth keeps from it, m, added to the cloth's thickness (a
  // body's "outer thickness"; empty: 0 for all).
  std::vector<double> body_offset;
  VectorX face_friction;                // per cloth face (empty: 0.3)
  int ccd_iterations = 8;               // impulse passes before impact zones
  int zone_iterations = 100;            // impact-zone passes (each grows or merges zones)
  bool count_intersections = true;      // exact intersection count at every frame end
  // Cloth/body contacts as constraints of the filtered solve (contact_constraints.h), released
  // by the sign of their impulse. Off only to compare (tests, benchmarks).
  bool contact_constraints = true;
  // Global intersection analysis (docs/intersection-analysis.md): against closed bodies and,
  // with self-collision, cloth/cloth untangling (cloth_untangling.h). 0 off, 1 on with body/body
  // pinch tracking, -1 (auto) on without it: the recovery runs only in steps that may start in
  // intersection, so a clean shot pays one analysis.
  int gia = 0;
  // Body/body pinch states (body_pinch.h) when gia is 1 and two or more bodies collide: CCD off
  // for cloth where two bodies intersect each other. Off only to compare (tests, diagnosis).
  bool body_pinch = true;
  // Pinches between parts of one character (gia on or auto, two or more colliding parts in a
  // group; body_pinch.h, part_gap.h): CCD off for cloth where two parts' surfaces face each
  // other closer than two cloth thicknesses. Off only to compare (tests, benchmarks).
  bool part_pinch = true;
  // While pinches, cloth in intersection (with a body or itself) or pairs left unresolved hold
  // the collision stage off its clean state, the contact constraints stay on for the cloth away
  // from them (collision_system.h, aside_local_); off: all cloth/body contact goes to the
  // impulses meanwhile. Off only to compare.
  bool local_aside = true;
  // Normal-cone culling of self-collision pairs inside patches that cannot touch themselves
  // (self_culling.h). Off only to compare (tests, benchmarks).
  bool self_culling = true;
  // Strain limiting before CCD (strain_limit.h): no step stretches an edge beyond this times its
  // rest length (<= 1: off).
  double max_strain = 1.4;
  // Kinetic friction that would stretch an edge past the strain limit acting on the held
  // vertices alone goes through the cloth's implicit response instead (collision_system.h,
  // spread_friction_with; needs the strain limit). Off only to compare (tests, benchmarks).
  bool spread_friction = true;
};

struct CollisionTelemetry {
  double broad_phase_seconds = 0.0;
  double proximity_seconds = 0.0;
  double ccd_seconds = 0.0;
  double response_seconds = 0.0;
  double intersection_seconds = 0.0;  // counting at frame end
  // What single features cost, parts of the sums above (so not in total_seconds again):
  double self_collision_seconds = 0.0;       // of broad_phase: cloth/cloth culling, traversal, expansion
  double contact_constraints_seconds = 0.0;  // of proximity: finding the contacts the solve constrains
  int broad_phase_pairs = 0;  // feature pairs the broad phase produced (proximity and CCD lists)
  int proximity_pairs = 0;
  int contact_constraints = 0;  // cloth/body contacts constrained in the solve, summed over substeps
  int released_contacts = 0;    // of those, released after the solve (the cloth pulled away)
  int strain_limited_edges = 0;  // edge corrections of the strain limit, summed over passes and substeps
  int friction_spreads = 0;      // substeps whose kinetic friction went through the cloth's response (respond)
  int ccd_candidates = 0;  // feature pairs a CCD pass examined (incremental passes: those with a moved vertex)
  int ccd_hits = 0;
  int impact_zones = 0;
  int iterations = 0;  // CCD impulse passes plus impact-zone passes
  int unresolved = 0;  // colliding pairs left when the zone budget ran out
  int intersections = -1;  // triangle pairs intersecting at frame end (-1: not counted)
  double gia_seconds = 0.0;     // cloth/body inside classification and recovery pushes
  int gia_coloured_vertices = 0;  // cloth vertices inside a closed body, most over the substeps
  int gia_pushed_vertices = 0;    // contour vertices pushed out, summed over substeps
  int gia_paths = 0;              // cloth/body intersection paths at a substep start, most over the frame
  int gia_body_coloured_faces = 0;  // body faces in intersection with the cloth, most over the frame
  int gia_pinched_body_pairs = 0;  // body pairs not free over a substep (body_pinch.h), most over the substeps
  int gia_pinched_part_pairs = 0;  // pairs of parts of one character closing on cloth (part_gap.h), most over them
  int gia_gripped_vertices = 0;    // cloth vertices moved with a body in a pinch, summed over substeps (not a column)
  int gia_self_coloured_vertices = 0;  // cloth/cloth GIA: coloured vertices, most over the substeps
  int gia_self_paths = 0;              // cloth/cloth GIA: intersection paths, most over the substeps
  double total_seconds() const {
    return broad_phase_seconds + proximity_seconds + ccd_seconds + response_seconds + intersection_seconds;
  }
  void add(const CollisionTelemetry& o);
};

// A feature pair: point indices >= 0 are cloth vertices, < 0 are body vertices -(1 + k) of
// body `body`. Vertex-triangle: (p, a, b, c); edge-edge: (a0, a1, b0, b1).
struct FeaturePair {
  std::array<int, 4> point;
  int body = -1;
  bool edge_edge = false;
  bool ccd = true;  // false: cloth in a body/body pinch region against one of the pair's bodies
};

}  // namespace weft
