// Per-step state of the collision stage (collision_system.h), shared by its parts and passed to
// them explicitly: the start-of-step positions x, the velocities v being corrected (the step
// moves x to x_end = x + h v), the collidable bodies' positions at the step's start and end,
// and the feature pairs the detection found. ContactProperties are the cloth's per-vertex
// contact data, fixed for a simulation.
#pragma once

#include <array>
#include <vector>

#include "weft/collision/collision_types.h"
#include "weft/collision/sharp_edges.h"
#include "weft/common/types.h"

namespace weft {

constexpr double kDefaultThickness = 0.002;
constexpr double kDefaultFriction = 0.3;
// CCD reports pairs that come closer than this fraction of the thickness (its broad phase
// looks no farther).
constexpr double kCcdSeparationFraction = 0.05;
// Contacts in the solve are looked for within this many thicknesses (contact_constraints.h):
// beyond one thickness the constraint only caps the approach speed, so a vertex arriving fast
// ends the step at the thickness instead of being caught by CCD.
constexpr double kContactBand = 2.0;

struct ContactProperties {
  std::vector<double> inverse_mass;         // per cloth vertex, 0 for pinned vertices
  std::vector<double> thickness, friction;  // per cloth vertex: most over its faces
  std::vector<double> body_offset;           // per body, added to the thickness against it (empty: 0)
  double default_thickness = kDefaultThickness;  // the largest vertex thickness

  // Per-face thickness and friction (empty: defaults) spread to the vertices; throws
  // std::invalid_argument for a thickness that is not positive.
  static ContactProperties from_faces(const Faces& faces, const VectorX& face_thickness, const VectorX& face_friction,
                                      const std::vector<double>& vertex_mass, const std::vector<int>& pinned_vertices,
                                      const std::vector<double>& body_offset = {});
  double inverse_mass_of(int p) const { return p >= 0 ? inverse_mass[p] : 0.0; }
  // The separation a cloth vertex keeps from a body (its thickness plus the body's offset).
  double body_separation(int vertex, int body) const {
    return thickness[vertex] + (body >= 0 && !body_offset.empty() ? body_offset[body] : 0.0);
  }
  double pair_thickness(const FeaturePair& pair) const;
  double pair_friction(const FeaturePair& pair) const;
};

struct CollisionStep {
  const Positions* x = nullptr;
  Positions* v = nullptr;
  Positions x_end;
  double h = 0.0;
  std::vector<Positions> body_start, body_end;  // per body (empty for bodies that do not collide)
  std::vector<FeaturePair> pairs;            // CCD candidates of the current pass (ContactDetection::collect)
  std::vector<FeaturePair> proximity_pairs;  // proximity candidates of the step (likewise)
  std::vector<char> changed;  // cloth vertices whose velocity changed since the last CCD pass
  // Per body, its edges sharp for the cloth and face normals at the step's start, as the
  // contact constraints found them (ContactConstraints::sharp_edges), through the whole step.
  // The proximity list is then found point by point (cloth vertices with body faces, body
  // corners with cloth faces) with edge/edge pairs only for the body edges that can reach a
  // cloth edge between vertices kept off: the sharp ones and the blunt ones pushing into the
  // cloth this step (SharpEdges::advancing); GIA's recovery finds with them the cloth edges that
  // cut a body's corner (SharpEdges::corner_cut). Null: the contact constraints did not run, and
  // the triangle traversal lists every pair of all three kinds.
  const std::vector<SharpEdges>* sharp_edges = nullptr;
  // With sharp_edges, per cloth vertex: no body face within its separation at the step's start
  // (ContactConstraints::clear_vertices); the point-by-point list skips such vertices.
  const std::vector<char>* clear_vertices = nullptr;
  int ccd_iteration = 0;      // CCD impulse pass within the step
  // The cloth edges GIA's recovery found cutting a body's corner this step, as (lower vertex,
  // higher vertex, body), sorted: it moves them out, and the proximity response leaves their
  // edge pairs with that body alone (pushed along their closest points, into the body, they
  // were carried with it).
  std::vector<std::array<int, 3>> corner_cuts;

  void begin(const Positions& x0, Positions& v0, double step) {
    x = &x0;
    v = &v0;
    h = step;
    x_end = x0 + step * v0;
    changed.assign(x0.rows(), 0);
    corner_cuts.clear();
  }
  void end() {
    sharp_edges = nullptr;
    x = nullptr;
    v = nullptr;
  }
  // After v.row(p) changed: its end position.
  void moved(int p) { x_end.row(p) = x->row(p) + h * v->row(p); }
  // Point p of a feature pair (cloth vertex p >= 0, else body vertex -(1 + p) of `body`).
  Vec3 start_of(int p, int body) const { return p >= 0 ? row3(*x, p) : row3(body_start[body], -1 - p); }
  Vec3 end_of(int p, int body) const { return p >= 0 ? row3(x_end, p) : row3(body_end[body], -1 - p); }
  Vec3 velocity_of(int p, int body) const {
    return p >= 0 ? row3(*v, p) : Vec3((row3(body_end[body], -1 - p) - row3(body_start[body], -1 - p)) / h);
  }
};

}  // namespace weft
