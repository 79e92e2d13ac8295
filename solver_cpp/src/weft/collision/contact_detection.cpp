#include "weft/collision/contact_detection.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "weft/common/ordered_append.h"
#include "weft/common/timer.h"

namespace weft {

namespace {
// The cloth tree over `boxes` as the collision stage builds it from positions x: faces paired
// across edges (pair_faces_across_edges), pieces in subtrees of their own (face_components).
void build_cloth_tree(AabbTree& tree, const Faces& faces, const std::vector<Aabb>& boxes, const Positions& x) {
  tree.build(boxes, pair_faces_across_edges(faces, x), face_components(faces, static_cast<int>(x.rows())));
}

bool face_has(const Faces& faces, int f, int v) { return faces(f, 0) == v || faces(f, 1) == v || faces(f, 2) == v; }

}  // namespace

ContactDetection::ContactDetection(const Faces& cloth_faces, const Positions& x, std::vector<char> face_collide,
                                   std::vector<char> face_self, std::vector<double> face_margin,
                                   const std::vector<KinematicBody>& bodies, const std::vector<char>& body_collide,
                                   bool self_culling)
    : cloth_faces_(cloth_faces), face_collide_(std::move(face_collide)), face_self_(std::move(face_self)),
      face_margin_(std::move(face_margin)), self_culling_(self_culling) {
  any_self_ = std::any_of(face_self_.begin(), face_self_.end(), [](char c) { return c != 0; });
  for (double m : face_margin_) largest_margin_ = std::max(largest_margin_, m);
  self_shrink_ = std::numeric_limits<double>::infinity();
  for (size_t f = 0; f < face_margin_.size(); ++f)
    if (face_self_[f]) self_shrink_ = std::min(self_shrink_, face_margin_[f]);
  if (!std::isfinite(self_shrink_)) self_shrink_ = 0.0;
  cloth_own_ = assign_features(cloth_faces_, static_cast<int>(x.rows()));
  triangle_boxes(cloth_faces_, x, x, face_margin_, cloth_boxes_);
  // Faces paired with an edge neighbour (pair_faces_across_edges) are siblings in the tree, so
  // that its nodes are edge-connected patches, which the self-collision culling needs; and the
  // pieces (faces connected through shared vertices) get subtrees of their own (AabbTree::build).
  build_cloth_tree(cloth_tree_, cloth_faces_, cloth_boxes_, x);
  if (any_self_ && self_culling_) culling_.rebuild(cloth_tree_, cloth_faces_, face_self_);
  bodies_.resize(bodies.size());
  body_shift_.assign(bodies.size(), Vec3::Zero());
  for (size_t b = 0; b < bodies.size(); ++b) {
    Body& state = bodies_[b];
    state.collide = body_collide[b] != 0;
    if (!state.collide) continue;
    any_body_ = true;
    colliding_.push_back(static_cast<int>(b));
    state.vertex_count = bodies[b].vertex_count();
    state.faces = bodies[b].faces();
    state.own = assign_features(state.faces, bodies[b].vertex_count());
    triangle_boxes(state.faces, bodies[b].frame_start(), bodies[b].frame_start(), {}, state.boxes);
    state.tree.build(state.boxes);
  }
}

namespace {
// Boxes of moving triangles (start and end not the same object): at the start, at the end and
// their union (triangle_boxes over the step), for a moving refit of their tree.
void moving_boxes(const Faces& faces, const Positions& start, const Positions& end, const std::vector<double>& margin,
                  std::vector<Aabb>& start_boxes, std::vector<Aabb>& end_boxes, std::vector<Aabb>& boxes,
                  int threads) {
  const int count = static_cast<int>(faces.rows());
  start_boxes.resize(count);
  end_boxes.resize(count);
  boxes.resize(count);
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1 && count >= 2048)
  for (int f = 0; f < count; ++f) {
    start_boxes[f] = triangle_box(faces, start, start, margin, f);
    end_boxes[f] = triangle_box(faces, end, end, margin, f);
    boxes[f] = start_boxes[f];
    boxes[f].expand(end_boxes[f]);
  }
}
}  // namespace

