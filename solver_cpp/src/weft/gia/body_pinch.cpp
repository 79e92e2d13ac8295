#include "weft/gia/body_pinch.h"

#include <algorithm>

#include <omp.h>

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

BodyPinchTracker::BodyPinchTracker(std::vector<int> bodies, int threads, const PinchTracking& tracking)
    : bodies_(std::move(bodies)), threads_(threads) {
  std::sort(bodies_.begin(), bodies_.end());
  auto group_of = [&](int b) { return b < static_cast<int>(tracking.group.size()) ? tracking.group[b] : -1; };
  auto offset_of = [&](int b) {
    return b < static_cast<int>(tracking.body_offset.size()) ? tracking.body_offset[b] : 0.0;
  };
  for (size_t i = 0; i < bodies_.size(); ++i)
    for (size_t j = i + 1; j < bodies_.size(); ++j) {
      BodyPairPinch p;
      p.a = bodies_[i];
      p.b = bodies_[j];
      p.parts = group_of(p.a) >= 0 && group_of(p.a) == group_of(p.b);
      if (p.parts ? !(tracking.part_gap > 0.0) : !tracking.body_pairs) continue;
      if (p.parts) {
        p.gap = tracking.part_gap + offset_of(p.a) + offset_of(p.b);
        half_gap_ = std::max(half_gap_, 0.5 * p.gap);
      }
      pairs_.push_back(p);
    }
}

void BodyPinchTracker::evaluate(const std::vector<const Positions*>& x, const std::vector<const Faces*>& faces,
                                std::vector<PartSurface>& surfaces, const std::vector<char>& wanted,
                                std::vector<BodyIntersection>& out) {
  const int n = static_cast<int>(pairs_.size());
  out.assign(n, {});
  // Bodies that are not parts: the exact test, serial in pair order (each test threaded).
  for (int k = 0; k < n; ++k)
    if (wanted[k] && !pairs_[k].parts) {
      const BodyPairPinch& p = pairs_[k];
      out[k] = body_intersection(*x[p.a], *faces[p.a], *x[p.b], *faces[p.b], threads_);
    }
  // Parts: their vertex boxes, the surfaces of the parts in a pair whose boxes (grown by the
  // gap) overlap, then those pairs' facing gaps; each loop's items on their own, so the same
  // for any thread count.
  const int threads = threads_ > 0 ? threads_ : omp_get_max_threads();
  const auto body_count = static_cast<int>(x.size());
  std::vector<char> used(body_count, 0);
  for (int k = 0; k < n; ++k)
    if (wanted[k] && pairs_[k].parts) used[pairs_[k].a] = used[pairs_[k].b] = 1;
  auto listed = [&](const std::vector<char>& mark) {
    std::vector<int> list;
    for (int b = 0; b < body_count; ++b)
      if (mark[b]) list.push_back(b);
    return list;
  };
  std::vector<Aabb> boxes(body_count);
  const std::vector<int> boxed = listed(used);
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads) if (threads > 1)
  for (int i = 0; i < static_cast<int>(boxed.size()); ++i) boxes[boxed[i]] = vertex_box(*x[boxed[i]], *faces[boxed[i]]);
  std::vector<char> fit(body_count, 0);
  std::vector<int> near;
  for (int k = 0; k < n; ++k) {
    const BodyPairPinch& p = pairs_[k];
    if (!wanted[k] || !p.parts || faces[p.a]->rows() == 0 || faces[p.b]->rows() == 0) continue;
    Aabb grown = boxes[p.a];
    grown.inflate(p.gap);
    if (!grown.overlaps(boxes[p.b])) continue;
    near.push_back(k);
    fit[p.a] = fit[p.b] = 1;
  }
  const std::vector<int> fitted = listed(fit);
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads) if (threads > 1)
  for (int i = 0; i < static_cast<int>(fitted.size()); ++i)
    surfaces[fitted[i]].fit(*x[fitted[i]], *faces[fitted[i]], half_gap_);
  for (int k : near) {
    BodyPairPinch& p = pairs_[k];
    if (p.yields < 0) p.yields = surfaces[p.a].volume() < surfaces[p.b].volume() ? p.a : p.b;
  }
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads) if (threads > 1)
  for (int i = 0; i < static_cast<int>(near.size()); ++i) {
    const BodyPairPinch& p = pairs_[near[i]];
    BodyIntersection& r = out[near[i]];
    r.region = facing_gap_region(surfaces[p.a], *x[p.a], *faces[p.a], surfaces[p.b], *x[p.b], *faces[p.b], p.gap);
    r.intersecting = (r.region.lo.array() <= r.region.hi.array()).all();
  }
}

