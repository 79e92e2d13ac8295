#include "weft/gia/pinch_driver.h"

#include <algorithm>
#include <limits>

#include "weft/common/timer.h"
#include "weft/geometry/closest_points.h"
#include "weft/geometry/intersection_count.h"

namespace weft {

PinchDriver::PinchDriver(std::vector<int> bodies, int body_count, int vertex_count, int threads,
                         const PinchTracking& tracking)
    : tracker_(std::move(bodies), threads, tracking), gripped_(body_count, std::vector<char>(vertex_count, 0)) {}

void PinchDriver::grip(int i, const Faces& faces, const Positions& start, const Positions& end, CollisionStep& step,
                       CollisionTelemetry& frame) const {
  // The velocity of the closest body point (lowest face id on ties).
  const Vec3 p = row3(*step.x, i);
  double best = std::numeric_limits<double>::infinity();
  Vec3 vb = Vec3::Zero();
  for (int f = 0; f < faces.rows(); ++f) {
    Vec3 bary;
    const double d = point_triangle_distance(p, row3(start, faces(f, 0)), row3(start, faces(f, 1)),
                                             row3(start, faces(f, 2)), bary);
    if (!(d < best)) continue;
    best = d;
    vb.setZero();
    for (int k = 0; k < 3; ++k) {
      const int bv = faces(f, k);
      vb += bary[k] * (row3(end, bv) - row3(start, bv)) / step.h;
    }
  }
  step.v->row(i) = vb.transpose();
  step.moved(i);
  ++frame.gia_gripped_vertices;
}

void PinchDriver::update(CollisionStep& step, ContactDetection& detection, double default_thickness, bool unclean,
                         CollisionTelemetry& frame, const std::vector<char>* through) {
  const Timer timer;
  const auto& bodies = detection.bodies();
  const Faces& cloth_faces = detection.cloth_faces();
  std::vector<const Positions*> s(bodies.size(), nullptr), e(bodies.size(), nullptr);
  std::vector<const Faces*> f(bodies.size(), nullptr);
  for (size_t b = 0; b < bodies.size(); ++b) {
    s[b] = &step.body_start[b];
    e[b] = &step.body_end[b];
    f[b] = &bodies[b].faces;
  }
  tracker_.update(s, e, f);
  // The cloth's boxes over the step: for the regions and the faces-through test below, when
  // either has work (collect() refits them anew in any case).
  if (tracker_.active_pairs() > 0 || unclean) detection.refit_cloth(*step.x, step.x_end);
  // Two thicknesses: cloth within one of the intersection volume touches both bodies, and
  // recovery or proximity leaves cloth one thickness outside a body face bounding the volume
  // (at the region's edge, where rounding would put it in or out step by step).
  const double margin = 2.0 * default_thickness;
  const auto& pairs = tracker_.pairs();
  const std::vector<Aabb>& cloth_boxes = detection.cloth_boxes();
  engaged_.assign(pairs.size(), 0);
  engaged_count_ = 0;
  engaged_parts_ = 0;
  for (size_t k = 0; k < pairs.size(); ++k) {
    const BodyPairPinch& p = pairs[k];
    if (p.state() == PinchState::kFree) continue;
    bool cloth_there = !p.parts;
    if (p.parts) {
      Aabb region = p.region();
      region.inflate(margin);
      for (size_t c = 0; c < cloth_boxes.size() && !cloth_there; ++c)
        cloth_there = detection.face_collide()[c] && cloth_boxes[c].overlaps(region);
    }
    if (!cloth_there) continue;
    engaged_[k] = 1;
    ++engaged_count_;
    if (p.parts) ++engaged_parts_;
  }
  frame.gia_pinched_body_pairs = std::max(frame.gia_pinched_body_pairs, engaged_count_ - engaged_parts_);
  frame.gia_pinched_part_pairs = std::max(frame.gia_pinched_part_pairs, engaged_parts_);
  faces_.assign(bodies.size(), {});
  held_.assign(bodies.size(), {});
  squeezed_.assign(bodies.size(), {});
  // Cloth faces already through a body (left by a pinch: the other body's rim cuts them while
  // CCD is off) get no CCD against it either: CCD can only keep such an intersection, so after
  // the pinch opens it would lock the tangle. Exact test on the broad phase's candidates. A
  // step that starts clean (the last left nothing unresolved, skipped no CCD and engaged no
  // pinch, and the last frame's count found no intersection) has no such face.
  if (unclean || engaged_count_ > 0) {
    for (size_t b = 0; b < bodies.size(); ++b) {
      const ContactDetection::Body& state = bodies[b];
      if (!state.collide || (through != nullptr && !(*through)[b])) continue;
      const Positions& start = step.body_start[b];
      for (const auto& [cf, bf] : detection.body_pairs(static_cast<int>(b), start, start)) {
        if (!detection.face_collide()[cf] || (!faces_[b].empty() && faces_[b][cf])) continue;
        const Positions& x = *step.x;
        const std::array<Vec3, 3> tc = {row3(x, cloth_faces(cf, 0)), row3(x, cloth_faces(cf, 1)),
                                        row3(x, cloth_faces(cf, 2))};
        const std::array<Vec3, 3> tb = {row3(start, state.faces(bf, 0)), row3(start, state.faces(bf, 1)),
                                        row3(start, state.faces(bf, 2))};
        if (!triangles_intersect(tc, tb)) continue;
        if (faces_[b].empty()) faces_[b].assign(cloth_faces.rows(), 0);
        faces_[b][cf] = 1;
      }
    }
  }
  if (engaged_count_ > 0) {
    // Held (GIA recovery waits, the body grips it) between bodies that intersect. Cloth that a
    // part of a character squeezes against another is only left alone by the recovery
    // (squeezed): CCD against the other part keeps it out of that one, and the squeezing part
    // passes over it (gripped, the cloth would be dragged along the other part).
    std::vector<char> hold(engaged_), squeeze(engaged_);
    for (size_t k = 0; k < pairs.size(); ++k) {
      hold[k] = engaged_[k] && !pairs[k].parts;
      squeeze[k] = engaged_[k] && pairs[k].parts;
    }
    for (size_t b = 0; b < bodies.size(); ++b) {
      if (!bodies[b].collide) continue;
      std::vector<char> region;
      tracker_.mark_faces(static_cast<int>(b), cloth_boxes, margin, region, &engaged_);
      if (faces_[b].empty()) faces_[b].swap(region);
      else
        for (size_t k = 0; k < region.size(); ++k) faces_[b][k] |= region[k];
      const int body = static_cast<int>(b);
      if (engaged_count_ > engaged_parts_) tracker_.mark_vertices(body, *step.x, margin, held_[b], &hold);
      if (engaged_parts_ > 0) tracker_.mark_vertices(body, *step.x, margin, squeezed_[b], &squeeze);
    }
  }
  marked_.assign(bodies.size(), 0);
  for (size_t b = 0; b < bodies.size(); ++b)
    marked_[b] = std::any_of(faces_[b].begin(), faces_[b].end(), [](char c) { return c != 0; });
  frame.gia_seconds += timer.seconds();
}

}  // namespace weft
