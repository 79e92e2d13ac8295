#include "weft/collision/contact_constraints.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "weft/collision/proximity_response.h"
#include "weft/common/ordered_append.h"
#include "weft/common/timer.h"

namespace weft {

namespace {
// Contacts are looked for within this many thicknesses: beyond one thickness the constraint only
// caps the approach speed, so a vertex arriving fast ends the step at the thickness instead of
// being caught by CCD.
constexpr double kContactBand = 2.0;
}  // namespace

void ContactConstraints::constrain(const Positions& x, const Positions& v, double h, const CollisionStep& step,
                                   ContactDetection& detection, const ContactProperties& props,
                                   ConstraintFilter& filter, CollisionTelemetry& frame) {
  const Timer timer;
  const int vertex_count = static_cast<int>(x.rows());
  if (released_.size() != static_cast<size_t>(vertex_count)) released_.assign(vertex_count, 0);
  if (held_.size() != static_cast<size_t>(vertex_count)) held_.assign(vertex_count, 0);
  // Closest collidable body face within the band, per cloth vertex and body: a nearest-first
  // search of the body's tree at the step's start from each free vertex, which skips every
  // subtree whose box is farther than the band or than the nearest face found so far (a face
  // is never nearer than its box, so none that could win or tie is skipped). A vertex is looked
  // at once, where a pair of triangles' boxes would list it against every body face near its
  // triangle (four times as many on a draped sheet).
  std::vector<double> best(vertex_count, std::numeric_limits<double>::infinity());
  std::vector<Contact> contact(vertex_count);
  std::vector<int> best_face(vertex_count, -1);
  // Distances computed in parallel over fixed chunks of cloth faces (each vertex with the face
  // that owns it), then reduced in that order: the same contacts as one serial pass.
  struct Near {
    int vertex;
    int face;  // of the body
    double distance;
    Contact contact;
  };
  constexpr std::int64_t kChunk = 256;
  const Faces& cloth_faces = detection.cloth_faces();
  const auto face_count = static_cast<std::int64_t>(cloth_faces.rows());
  std::vector<Near> nearby;
  for (size_t b = 0; b < detection.bodies().size(); ++b) {
    if (!detection.bodies()[b].collide) continue;
    const int body = static_cast<int>(b);
    const Positions& start = step.body_start[b];
    const Positions& end = step.body_end[b];
    const ContactDetection::Body& state = detection.refit_body(body, start, start);
    nearby.clear();
    ordered_append(face_count, kChunk, detection.threads(), nearby, [&](std::int64_t cf, std::vector<Near>& out) {
      if (!detection.face_collide()[cf]) return;
      for (int vtx : detection.cloth_ownership().face_vertices[cf]) {
        if (props.inverse_mass[vtx] == 0.0) continue;
        const Vec3 p = row3(x, vtx);
        const double th = props.body_separation(vtx, body);
        double radius = kContactBand * th;
        int face = -1;
        double nearest = std::numeric_limits<double>::infinity();
        Vec3 weights;
        state.tree.nearest(p, radius, [&](int bf) {
          Vec3 bary;
          const double d = point_triangle_distance(p, row3(start, state.faces(bf, 0)), row3(start, state.faces(bf, 1)),
                                                   row3(start, state.faces(bf, 2)), bary);
          if (d >= kContactBand * th || d <= 1e-12 * th) return;
          if (d < nearest || (d == nearest && bf < face)) {
            nearest = d;
            face = bf;
            weights = bary;
            radius = d;
          }
        });
        if (face < 0) continue;
        Vec3 closest = Vec3::Zero(), vb = Vec3::Zero();
        for (int q = 0; q < 3; ++q) {
          const int bv = state.faces(face, q);
          closest += weights[q] * row3(start, bv);
          vb += weights[q] * (row3(end, bv) - row3(start, bv)) / h;
        }
        out.push_back({vtx, face, nearest, {vtx, body, (p - closest) / nearest, vb, 0.0}});
      }
    });
    // Ties (a vertex closest to an edge or corner that faces share): the lowest body, then face.
    for (const Near& near : nearby) {
      const int i = near.vertex;
      if (near.distance < best[i] ||
          (near.distance == best[i] && contact[i].body == body && near.face < best_face[i])) {
        best[i] = near.distance;
        best_face[i] = near.face;
        contact[i] = near.contact;
      }
    }
  }
  for (int i = 0; i < vertex_count; ++i) {
    const bool released = released_[i] != 0, held = held_[i] != 0;
    released_[i] = 0;
    held_[i] = 0;
    if (released || !std::isfinite(best[i]) || filter.projection[i] != Mat3::Identity()) continue;
    Contact c = contact[i];
    const double th = props.body_separation(i, c.body);
    const double target = best[i] < th ? kRepulsionRate * (th - best[i]) / h : (th - best[i]) / h;
    const double vn = (row3(v, i) - c.body_velocity).dot(c.normal);
    // A contact the last solve held with a pushing impulse stays (resting cloth is pressed by
    // this step's forces too, which the velocity before the solve does not show); a new one
    // only when the vertex already approaches faster than the target.
    if (!held && vn > target) continue;
    c.delta_vn = target - vn;
    filter.constrain_direction(i, c.normal, c.delta_vn);
    held_[i] = 1;  // cleared by impulses() when the constraint pulled
    contacts_.push_back(c);
  }
  frame.contact_constraints += static_cast<int>(contacts_.size());
  frame.proximity_seconds += timer.seconds();
}

int ContactConstraints::impulses(const VectorX& residual) {
  int pulled = 0;
  for (Contact& c : contacts_) {
    // The solved system is A dv = b + (constraint impulses): the constraint's is -r_i.
    const double impulse = -c.normal.dot(residual.segment<3>(3 * c.vertex));
    if (impulse < 0.0) {
      released_[c.vertex] = 1;
      held_[c.vertex] = 0;
      ++pulled;
    }
    c.impulse = std::max(impulse, 0.0);
  }
  return pulled;
}

void ContactConstraints::friction(CollisionStep& step, const ContactProperties& props) const {
  for (const Contact& c : contacts_) {
    const double mu = props.friction[c.vertex];
    if (mu <= 0.0 || c.impulse <= 0.0) continue;
    const Vec3 v_rel = row3(*step.v, c.vertex) - c.body_velocity;
    const Vec3 v_t = v_rel - c.normal.dot(v_rel) * c.normal;
    const double vt_norm = v_t.norm();
    if (vt_norm <= 0.0) continue;
    // Coulomb: the tangential velocity change is at most mu times the normal one.
    const double scale = std::max(0.0, 1.0 - mu * c.impulse * props.inverse_mass[c.vertex] / vt_norm);
    step.v->row(c.vertex) += ((scale - 1.0) * v_t).transpose();
    step.moved(c.vertex);
  }
}

}  // namespace weft