int BodyPinchTracker::update(const std::vector<const Positions*>& start, const std::vector<const Positions*>& end,
                             const std::vector<const Faces*>& faces) {
  if (last_end_.size() < end.size()) last_end_.resize(end.size());
  if (start_surfaces_.size() < end.size()) {
    start_surfaces_.resize(end.size());
    end_surfaces_.resize(end.size());
  }
  std::vector<char> continues(end.size(), 0);  // starts exactly where the last update ended
  for (int b : bodies_)
    continues[b] = last_end_[b].rows() == start[b]->rows() && last_end_[b].size() > 0 && last_end_[b] == *start[b];
  std::vector<char> test_start(pairs_.size(), 0), test_end(pairs_.size(), 1);
  for (size_t k = 0; k < pairs_.size(); ++k) test_start[k] = !(continues[pairs_[k].a] && continues[pairs_[k].b]);
  std::vector<BodyIntersection> s, e;
  evaluate(start, faces, start_surfaces_, test_start, s);
  evaluate(end, faces, end_surfaces_, test_end, e);
  for (size_t k = 0; k < pairs_.size(); ++k) {
    BodyPairPinch& p = pairs_[k];
    if (test_start[k]) {
      p.start = s[k].intersecting;
      p.start_region = s[k].region;
    } else {
      p.start = p.end;
      p.start_region = p.end_region;
    }
    p.end = e[k].intersecting;
    p.end_region = e[k].region;
  }
  for (int b : bodies_) last_end_[b] = *end[b];
  return active_pairs();
}

int BodyPinchTracker::active_pairs() const {
  return static_cast<int>(
      std::count_if(pairs_.begin(), pairs_.end(), [](const BodyPairPinch& p) { return p.state() != PinchState::kFree; }));
}

void BodyPinchTracker::mark_faces(int body, const std::vector<Aabb>& cloth_boxes, double margin,
                                  std::vector<char>& out, const std::vector<char>* only) const {
  out.assign(cloth_boxes.size(), 0);
  for (size_t k = 0; k < pairs_.size(); ++k) {
    const BodyPairPinch& p = pairs_[k];
    if ((only && !(*only)[k]) || p.state() == PinchState::kFree || !gives_way(p, body)) continue;
    Aabb region = p.region();
    region.inflate(margin);
    for (size_t f = 0; f < cloth_boxes.size(); ++f)
      if (!out[f] && cloth_boxes[f].overlaps(region)) out[f] = 1;
  }
}

void BodyPinchTracker::mark_vertices(int body, const Positions& x, double margin, std::vector<char>& out,
                                     const std::vector<char>* only) const {
  out.assign(x.rows(), 0);
  for (size_t k = 0; k < pairs_.size(); ++k) {
    const BodyPairPinch& p = pairs_[k];
    if ((only && !(*only)[k]) || p.state() == PinchState::kFree || !gives_way(p, body)) continue;
    Aabb region = p.region();
    region.inflate(margin);
    for (int i = 0; i < x.rows(); ++i)
      if (!out[i] && (region.lo.array() <= x.row(i).transpose().array()).all() &&
          (x.row(i).transpose().array() <= region.hi.array()).all())
        out[i] = 1;
  }
}

}  // namespace weft
