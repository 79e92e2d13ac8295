#include "weft/collision/contact_constraints.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

#include "weft/collision/proximity_response.h"
#include "weft/geometry/closest_points.h"
#include "weft/common/ordered_append.h"
#include "weft/common/timer.h"

namespace weft {

namespace {
// Cloth faces per parallel work item of the searches.
constexpr std::int64_t kChunk = 256;
constexpr double kInfinity = std::numeric_limits<double>::infinity();
}  // namespace

std::vector<std::uint8_t> ContactConstraints::flags() const {
  std::vector<std::uint8_t> out(held_.size(), 0);
  for (size_t i = 0; i < out.size(); ++i)
    out[i] = held_[i] ? (i < stuck_.size() && stuck_[i] ? kStuck : kHeld) : (released_[i] ? kReleased : 0);
  return out;
}

void ContactConstraints::set_flags(const std::vector<std::uint8_t>& flags, int vertex_count) {
  if (!flags.empty() && flags.size() != static_cast<size_t>(vertex_count))
    throw std::invalid_argument("contact_flags must be empty or have one entry per vertex (" +
                                std::to_string(vertex_count) + ")");
  for (std::uint8_t f : flags)
    if (f > kStuck)
      throw std::invalid_argument(
          "contact_flags entries must be 0 (none), 1 (held), 2 (released) or 3 (held, sticking)");
  held_.assign(flags.size(), 0);
  released_.assign(flags.size(), 0);
  stuck_.assign(flags.size(), 0);
  for (size_t i = 0; i < flags.size(); ++i) {
    held_[i] = flags[i] == kHeld || flags[i] == kStuck;
    stuck_[i] = flags[i] == kStuck;
    released_[i] = flags[i] == kReleased;
  }
}

void ContactConstraints::constrain(const Positions& x, const Positions& v, double h, const CollisionStep& step,
                                   ContactDetection& detection, const ContactProperties& props,
                                   ConstraintFilter& filter, CollisionTelemetry& frame,
                                   const std::vector<char>* aside) {
  const Timer timer;
  const int vertex_count = static_cast<int>(x.rows());
  if (released_.size() != static_cast<size_t>(vertex_count)) released_.assign(vertex_count, 0);
  if (held_.size() != static_cast<size_t>(vertex_count)) held_.assign(vertex_count, 0);
  if (stuck_.size() != static_cast<size_t>(vertex_count)) stuck_.assign(vertex_count, 0);
  // Closest collidable body face within the band, per cloth vertex and body: a nearest-first
  // search of the body's tree at the step's start from each free vertex, which skips every
  // subtree whose box is farther than the band or than the nearest face found so far (a face
  // is never nearer than its box, so none that could win or tie is skipped). A vertex is looked
  // at once, where a pair of triangles' boxes would list it against every body face near its
  // triangle (four times as many on a draped sheet).
  std::vector<double> best(vertex_count, std::numeric_limits<double>::infinity());
  std::vector<Contact> contact(vertex_count);
  // Distances computed in parallel over fixed chunks of cloth faces (each vertex with the face
  // that owns it, against every body in order), then written in that order: the same contacts
  // as one serial pass.
  struct Near {
    double distance;
    Contact contact;
  };
  const Faces& cloth_faces = detection.cloth_faces();
  const auto face_count = static_cast<std::int64_t>(cloth_faces.rows());
  const std::vector<int>& bodies = detection.colliding();
  detection.refit_bodies(step, false);
  std::vector<Near> nearby;
  // clear_[v] is written by the chunk owning v only (each vertex has one owning face).
  clear_.assign(vertex_count, 0);
  // A vertex far from a body stays out of its band for many steps (a sheet hanging below a
  // sphere, a skirt against each of a character's parts but the nearest): where a search found
  // no face, every face lay at least as far as the nearest one it visited or subtree it skipped
  // (AabbTree::nearest's pruned bound). That bound, less the band, is the vertex's margin for
  // this body; each call takes off how far the vertex and the body's farthest-moving vertex
  // moved since the last, and while the margin stays above 0 no face can be within the band
  // (or the reach) and the search is skipped: the same contacts, and the same clear vertices.
  const auto body_slots = static_cast<int>(bodies.size());
  const bool known = last_x_.rows() == vertex_count && last_body_x_.size() == bodies.size() &&
                     far_margin_.size() == static_cast<size_t>(vertex_count) * bodies.size();
  if (!known) far_margin_.assign(static_cast<size_t>(vertex_count) * bodies.size(), -kInfinity);
  std::vector<double> body_moved(bodies.size(), kInfinity);
  for (int k = 0; known && k < body_slots; ++k) {
    const Positions& now = step.body_start[bodies[k]];
    if (now.rows() != last_body_x_[k].rows()) continue;
    double farthest = 0.0;
    for (Eigen::Index i = 0; i < now.rows(); ++i) farthest = std::max(farthest, (row3(now, i) - row3(last_body_x_[k], i)).norm());
    body_moved[k] = farthest;
  }
  ordered_append(face_count, kChunk, detection.threads(), nearby, [&](std::int64_t cf, std::vector<Near>& out) {
    if (!detection.face_collide()[cf]) return;
    for (int vtx : detection.cloth_ownership().face_vertices[cf]) {
      double* margin = far_margin_.data() + static_cast<size_t>(vtx) * bodies.size();
      if (props.inverse_mass[vtx] == 0.0) {  // not looked at: nothing known when it is freed
        std::fill(margin, margin + body_slots, -kInfinity);
        continue;
      }
      const Vec3 p = row3(x, vtx);
      const double vertex_moved = known ? (p - row3(last_x_, vtx)).norm() : kInfinity;
      Near found{std::numeric_limits<double>::infinity(), {}};
      // Any face nearer than the separation, the ones the nearest face search passes over
      // (within 1e-12 of it) included: the search visits every face within its radius, which
      // never falls below the separation before such a face was seen.
      bool within_separation = false;
      for (int k = 0; k < body_slots; ++k) {
        const int body = bodies[k];
        margin[k] -= vertex_moved + body_moved[k];
        if (margin[k] > 0.0) continue;
        const Positions& start = step.body_start[body];
        const Positions& end = step.body_end[body];
        const ContactDetection::Body& state = detection.bodies()[body];
        const double th = props.body_separation(vtx, body);
        // The proximity response's reach for this vertex's pairs (ContactProperties::pair_thickness).
        const double reach = props.thickness[vtx] > 0.0 ? th : th + props.default_thickness;
        double radius = kContactBand * th;
        int face = -1;
        double nearest = std::numeric_limits<double>::infinity();
        double beyond = kInfinity;  // no face nearer (squared): skipped subtrees, rejected faces
        Vec3 weights;
        state.tree.nearest(p, radius, [&](int bf) {
          Vec3 bary;
          const double d = point_triangle_distance(p, row3(start, state.faces(bf, 0)), row3(start, state.faces(bf, 1)),
                                                   row3(start, state.faces(bf, 2)), bary);
          if (d < reach) within_separation = true;
          if (d >= kContactBand * th || d <= 1e-12 * th) {
            beyond = std::min(beyond, d * d);
            return;
          }
          if (d < nearest || (d == nearest && bf < face)) {
            nearest = d;
            face = bf;
            weights = bary;
            radius = d;
          }
        }, &beyond);
        // A face found, or one within the reach (the band below it): searched again next time.
        // The bound shrunk by a relative 1e-9 for the rounding of box and face distances.
        margin[k] = face < 0 ? std::sqrt(beyond) * (1.0 - 1e-9) - std::max(kContactBand * th, reach) : -kInfinity;
        // Ties (a vertex closest to an edge or corner that faces share): the lowest body, then
        // face (the search keeps the lowest face of a body).
        if (face < 0 || !(nearest < found.distance)) continue;
        Vec3 closest = Vec3::Zero(), vb = Vec3::Zero();
        for (int q = 0; q < 3; ++q) {
          const int bv = state.faces(face, q);
          closest += weights[q] * row3(start, bv);
          vb += weights[q] * (row3(end, bv) - row3(start, bv)) / h;
        }
        found = {nearest, {vtx, body, (p - closest) / nearest, vb, 0.0}};
      }
      if (std::isfinite(found.distance)) out.push_back(found);
      clear_[vtx] = !within_separation;
    }
  });
  last_x_ = x;
  last_body_x_.resize(bodies.size());
  for (int k = 0; k < body_slots; ++k) last_body_x_[k] = step.body_start[bodies[k]];
  for (const Near& near : nearby) {
    best[near.contact.vertex] = near.distance;
    contact[near.contact.vertex] = near.contact;
  }
  // A vertex set aside is treated as released: no vertex or edge contact, nothing kept.
  std::vector<char> was_released = released_;
  const std::vector<char> was_held = held_;
  const std::vector<char> was_stuck = stuck_;
  std::fill(stuck_.begin(), stuck_.end(), 0);
  if (aside)
    for (int i = 0; i < vertex_count; ++i) was_released[i] |= (*aside)[i];
  std::fill(released_.begin(), released_.end(), 0);
  std::fill(held_.begin(), held_.end(), 0);
  for (int i = 0; i < vertex_count; ++i) {
    if (was_released[i] || !std::isfinite(best[i]) || filter.projection[i] != Mat3::Identity()) continue;
    Contact c = contact[i];
    const double th = props.body_separation(i, c.body);
    const double target = best[i] < th ? kRepulsionRate * (th - best[i]) / h : (th - best[i]) / h;
    const double vn = (row3(v, i) - c.body_velocity).dot(c.normal);
    // A contact the last solve held with a pushing impulse stays (resting cloth is pressed by
    // this step's forces too, which the velocity before the solve does not show); a new one
    // only when the vertex already approaches faster than the target.
    if (!was_held[i] && vn > target) continue;
    c.delta_vn = target - vn;
    c.friction = props.friction[i];
    c.fresh = !was_held[i];
    if (c.fresh) c.impact = std::max(0.0, -vn) / props.inverse_mass[i];
    if (was_stuck[i] && c.friction > 0.0) {
      // Static friction inside the solve: the last step's friction stopped this held vertex on
      // the body, so this solve prescribes all of its velocity (the body's plus the normal
      // target) and its neighbours answer to a vertex that stays put. Applied after the solve
      // instead, friction stops the vertex while they move as if it had slid: the stretch that
      // leaves is elastic energy from nowhere (a drape kept its contacts over frames gained
      // ten times its elastic energy and slid off the sphere).
      c.stuck = true;
      c.stuck_dv = c.body_velocity + target * c.normal - row3(v, i);
      filter.constrain_fully(i, c.stuck_dv);
    } else {
      filter.constrain_direction(i, c.normal, c.delta_vn);
    }
    held_[i] = 1;  // cleared by impulses() when the constraint pulled
    contacts_.push_back(c);
  }
  // Edges are looked at only where neither end is held by a vertex contact or was released.
  std::vector<char> open_end(vertex_count);
  for (int i = 0; i < vertex_count; ++i)
    open_end[i] = !was_released[i] && filter.projection[i] == Mat3::Identity() && props.inverse_mass[i] != 0.0;
  for (const EdgeNear& e : edge_contacts(x, h, step, detection, props, open_end)) {
    if (filter.projection[e.a] != Mat3::Identity() || filter.projection[e.b] != Mat3::Identity()) continue;
    const double th = std::max(props.body_separation(e.a, e.body), props.body_separation(e.b, e.body));
    const double target = e.distance < th ? kRepulsionRate * (th - e.distance) / h : (th - e.distance) / h;
    const Vec3 v_point = (1.0 - e.s) * row3(v, e.a) + e.s * row3(v, e.b);
    const double vn = (v_point - e.body_velocity).dot(e.normal);
    if (!(was_held[e.a] && was_held[e.b]) && vn > target) continue;
    // Both ends move at the target normal speed: the edge's contact point does too.
    // Their friction takes the whole normal impulse of each end (which is not at the body):
    // with the first-step rule of vertex contacts (header) applied to these ends too, the
    // swept sheet of the header reached 1.73x and 2.99x (friction 0.3 and 0.6) instead of 1.61x
    // and 1.68x (measured before the sliding rule; docs/collisions.md).
    for (int i : {e.a, e.b}) {
      const double delta = target - (row3(v, i) - e.body_velocity).dot(e.normal);
      filter.constrain_direction(i, e.normal, delta);
      held_[i] = 1;
      contacts_.push_back({i, e.body, e.normal, e.body_velocity, delta, 0.0});
    }
  }
  looked_ = true;
  frame.contact_constraints += static_cast<int>(contacts_.size());
  const double seconds = timer.seconds();
  frame.proximity_seconds += seconds;
  frame.contact_constraints_seconds += seconds;
}

// Cloth edges across a body edge (a coarse sheet hooked on a thin limb, a strap over a box
// corner): both ends may lie beyond the band while the edge touches the body, where no vertex
// contact sees it. Only the body's sharp edges can be touched so (sharp_edges.h); each cloth
// edge gets the closest of them within the band (at an interior point of the cloth edge),
// searched from the edge's midpoint with the band plus half its length.
std::vector<ContactConstraints::EdgeNear> ContactConstraints::edge_contacts(const Positions& x, double h,
                                                                           const CollisionStep& step,
                                                                           const ContactDetection& detection,
                                                                           const ContactProperties& props,
                                                                           const std::vector<char>& open_end) {
  std::vector<EdgeNear> edge_near;
  const Faces& cloth_faces = detection.cloth_faces();
  const auto face_count = static_cast<std::int64_t>(cloth_faces.rows());
  if (sharp_.size() != detection.bodies().size()) {  // once: body topology, thickness range
    sharp_.clear();
    for (const ContactDetection::Body& body : detection.bodies()) sharp_.emplace_back(body.faces);
    const auto [thinnest, thickest] = std::minmax_element(props.thickness.begin(), props.thickness.end());
    thinnest_ = thinnest != props.thickness.end() ? *thinnest : 0.0;
    thickest_ = thickest != props.thickness.end() ? *thickest : 0.0;
  }
  double longest_edge = 0.0;
  for (std::int64_t cf = 0; cf < face_count; ++cf) {
    if (!detection.face_collide()[cf]) continue;
    for (int c = 0; c < 3; ++c)
      longest_edge = std::max(longest_edge, (row3(x, cloth_faces(cf, c)) - row3(x, cloth_faces(cf, (c + 1) % 3))).norm());
  }
  // The bodies with sharp edges, each with the box their edges can reach cloth within.
  std::vector<int> sharp_bodies;
  std::vector<Aabb> reach;
  for (size_t bi = 0; bi < detection.bodies().size(); ++bi) {
    if (!detection.bodies()[bi].collide) continue;
    const double offset = props.body_offset.empty() ? 0.0 : props.body_offset[bi];
    if (sharp_[bi].update(detection.bodies()[bi].faces, step.body_start[bi], longest_edge, thinnest_ + offset) == 0)
      continue;
    sharp_bodies.push_back(static_cast<int>(bi));
    Aabb box = sharp_[bi].tree().bounds();
    box.inflate(kContactBand * (thickest_ + offset));
    reach.push_back(box);
  }
  if (!sharp_bodies.empty()) {
    ordered_append(face_count, kChunk, detection.threads(), edge_near, [&](std::int64_t cf, std::vector<EdgeNear>& out) {
      if (!detection.face_collide()[cf]) return;
      for (const auto& edge : detection.cloth_ownership().face_edges[cf]) {
        const int a = edge[0], b = edge[1];
        if (!open_end[a] || !open_end[b]) continue;
        const Vec3 pa = row3(x, a), pb = row3(x, b);
        Aabb segment;
        segment.expand(pa);
        segment.expand(pb);
        const double half_length = 0.5 * (pb - pa).norm();
        EdgeNear found{a, b, 0.0, std::numeric_limits<double>::infinity(), -1, Vec3::Zero(), Vec3::Zero()};
        for (size_t k = 0; k < sharp_bodies.size(); ++k) {
          if (!segment.overlaps(reach[k])) continue;
          const int body = sharp_bodies[k];
          const Positions& start = step.body_start[body];
          const Positions& end = step.body_end[body];
          const SharpEdges& sharp = sharp_[body];
          const double th = std::max(props.body_separation(a, body), props.body_separation(b, body));
          // Only edges sharp for this cloth edge's length can catch it (sharp_edges.h).
          const double length = 2.0 * half_length;
          if (!sharp.sharp_for(sharp.sharpest(), length, th)) continue;
          const double band = kContactBand * th;
          double nearest = band, radius = band + half_length, along = 0.0, at = 0.0;
          int nearest_leaf = -1;
          sharp.tree().nearest(0.5 * (pa + pb), radius, [&](int leaf) {
            if (!sharp.sharp_for(sharp.sharpness(leaf), length, th)) return;
            const std::array<int, 2>& be = sharp.edge(leaf);
            double s_cloth, t_body;
            const double d = segment_segment_distance(pa, pb, row3(start, be[0]), row3(start, be[1]), s_cloth, t_body);
            if (s_cloth <= 0.0 || s_cloth >= 1.0 || d <= 1e-12 * th) return;
            if (d < nearest || (d == nearest && leaf < nearest_leaf)) {
              nearest = d;
              along = s_cloth;
              at = t_body;
              nearest_leaf = leaf;
              radius = d + half_length;  // no edge nearer the segment lies farther from its midpoint
            }
          });
          // The nearest body wins; on a tie the lower one (bodies go in increasing order).
          if (nearest_leaf < 0 || !(nearest < found.distance)) continue;
          const std::array<int, 2>& be = sharp.edge(nearest_leaf);
          const Vec3 q0 = row3(start, be[0]), q1 = row3(start, be[1]);
          found.distance = nearest;
          found.s = along;
          found.body = body;
          found.normal = ((1.0 - along) * pa + along * pb - ((1.0 - at) * q0 + at * q1)) / nearest;
          found.body_velocity = ((1.0 - at) * (row3(end, be[0]) - q0) + at * (row3(end, be[1]) - q1)) / h;
        }
        if (found.body >= 0) out.push_back(found);
      }
    });
  }
  return edge_near;
}

int ContactConstraints::impulses(const VectorX& residual) {
  int pulled = 0;
  for (Contact& c : contacts_) {
    // The solved system is A dv = b + (constraint impulses): the constraint's is -r_i.
    const Vec3 force = -residual.segment<3>(3 * c.vertex);
    const double impulse = c.normal.dot(force);
    // A sticking contact whose tangential impulse left the friction cone slides from the next
    // step on (its normal only prescribed, kinetic friction after the solve).
    if (c.stuck && impulse >= 0.0) c.slides = (force - impulse * c.normal).norm() > c.friction * impulse;
    if (impulse < 0.0) {
      c.stuck = false;
      released_[c.vertex] = 1;
      held_[c.vertex] = 0;
      ++pulled;
    }
    c.impulse = std::max(impulse, 0.0);
  }
  return pulled;
}

void ContactConstraints::contact_normals(int vertex_count, std::vector<Vec3>& normals) const {
  normals.assign(static_cast<size_t>(vertex_count), Vec3::Zero());
  for (const Contact& c : contacts_) normals[static_cast<size_t>(c.vertex)] = c.normal;
}

void ContactConstraints::friction(CollisionStep& step, const ContactProperties& props) {
  friction_changes_.clear();
  for (const Contact& c : contacts_) {
    const double mu = props.friction[c.vertex];
    if (c.stuck) {  // the solve kept it on the body
      if (!c.slides) stuck_[c.vertex] = 1;
      continue;
    }
    // The normal impulse that presses the vertex on the body: of a new contact's, what is left
    // after stopping its approach (an impact's share would stop the vertex alone: header).
    const double pressing = c.impulse - c.impact;
    if (mu <= 0.0 || pressing <= 0.0) continue;
    const Vec3 v_rel = row3(*step.v, c.vertex) - c.body_velocity;
    const Vec3 v_t = v_rel - c.normal.dot(v_rel) * c.normal;
    const double vt_norm = v_t.norm();
    // A held contact that friction stops (or finds at rest on the body) sticks in the next
    // solve, unless it is new or slid farther than its thickness in this step (header).
    const bool may_stick = held_[c.vertex] && !c.fresh && vt_norm * step.h < props.thickness[c.vertex];
    if (vt_norm <= 0.0) {
      if (may_stick) stuck_[c.vertex] = 1;  // at rest on the body
      continue;
    }
    // Coulomb: the tangential velocity change is at most mu times the normal one.
    const double scale = std::max(0.0, 1.0 - mu * pressing * props.inverse_mass[c.vertex] / vt_norm);
    if (scale == 0.0 && may_stick) stuck_[c.vertex] = 1;  // stopped: sticks in the next solve
    const Vec3 change = (scale - 1.0) * v_t;
    step.v->row(c.vertex) += change.transpose();
    step.moved(c.vertex);
    friction_changes_.push_back({c.vertex, change, vt_norm * step.h});
  }
}

}  // namespace weft