void ContactDetection::refit_cloth(const Positions& start, const Positions& end, double fraction, bool moving) {
  swept_cloth_current_ = false;
  const std::vector<double>* margin = &face_margin_;
  if (fraction != 1.0) {
    scaled_margin_.resize(face_margin_.size());
    for (size_t f = 0; f < face_margin_.size(); ++f) scaled_margin_[f] = fraction * face_margin_[f];
    margin = &scaled_margin_;
  }
  if (!moving || &start == &end) {
    triangle_boxes(cloth_faces_, start, end, *margin, cloth_boxes_, threads_);
    cloth_tree_.refit(cloth_boxes_, threads_);
    return;
  }
  moving_boxes(cloth_faces_, start, end, *margin, cloth_start_boxes_, cloth_end_boxes_, cloth_boxes_, threads_);
  cloth_tree_.refit(cloth_start_boxes_, cloth_end_boxes_, threads_);
}

std::pair<double, double> ContactDetection::cloth_tree_quality(const Positions& x) const {
  std::vector<Aabb> boxes;
  triangle_boxes(cloth_faces_, x, x, face_margin_, boxes);
  AabbTree refitted = cloth_tree_, fresh;
  refitted.refit(boxes);
  build_cloth_tree(fresh, cloth_faces_, boxes, x);
  return {refitted.surface_cost(), fresh.surface_cost()};
}

Aabb ContactDetection::shifted_cloth_box(int f, const Vec3& shift) const {
  return swept_box(cloth_start_boxes_[f], cloth_end_boxes_[f], shift);
}

bool ContactDetection::choose_sweep_frames(const CollisionStep& step) {
  // Each body's frame from its own vertices and the cloth near it (a SweepFrame of its own for
  // scratch), and the cloth's own frame for its self pairs: in parallel (the last item is the
  // cloth's), the same shifts for any thread count.
  self_shift_ = Vec3::Zero();
  std::fill(body_shift_.begin(), body_shift_.end(), Vec3::Zero());
  body_sweep_frames_.resize(bodies_.size());
  const int count = static_cast<int>(colliding_.size());
  const int items = count + (any_self_ ? 1 : 0);
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads_) if (threads_ > 1 && items > 1)
  for (int i = 0; i < items; ++i) {
    if (i == count) {
      self_shift_ = sweep_frame_.shift(*step.x, step.x_end, kCcdSeparationFraction * largest_margin_);
      continue;
    }
    const int b = colliding_[i];
    const Body& state = refit_body(b, step.body_start[b], step.body_end[b]);
    Aabb reach = state.tree.bounds();
    reach.inflate(largest_margin_);
    body_shift_[b] = body_sweep_frames_[b].shift(step.body_start[b], step.body_end[b], reach, *step.x, step.x_end,
                                                 kCcdSeparationFraction * largest_margin_);
  }
  bool any = self_shift_ != Vec3::Zero();
  for (const Vec3& shift : body_shift_) any = any || shift != Vec3::Zero();
  return any;
}

bool FittedAt::same(const Positions& start, const Positions& end) const {
  return valid_ && same_bits(start, start_) && same_bits(end, end_);
}

void FittedAt::set(const Positions& start, const Positions& end) {
  start_ = start;
  end_ = end;
  valid_ = true;
}

const ContactDetection::Body& ContactDetection::refit_body(int body, const Positions& start, const Positions& end) {
  Body& state = bodies_[body];
  // Boxes and tree as they are when start and end are those of the last refit, and it was a
  // moving one if this is.
  if (state.boxes_at.same(start, end) && (&start == &end || state.tree.moving())) return state;
  if (&start == &end) {
    triangle_boxes(state.faces, start, end, {}, state.boxes, threads_);
    state.tree.refit(state.boxes, threads_);
  } else {
    moving_boxes(state.faces, start, end, {}, state.start_boxes, state.end_boxes, state.boxes, threads_);
    state.tree.refit(state.start_boxes, state.end_boxes, threads_);
  }
  state.boxes_at.set(start, end);
  return state;
}

void ContactDetection::refit_bodies(const CollisionStep& step, bool swept) {
  const int count = static_cast<int>(colliding_.size());
  // Each body's boxes, tree and planes are its own: a thread per body (a nested region inside
  // runs on one thread), the same values for any thread count.
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads_) if (threads_ > 1 && count > 1)
  for (int i = 0; i < count; ++i) {
    const int b = colliding_[i];
    const Positions& start = step.body_start[b];
    const Positions& end = swept ? step.body_end[b] : start;
    refit_body(b, start, end);
    fit_body_planes(b, start, end);
  }
}

