#include "weft/collision/contact_detection.h"

#include <algorithm>

#include "weft/common/timer.h"

namespace weft {

namespace {
bool face_has(const Faces& faces, int f, int v) { return faces(f, 0) == v || faces(f, 1) == v || faces(f, 2) == v; }
}  // namespace

ContactDetection::ContactDetection(const Faces& cloth_faces, const Positions& x, std::vector<char> face_collide,
                                   std::vector<char> face_self, std::vector<double> face_margin,
                                   const std::vector<KinematicBody>& bodies, const std::vector<char>& body_collide)
    : cloth_faces_(cloth_faces), face_collide_(std::move(face_collide)), face_self_(std::move(face_self)),
      face_margin_(std::move(face_margin)) {
  any_self_ = std::any_of(face_self_.begin(), face_self_.end(), [](char c) { return c != 0; });
  cloth_own_ = assign_features(cloth_faces_, static_cast<int>(x.rows()));
  triangle_boxes(cloth_faces_, x, x, face_margin_, cloth_boxes_);
  cloth_tree_.build(cloth_boxes_);
  bodies_.resize(bodies.size());
  for (size_t b = 0; b < bodies.size(); ++b) {
    Body& state = bodies_[b];
    state.collide = body_collide[b] != 0;
    if (!state.collide) continue;
    any_body_ = true;
    state.vertex_count = bodies[b].vertex_count();
    state.faces = bodies[b].faces();
    state.own = assign_features(state.faces, bodies[b].vertex_count());
    triangle_boxes(state.faces, bodies[b].frame_start(), bodies[b].frame_start(), {}, state.boxes);
    state.tree.build(state.boxes);
  }
}

void ContactDetection::refit_cloth(const Positions& start, const Positions& end) {
  triangle_boxes(cloth_faces_, start, end, face_margin_, cloth_boxes_);
  cloth_tree_.refit(cloth_boxes_);
}

const std::vector<std::pair<int, int>>& ContactDetection::body_pairs(int body, const Positions& start,
                                                                    const Positions& end) {
  Body& state = bodies_[body];
  triangle_boxes(state.faces, start, end, {}, state.boxes);
  state.tree.refit(state.boxes);
  scratch_pairs_.clear();
  cloth_tree_.pairs(state.tree, scratch_pairs_);
  return scratch_pairs_;
}

void ContactDetection::expand_triangle_pair(int cf, int of, int body, const ContactFilter& filter,
                                            std::vector<FeaturePair>& out) const {
  if (body < 0) {
    // Cloth/cloth GIA one-way membrane (cloth_untangling.h): triangle pairs across an
    // intersection are skipped, so regions in intersection can pass back; clean cloth cannot enter.
    if (filter.skip_cloth_pair(cf, of)) return;
    for (int v : cloth_own_.face_vertices[cf])
      if (!face_has(cloth_faces_, of, v))
        out.push_back({{v, cloth_faces_(of, 0), cloth_faces_(of, 1), cloth_faces_(of, 2)}, -1, false});
    for (int v : cloth_own_.face_vertices[of])
      if (!face_has(cloth_faces_, cf, v))
        out.push_back({{v, cloth_faces_(cf, 0), cloth_faces_(cf, 1), cloth_faces_(cf, 2)}, -1, false});
    for (const auto& e1 : cloth_own_.face_edges[cf])
      for (const auto& e2 : cloth_own_.face_edges[of])
        if (e1[0] != e2[0] && e1[0] != e2[1] && e1[1] != e2[0] && e1[1] != e2[1])
          out.push_back({{e1[0], e1[1], e2[0], e2[1]}, -1, true});
    return;
  }
  const Body& b = bodies_[body];
  auto bv = [](int k) { return -1 - k; };
  // GIA one-way membrane, body side (gia_body_driver.h), so a body segment that went through
  // the cloth can come back out: a body face wholly in the body's coloured region lets all
  // cloth pass; one with some coloured corner, or only pierced, lets pass the cloth triangles
  // on the contour (pierced by the body or piercing it), so cloth away from the intersection
  // still cannot enter. Pierced-only faces stay closed in a body/body pinch region: the
  // squeezed cloth is on the contour of both bodies there, and opening a coarse body's pierced
  // faces (a box's top) let it sink into the lower box.
  const int body_colour = filter.body_face_colour(of, body);
  const bool in_pinch = filter.pinched_face(cf, body);
  if (body_colour == 3 ||
      (body_colour >= 1 && filter.cloth_face_contour(cf, body) && (body_colour == 2 || !in_pinch)))
    return;
  // GIA one-way membrane: features with a cloth vertex coloured inside this body are skipped.
  for (int v : cloth_own_.face_vertices[cf])
    if (!filter.coloured(v, body))
      out.push_back({{v, bv(b.faces(of, 0)), bv(b.faces(of, 1)), bv(b.faces(of, 2))}, body, false});
  const bool face_coloured = filter.coloured(cloth_faces_(cf, 0), body) || filter.coloured(cloth_faces_(cf, 1), body) ||
                             filter.coloured(cloth_faces_(cf, 2), body);
  if (!face_coloured)
    for (int k : b.own.face_vertices[of])
      out.push_back({{bv(k), cloth_faces_(cf, 0), cloth_faces_(cf, 1), cloth_faces_(cf, 2)}, body, false});
  for (const auto& e1 : cloth_own_.face_edges[cf])
    if (!filter.coloured(e1[0], body) && !filter.coloured(e1[1], body))
      for (const auto& e2 : b.own.face_edges[of]) out.push_back({{e1[0], e1[1], bv(e2[0]), bv(e2[1])}, body, true});
}

void ContactDetection::collect(CollisionStep& step, const ContactFilter& filter, CollisionTelemetry& frame) {
  const Timer timer;
  refit_cloth(*step.x, step.x_end);
  std::vector<FeaturePair>& pairs = step.pairs;
  pairs.clear();
  if (any_self_) {
    scratch_pairs_.clear();
    cloth_tree_.self_pairs(scratch_pairs_);
    for (const auto& [a, b] : scratch_pairs_)
      if (face_self_[a] && face_self_[b]) expand_triangle_pair(a, b, -1, filter, pairs);
  }
  for (size_t b = 0; b < bodies_.size(); ++b) {
    if (!bodies_[b].collide) continue;
    const int body = static_cast<int>(b);
    for (const auto& [cf, bf] : body_pairs(body, step.body_start[b], step.body_end[b])) {
      if (!face_collide_[cf]) continue;
      const size_t first = pairs.size();
      expand_triangle_pair(cf, bf, body, filter, pairs);
      if (filter.pinched_face(cf, body))  // cloth in a body/body pinch: proximity only, no CCD
        for (size_t k = first; k < pairs.size(); ++k) pairs[k].ccd = false;
    }
  }
  frame.broad_phase_seconds += timer.seconds();
}

}  // namespace weft
