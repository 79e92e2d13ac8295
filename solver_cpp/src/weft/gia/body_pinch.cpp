#include "weft/gia/body_pinch.h"

#include <algorithm>

#include "weft/gia/intersection_analysis.h"

namespace weft {

namespace {

Aabb vertex_box(const Positions& x, const Faces& f) {
  Aabb box;
  for (int t = 0; t < f.rows(); ++t)
    for (int k = 0; k < 3; ++k) box.expand(Vec3(row3(x, f(t, k))));
  return box;
}

}  // namespace

BodyIntersection body_intersection(const Positions& xa, const Faces& fa, const Positions& xb, const Faces& fb,
                                   int threads) {
  BodyIntersection r;
  if (fa.rows() == 0 || fb.rows() == 0 || !vertex_box(xa, fa).overlaps(vertex_box(xb, fb))) return r;
  GiaOptions options;
  options.colour = false;
  options.inside_test = true;  // only runs against closed meshes
  options.threads = threads;
  const GiaResult g = analyse_intersections(xa, fa, xb, fb, options);
  r.hits = static_cast<int>(g.hits.size());
  r.paths = static_cast<int>(g.paths.size());
  // The intersection volume is a polyhedron whose vertices are edge/face crossings and vertices
  // of one body inside the other: their box is the volume's box.
  for (const GiaHit& h : g.hits) r.region.expand(h.point);
  const Positions* x[2] = {&xa, &xb};
  for (int m = 0; m < 2; ++m) {
    const auto& inside = g.mesh[m].inside_other;
    for (size_t i = 0; i < inside.size(); ++i)
      if (inside[i]) r.region.expand(Vec3(row3(*x[m], static_cast<int>(i))));
  }
  r.intersecting = (r.region.lo.array() <= r.region.hi.array()).all();
  return r;
}

BodyPinchTracker::BodyPinchTracker(std::vector<int> bodies, int threads, const std::vector<int>& group)
    : bodies_(std::move(bodies)), threads_(threads) {
  std::sort(bodies_.begin(), bodies_.end());
  auto group_of = [&](int b) { return b < static_cast<int>(group.size()) ? group[b] : -1; };
  for (size_t i = 0; i < bodies_.size(); ++i)
    for (size_t j = i + 1; j < bodies_.size(); ++j) {
      if (group_of(bodies_[i]) >= 0 && group_of(bodies_[i]) == group_of(bodies_[j])) continue;
      BodyPairPinch p;
      p.a = bodies_[i];
      p.b = bodies_[j];
      pairs_.push_back(p);
    }
}

int BodyPinchTracker::update(const std::vector<const Positions*>& start, const std::vector<const Positions*>& end,
                             const std::vector<const Faces*>& faces) {
  if (last_end_.size() < end.size()) last_end_.resize(end.size());
  std::vector<char> continues(end.size(), 0);  // starts exactly where the last update ended
  for (int b : bodies_)
    continues[b] = last_end_[b].rows() == start[b]->rows() && last_end_[b].size() > 0 && last_end_[b] == *start[b];
  for (BodyPairPinch& p : pairs_) {  // serial, in pair order: deterministic
    if (continues[p.a] && continues[p.b]) {
      p.start = p.end;
      p.start_region = p.end_region;
    } else {
      const BodyIntersection s = body_intersection(*start[p.a], *faces[p.a], *start[p.b], *faces[p.b], threads_);
      p.start = s.intersecting;
      p.start_region = s.region;
    }
    const BodyIntersection e = body_intersection(*end[p.a], *faces[p.a], *end[p.b], *faces[p.b], threads_);
    p.end = e.intersecting;
    p.end_region = e.region;
  }
  for (int b : bodies_) last_end_[b] = *end[b];
  return active_pairs();
}

int BodyPinchTracker::active_pairs() const {
  return static_cast<int>(
      std::count_if(pairs_.begin(), pairs_.end(), [](const BodyPairPinch& p) { return p.state() != PinchState::kFree; }));
}

void BodyPinchTracker::mark_faces(int body, const std::vector<Aabb>& cloth_boxes, double margin,
                                  std::vector<char>& out) const {
  out.assign(cloth_boxes.size(), 0);
  for (const BodyPairPinch& p : pairs_) {
    if (p.state() == PinchState::kFree || (p.a != body && p.b != body)) continue;
    Aabb region = p.region();
    region.inflate(margin);
    for (size_t f = 0; f < cloth_boxes.size(); ++f)
      if (!out[f] && cloth_boxes[f].overlaps(region)) out[f] = 1;
  }
}

void BodyPinchTracker::mark_vertices(int body, const Positions& x, double margin, std::vector<char>& out) const {
  out.assign(x.rows(), 0);
  for (const BodyPairPinch& p : pairs_) {
    if (p.state() == PinchState::kFree || (p.a != body && p.b != body)) continue;
    Aabb region = p.region();
    region.inflate(margin);
    for (int i = 0; i < x.rows(); ++i)
      if (!out[i] && (region.lo.array() <= x.row(i).transpose().array()).all() &&
          (x.row(i).transpose().array() <= region.hi.array()).all())
        out[i] = 1;
  }
}

}  // namespace weft