void ContactDetection::fit_body_planes(int body, const Positions& start, const Positions& end) {
  Body& state = bodies_[body];
  if (state.planes_at.same(start, end)) return;
  state.planes.compute(state.faces, start, end, threads_);
  state.planes_at.set(start, end);
}

const std::vector<std::pair<int, int>>& ContactDetection::body_pairs(int body, const Positions& start,
                                                                    const Positions& end) {
  scratch_pairs_.clear();
  body_pairs(body, start, end, scratch_pairs_);
  return scratch_pairs_;
}

void ContactDetection::body_pairs(int body, const Positions& start, const Positions& end,
                                  std::vector<std::pair<int, int>>& out) {
  const Body& state = refit_body(body, start, end);
  cloth_tree_.pairs(state.tree, out, threads_);
}

const std::vector<std::pair<int, int>>& ContactDetection::self_intersection_candidates(const Positions& x) {
  refit_cloth(x, x, 0.0);
  scratch_pairs_.clear();
  const std::vector<char>* culled = nullptr;
  if (self_culling_) {
    culling_.update(cloth_tree_, cloth_faces_, x, x, 0.0, threads_);
    culled = &culling_.culled();
  }
  cloth_tree_.self_pairs(scratch_pairs_, culled, threads_);
  return scratch_pairs_;
}

namespace {

// Boxes over the step (start and end; the same object: static) of a face's three corners and
// their union: what expand_triangle_pair's sweep test reads, computed once per triangle pair.
// The bounds are those boxes_within (contact_impulse.h) forms from the same points.
struct CornerBoxes {
  std::array<int, 3> vertex{};
  std::array<Aabb, 3> box;
  Aabb face;
  // shift: in the frame moving by it over the step (sweep_frame.h), end positions less it.
  void compute(std::array<int, 3> corners, const Positions& start, const Positions& end, const Vec3* shift) {
    vertex = corners;
    face = Aabb();
    for (int c = 0; c < 3; ++c) {
      const Vec3 s = row3(start, corners[c]);
      Vec3 e = &end != &start ? Vec3(row3(end, corners[c])) : s;
      if (shift) e -= *shift;
      box[c].lo = s.cwiseMin(e);
      box[c].hi = s.cwiseMax(e);
      face.expand(box[c]);
    }
  }
  int corner(int v) const { return v == vertex[0] ? 0 : (v == vertex[1] ? 1 : 2); }
  int bits(int v) const { return 1 << corner(v); }
  int bits(const std::array<int, 2>& edge) const { return bits(edge[0]) | bits(edge[1]); }
  const Aabb& of(int v) const { return box[corner(v)]; }
  Aabb of(const std::array<int, 2>& edge) const {
    Aabb b = of(edge[0]);
    b.expand(of(edge[1]));
    return b;
  }
};

}  // namespace

void ContactDetection::expand_triangle_pair(int cf, int of, int body, const ContactFilter& filter,
                                            std::vector<FeaturePair>& out, const Sweep* sweep) const {
  // The sweep's test is boxes_within's, side for side: the box of the pair's first feature (the
  // vertex of a vertex-face pair, the first edge) grown by the gap must overlap the other's (a
  // face's box is its corners' union, an edge's its two corners').
  // Computed after the filters' early returns (compute_boxes). A filter that skips nothing
  // against this body is not asked about each feature.
  const bool plain = filter.skips_nothing(body);
  const bool boxed = sweep != nullptr && !(body >= 0 && !plain && filter.pinched_face(cf, body));
  CornerBoxes cloth, other;
  auto compute_boxes = [&](const Faces& other_faces) {
    if (!boxed) return;
    cloth.compute({cloth_faces_(cf, 0), cloth_faces_(cf, 1), cloth_faces_(cf, 2)}, *sweep->cloth_start,
                  *sweep->cloth_end, sweep->shift);
    other.compute({other_faces(of, 0), other_faces(of, 1), other_faces(of, 2)}, *sweep->other_start,
                  *sweep->other_end, sweep->shift);
  };
  auto first_near = [&](Aabb first, const Aabb& second) {
    first.inflate(sweep->gap);
    return first.overlaps(second);
  };
  const PlaneSides* planes = boxed ? sweep->planes : nullptr;
  auto cloth_point_near = [&](int v) {
    return !boxed || (first_near(cloth.of(v), other.face) && !(planes && planes->apart(cloth.bits(v), 7)));
  };
  auto other_point_near = [&](int v) {
    return !boxed || (first_near(other.of(v), cloth.face) && !(planes && planes->apart(7, other.bits(v))));
  };
  auto edges_near = [&](const std::array<int, 2>& e1, const std::array<int, 2>& e2) {  // e2: other numbering
    return !boxed ||
           (first_near(cloth.of(e1), other.of(e2)) && !(planes && planes->apart(cloth.bits(e1), other.bits(e2))));
  };
  if (body < 0) {
    // Cloth/cloth GIA one-way membrane (cloth_untangling.h): triangle pairs across an
    // intersection are skipped, so regions in intersection can pass back; clean cloth cannot enter.
    if (!plain && filter.skip_cloth_pair(cf, of)) return;
    compute_boxes(cloth_faces_);
    for (int v : cloth_own_.face_vertices[cf])
      if (!face_has(cloth_faces_, of, v) && cloth_point_near(v))
        out.push_back({{v, cloth_faces_(of, 0), cloth_faces_(of, 1), cloth_faces_(of, 2)}, -1, false});
    for (int v : cloth_own_.face_vertices[of])
      if (!face_has(cloth_faces_, cf, v) && other_point_near(v))
        out.push_back({{v, cloth_faces_(cf, 0), cloth_faces_(cf, 1), cloth_faces_(cf, 2)}, -1, false});
    for (const auto& e1 : cloth_own_.face_edges[cf])
      for (const auto& e2 : cloth_own_.face_edges[of])
        if (e1[0] != e2[0] && e1[0] != e2[1] && e1[1] != e2[0] && e1[1] != e2[1] && edges_near(e1, e2))
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
  const int body_colour = plain ? 0 : filter.body_face_colour(of, body);
  const bool in_pinch = !plain && filter.pinched_face(cf, body);
  if (body_colour == 3 ||
      (body_colour >= 1 && filter.cloth_face_contour(cf, body) && (body_colour == 2 || !in_pinch)))
    return;
  compute_boxes(b.faces);
  // GIA one-way membrane: features with a cloth vertex coloured inside this body are skipped;
  // so are, against a coloured or pierced body face, the corners of the cloth faces on the
  // contour (and edges between two), whichever face owns them: a contour triangle's corner
  // owned by a face off the contour would otherwise hold its triangle at the body. Not in a
  // body with a pinch region (its squeezed cloth is on the contour of both bodies there).
  const bool open_face = body_colour >= 1 && !in_pinch && !filter.pinch_region(body);
  auto coloured = [&](int p) { return !plain && filter.coloured(p, body); };
  auto passes = [&](int p) { return open_face && filter.contour_corner(p, body); };
  for (int v : cloth_own_.face_vertices[cf])
    if (!coloured(v) && !passes(v) && cloth_point_near(v))
      out.push_back({{v, bv(b.faces(of, 0)), bv(b.faces(of, 1)), bv(b.faces(of, 2))}, body, false});
  const bool face_coloured =
      coloured(cloth_faces_(cf, 0)) || coloured(cloth_faces_(cf, 1)) || coloured(cloth_faces_(cf, 2));
  if (!face_coloured)
    for (int k : b.own.face_vertices[of])
      if (other_point_near(k))
        out.push_back({{bv(k), cloth_faces_(cf, 0), cloth_faces_(cf, 1), cloth_faces_(cf, 2)}, body, false});
  for (const auto& e1 : cloth_own_.face_edges[cf])
    if (!coloured(e1[0]) && !coloured(e1[1]) && !(passes(e1[0]) && passes(e1[1])))
      for (const auto& e2 : b.own.face_edges[of])
        if (edges_near(e1, e2)) out.push_back({{e1[0], e1[1], bv(e2[0]), bv(e2[1])}, body, true});
}

void ContactDetection::collect(CollisionStep& step, const ContactFilter& filter, CollisionTelemetry& frame,
                               bool swept) {
  const Timer timer;
  const Positions& x = *step.x;
  const Positions& end = swept ? step.x_end : x;
  const double fraction = swept ? kCcdSeparationFraction : 1.0;
  // The bodies' sweep frames first: the cloth tree keeps its start and end boxes only where
  // some body needs them.
  refit_bodies(step, swept);
  const bool shifted = swept && choose_sweep_frames(step);
  refit_cloth(x, end, fraction, shifted);
  cloth_planes_.compute(cloth_faces_, x, end, threads_);
  std::vector<FeaturePair>& pairs = swept ? step.pairs : step.proximity_pairs;
  pairs.clear();
  if (any_self_) {
    const Timer self_timer;
    scratch_pairs_.clear();
    const Vec3* shift = swept && self_shift_ != Vec3::Zero() ? &self_shift_ : nullptr;
    const std::vector<char>* culled = nullptr;
    if (self_culling_) {
      culling_.update(cloth_tree_, cloth_faces_, x, end, fraction * largest_margin_, threads_);
      culled = &culling_.culled();
    }
    if (shift)
      cloth_tree_.self_pairs(*shift, scratch_pairs_, culled, threads_, fraction * self_shrink_);
    else
      cloth_tree_.self_pairs(scratch_pairs_, culled, threads_, fraction * self_shrink_);
    ordered_append(static_cast<std::int64_t>(scratch_pairs_.size()), kExpandChunk, threads_, pairs, chunk_pairs_,
                   [&](std::int64_t k, std::vector<FeaturePair>& out) {
                     const auto [a, b] = scratch_pairs_[k];
                     if (!face_self_[a] || !face_self_[b]) return;
                     const double gap = fraction * std::max(face_margin_[a], face_margin_[b]);
                     PlaneSides sides;
                     if (triangles_apart(cloth_planes_, a, cloth_faces_, x, end, cloth_planes_, b, cloth_faces_, x,
                                         end, gap, !swept, sides, shift))
                       return;
                     const Sweep sweep{&x, &end, &x, &end, gap, &sides, shift};
                     expand_triangle_pair(a, b, -1, filter, out, &sweep);
                   });
    frame.self_collision_seconds += self_timer.seconds();
  }
  // Every body's candidates first (each traversal in parallel), then one parallel pass over all
  // of them, body after body: the list is the bodies' lists concatenated, as one pass per body
  // would give, without a parallel region and its tail per body.
  const size_t body_count = bodies_.size();
  body_candidates_.resize(body_count);
  candidate_start_.assign(body_count + 1, 0);
  body_plain_.assign(body_count, 1);
  vertex_bodies_.clear();
  for (size_t b = 0; b < body_count; ++b) {
    candidate_start_[b + 1] = candidate_start_[b];
    if (!bodies_[b].collide) continue;
    const Positions& body_start = step.body_start[b];
    const Positions& body_end = swept ? step.body_end[b] : body_start;
    body_candidates_[b].clear();
    // A body the contact constraints looked at (CollisionStep::sharp_edges): its pairs are
    // found point by point below, where no GIA membrane or pinch asks about single features.
    if (!swept && step.sharp_edges != nullptr && filter.skips_nothing(static_cast<int>(b))) {
      refit_body(static_cast<int>(b), body_start, body_start);
      fit_body_planes(static_cast<int>(b), body_start, body_start);
      vertex_bodies_.push_back(static_cast<int>(b));
      continue;
    }
    const Body& state = refit_body(static_cast<int>(b), body_start, body_end);
    if (swept && body_shift_[b] != Vec3::Zero())
      cloth_tree_.pairs(state.tree, body_shift_[b], body_candidates_[b], threads_);
    else
      cloth_tree_.pairs(state.tree, body_candidates_[b], threads_);
    fit_body_planes(static_cast<int>(b), body_start, body_end);
    body_plain_[b] = filter.skips_nothing(static_cast<int>(b));
    candidate_start_[b + 1] += static_cast<std::int64_t>(body_candidates_[b].size());
  }
  ordered_append(candidate_start_[body_count], kExpandChunk, threads_, pairs, chunk_pairs_,
                 [&](std::int64_t k, std::vector<FeaturePair>& out) {
                   const auto b = static_cast<size_t>(
                       std::upper_bound(candidate_start_.begin(), candidate_start_.end(), k) - candidate_start_.begin() - 1);
                   const auto [cf, bf] = body_candidates_[b][static_cast<size_t>(k - candidate_start_[b])];
                   if (!face_collide_[cf]) return;
                   const int body = static_cast<int>(b);
                   const Positions& body_start = step.body_start[b];
                   const Positions& body_end = swept ? step.body_end[b] : body_start;
                   const double gap = fraction * face_margin_[cf];
                   const Vec3* shift = swept && body_shift_[b] != Vec3::Zero() ? &body_shift_[b] : nullptr;
                   PlaneSides sides;
                   if (triangles_apart(cloth_planes_, cf, cloth_faces_, x, end, bodies_[b].planes, bf, bodies_[b].faces,
                                       body_start, body_end, gap, !swept, sides, shift))
                     return;
                   const size_t first = out.size();
                   const Sweep sweep{&x, &end, &body_start, &body_end, gap, &sides, shift};
                   expand_triangle_pair(cf, bf, body, filter, out, &sweep);
                   if (!body_plain_[b] && filter.pinched_face(cf, body))  // cloth in a body/body pinch: no CCD
                     for (size_t j = first; j < out.size(); ++j) out[j].ccd = false;
                 });
  if (!vertex_bodies_.empty()) point_pairs(x, step, pairs);
  swept_cloth_current_ = swept;
  frame.broad_phase_pairs += static_cast<int>(pairs.size());
  frame.broad_phase_seconds += timer.seconds();
}

void ContactDetection::collect_changed(CollisionStep& step, const ContactFilter& filter, CollisionTelemetry& frame) {
  const Timer timer;
  const Positions& x = *step.x;
  const Positions& end = step.x_end;
  const double fraction = kCcdSeparationFraction;
  std::vector<FeaturePair>& pairs = step.pairs;
  pairs.clear();
  const int face_count = static_cast<int>(cloth_faces_.rows());
  face_changed_.assign(face_count, 0);
  changed_faces_.clear();
  for (int f = 0; f < face_count; ++f)
    if (step.changed[cloth_faces_(f, 0)] || step.changed[cloth_faces_(f, 1)] || step.changed[cloth_faces_(f, 2)]) {
      face_changed_[f] = 1;
      changed_faces_.push_back(f);
    }
  // Since the last swept collect (or collect_changed) of this step only the changed vertices'
  // end positions moved: only their faces' boxes, planes and culling cones are redone.
  const bool incremental = swept_cloth_current_;
  if (incremental) {
    if (scaled_margin_.size() != face_margin_.size()) scaled_margin_.resize(face_margin_.size());
    for (int f : changed_faces_) {
      scaled_margin_[f] = fraction * face_margin_[f];
      if (cloth_tree_.moving()) {
        cloth_end_boxes_[f] = triangle_box(cloth_faces_, end, end, scaled_margin_, f);
        cloth_boxes_[f] = cloth_start_boxes_[f];
        cloth_boxes_[f].expand(cloth_end_boxes_[f]);
      } else {
        cloth_boxes_[f] = triangle_box(cloth_faces_, x, end, scaled_margin_, f);
      }
    }
    if (cloth_tree_.moving())
      cloth_tree_.refit(cloth_start_boxes_, cloth_end_boxes_, threads_);
    else
      cloth_tree_.refit(cloth_boxes_, threads_);
    cloth_planes_.compute_faces(cloth_faces_, x, end, changed_faces_);
  } else {
    // The sweep frames of the step's swept collect stay (any frame lists every pair that can
    // come within the gap).
    const bool shifted = self_shift_ != Vec3::Zero() ||
                         std::any_of(body_shift_.begin(), body_shift_.end(), [](const Vec3& s) { return s != Vec3::Zero(); });
    refit_cloth(x, end, fraction, shifted);
    cloth_planes_.compute(cloth_faces_, x, end, threads_);
  }
  const auto changed_count = static_cast<std::int64_t>(changed_faces_.size());
  if (any_self_ && changed_count > 0) {
    const Timer self_timer;
    leaf_culled_top_.clear();
    if (self_culling_) {
      if (incremental)
        culling_.update_changed(cloth_tree_, cloth_faces_, x, end, fraction * largest_margin_, face_changed_, threads_);
      else
        culling_.update(cloth_tree_, cloth_faces_, x, end, fraction * largest_margin_, threads_);
      cloth_tree_.topmost_marked(culling_.culled(), leaf_culled_top_);
    }
    const Vec3* shift = self_shift_ != Vec3::Zero() ? &self_shift_ : nullptr;
    ordered_append(changed_count, 16, threads_, pairs, chunk_pairs_, [&](std::int64_t k, std::vector<FeaturePair>& out) {
      const int a = changed_faces_[k];
      if (!face_self_[a]) return;
      auto expand = [&](int b) {
        // Each pair once: a changed partner takes it only from the smaller face.
        if (b == a || !face_self_[b] || (face_changed_[b] && b < a)) return;
        if (!leaf_culled_top_.empty() && leaf_culled_top_[a] >= 0 && leaf_culled_top_[a] == leaf_culled_top_[b]) return;
        const int lo = std::min(a, b), hi = std::max(a, b);
        const double gap = fraction * std::max(face_margin_[lo], face_margin_[hi]);
        PlaneSides sides;
        if (triangles_apart(cloth_planes_, lo, cloth_faces_, x, end, cloth_planes_, hi, cloth_faces_, x, end, gap, false,
                            sides, shift))
          return;
        const Sweep sweep{&x, &end, &x, &end, gap, &sides, shift};
        expand_triangle_pair(lo, hi, -1, filter, out, &sweep);
      };
      // The face's box less the self shrink (AabbTree::self_pairs'): a face a self pair is wanted
      // with has a box that overlaps a's by that much.
      Aabb box = shift ? shifted_cloth_box(a, *shift) : cloth_boxes_[a];
      box.inflate(-fraction * self_shrink_);
      if (shift)
        cloth_tree_.query(box, *shift, expand);
      else
        cloth_tree_.query(box, expand);
    });
    frame.self_collision_seconds += self_timer.seconds();
  }
  if (changed_count > 0 && any_body_) {
    body_plain_.assign(bodies_.size(), 1);
    for (size_t b = 0; b < bodies_.size(); ++b) {
      if (!bodies_[b].collide) continue;
      // Current since the step's swept collect (the body does not move within a step): kept.
      refit_body(static_cast<int>(b), step.body_start[b], step.body_end[b]);
      fit_body_planes(static_cast<int>(b), step.body_start[b], step.body_end[b]);
      body_plain_[b] = filter.skips_nothing(static_cast<int>(b));
    }
    // One parallel pass over (body, changed face), body after body: the per-body passes' lists
    // concatenated.
    const auto body_count = static_cast<std::int64_t>(bodies_.size());
    ordered_append(body_count * changed_count, 16, threads_, pairs, chunk_pairs_,
                   [&](std::int64_t k, std::vector<FeaturePair>& out) {
                     const auto b = static_cast<size_t>(k / changed_count);
                     const Body& state = bodies_[b];
                     const int cf = changed_faces_[static_cast<size_t>(k % changed_count)];
                     if (!state.collide || !face_collide_[cf]) return;
                     const int body = static_cast<int>(b);
                     const Positions& body_start = step.body_start[b];
                     const Positions& body_end = step.body_end[b];
                     const Vec3* shift = body_shift_[b] != Vec3::Zero() ? &body_shift_[b] : nullptr;
                     auto expand = [&](int bf) {
                       const double gap = fraction * face_margin_[cf];
                       PlaneSides sides;
                       if (triangles_apart(cloth_planes_, cf, cloth_faces_, x, end, state.planes, bf, state.faces,
                                           body_start, body_end, gap, false, sides, shift))
                         return;
                       const size_t first = out.size();
                       const Sweep sweep{&x, &end, &body_start, &body_end, gap, &sides, shift};
                       expand_triangle_pair(cf, bf, body, filter, out, &sweep);
                       if (!body_plain_[b] && filter.pinched_face(cf, body))
                         for (size_t j = first; j < out.size(); ++j) out[j].ccd = false;
                     };
                     if (shift == nullptr) {
                       state.tree.query(cloth_boxes_[cf], expand);
                     } else {
                       state.tree.query(shifted_cloth_box(cf, *shift), *shift, expand);
                     }
                   });
  }
  // Boxes and planes are now those of this pass; the culling too where it was updated.
  swept_cloth_current_ = incremental || !any_self_ || !self_culling_ || changed_count > 0;
  frame.broad_phase_pairs += static_cast<int>(pairs.size());
  frame.broad_phase_seconds += timer.seconds();
}

}  // namespace weft
