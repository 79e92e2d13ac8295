#include "weft/collision/collision_response.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>

#include "weft/collision/ccd.h"
#include "weft/gia/intersection_analysis.h"
#include "weft/geometry/intersection_count.h"

namespace weft {

namespace {
using Clock = std::chrono::steady_clock;
double since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

constexpr double kDefaultThickness = 0.002;
constexpr double kDefaultFriction = 0.3;
// Proximity: a pair closer than the thickness gets a normal velocity of at least this fraction
// of the missing separation per step (a stiff, damped repulsion, Bridson et al. 2002).
constexpr double kRepulsionRate = 0.1;
// CCD reports pairs that come closer than this fraction of the thickness ...
constexpr double kCcdSeparationFraction = 0.05;
// ... and its impulses aim for this separation at the end of the step.
constexpr double kTargetSeparationFraction = 0.1;
// GIA recovery: a contour vertex inside a body gets an outward normal velocity (relative to the
// body) of at least this fraction of (depth + thickness) per step.
constexpr double kRecoveryRate = 1.0;

struct UnionFind {
  std::vector<int> parent;
  explicit UnionFind(int n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  int find(int i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  }
  void unite(int a, int b) {
    a = find(a);
    b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

bool face_has(const Faces& faces, int f, int v) { return faces(f, 0) == v || faces(f, 1) == v || faces(f, 2) == v; }

}  // namespace

void CollisionTelemetry::add(const CollisionTelemetry& o) {
  broad_phase_seconds += o.broad_phase_seconds;
  proximity_seconds += o.proximity_seconds;
  ccd_seconds += o.ccd_seconds;
  response_seconds += o.response_seconds;
  intersection_seconds += o.intersection_seconds;
  gia_seconds += o.gia_seconds;
  gia_coloured_vertices = std::max(gia_coloured_vertices, o.gia_coloured_vertices);
  gia_pushed_vertices += o.gia_pushed_vertices;
  gia_paths = std::max(gia_paths, o.gia_paths);
  gia_body_coloured_faces = std::max(gia_body_coloured_faces, o.gia_body_coloured_faces);
  gia_pinched_body_pairs = std::max(gia_pinched_body_pairs, o.gia_pinched_body_pairs);
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

CollisionSystem::CollisionSystem(const Faces& cloth_faces, const Positions& x, const std::vector<double>& vertex_mass,
                                 const std::vector<int>& pinned_vertices, const std::vector<KinematicBody>& bodies,
                                 CollisionSettings settings, int threads)
    : settings_(std::move(settings)), cloth_faces_(cloth_faces), vertex_count_(static_cast<int>(x.rows())),
      threads_(std::max(threads, 1)) {
  const int face_count = static_cast<int>(cloth_faces_.rows());
  auto check_size = [face_count](size_t size, const char* name) {
    if (size != 0 && size != static_cast<size_t>(face_count))
      throw std::invalid_argument(std::string("collision.") + name + " has " + std::to_string(size) +
                                  " entries, expected one per face (" + std::to_string(face_count) + ")");
  };
  check_size(settings_.face_collide.size(), "face_collide");
  check_size(settings_.face_self_collide.size(), "face_self_collide");
  check_size(settings_.face_thickness.size(), "face_thickness");
  check_size(settings_.face_friction.size(), "face_friction");
  if (!settings_.body_collide.empty() && settings_.body_collide.size() != bodies.size())
    throw std::invalid_argument("collision.body_collide must have one entry per body");

  inverse_mass_.resize(vertex_count_);
  for (int i = 0; i < vertex_count_; ++i) inverse_mass_[i] = 1.0 / vertex_mass[i];
  for (int p : pinned_vertices) inverse_mass_[p] = 0.0;
  face_collide_ = settings_.face_collide.empty() ? std::vector<char>(face_count, 1) : settings_.face_collide;
  face_self_ = settings_.face_self_collide.empty() ? std::vector<char>(face_count, 0) : settings_.face_self_collide;
  any_self_ = std::any_of(face_self_.begin(), face_self_.end(), [](char c) { return c != 0; });

  vertex_thickness_.assign(vertex_count_, 0.0);
  vertex_friction_.assign(vertex_count_, 0.0);
  face_margin_.assign(face_count, 0.0);
  for (int f = 0; f < face_count; ++f) {
    const double th = settings_.face_thickness.size() ? settings_.face_thickness[f] : kDefaultThickness;
    const double mu = settings_.face_friction.size() ? settings_.face_friction[f] : kDefaultFriction;
    if (!(th > 0.0)) throw std::invalid_argument("collision thickness must be positive");
    for (int c = 0; c < 3; ++c) {
      vertex_thickness_[cloth_faces_(f, c)] = std::max(vertex_thickness_[cloth_faces_(f, c)], th);
      vertex_friction_[cloth_faces_(f, c)] = std::max(vertex_friction_[cloth_faces_(f, c)], mu);
    }
  }
  for (int f = 0; f < face_count; ++f)
    for (int c = 0; c < 3; ++c) face_margin_[f] = std::max(face_margin_[f], vertex_thickness_[cloth_faces_(f, c)]);
  default_thickness_ = *std::max_element(vertex_thickness_.begin(), vertex_thickness_.end());

  cloth_own_ = assign_features(cloth_faces_, vertex_count_);
  triangle_boxes(cloth_faces_, x, x, face_margin_, cloth_boxes_);
  cloth_tree_.build(cloth_boxes_);

  const bool cloth_collides = std::any_of(face_collide_.begin(), face_collide_.end(), [](char c) { return c != 0; });
  bodies_.resize(bodies.size());
  for (size_t b = 0; b < bodies.size(); ++b) {
    BodyState& state = bodies_[b];
    state.collide = cloth_collides && (settings_.body_collide.empty() || settings_.body_collide[b]);
    if (!state.collide) continue;
    any_body_ = true;
    state.faces = bodies[b].faces();
    state.own = assign_features(state.faces, bodies[b].vertex_count());
    triangle_boxes(state.faces, bodies[b].frame_start(), bodies[b].frame_start(), {}, state.boxes);
    state.tree.build(state.boxes);
    state.closed = build_gia_topology(bodies[b].vertex_count(), state.faces).closed;
  }

  // GIA switch: -1 resolves to on when the cloth starts in intersection with a closed body:
  // some cloth vertex inside it, or some cloth triangle through it (a patch pushed wholly
  // through a thin body has no vertex inside).
  for (int f = 0; f < face_count; ++f)
    if (face_collide_[f]) collide_face_ids_.push_back(f);
  collide_faces_.resize(static_cast<Eigen::Index>(collide_face_ids_.size()), 3);
  for (size_t k = 0; k < collide_face_ids_.size(); ++k) collide_faces_.row(k) = cloth_faces_.row(collide_face_ids_[k]);
  gia_ = settings_.gia > 0;
  if (settings_.gia < 0) {
    for (size_t b = 0; b < bodies_.size() && !gia_; ++b) {
      if (!bodies_[b].collide || !bodies_[b].closed) continue;
      const auto inside = points_inside_closed_mesh(x, bodies[b].frame_start(), bodies_[b].faces, threads_);
      gia_ = std::any_of(inside.begin(), inside.end(), [](std::int8_t c) { return c != 0; }) ||
             weft::count_intersections(x, cloth_faces_, bodies[b].frame_start(), bodies_[b].faces, face_collide_) > 0;
    }
    // ... or when the self-colliding cloth starts self-intersecting (exact count).
    if (!gia_ && any_self_) gia_ = count_self_intersections(x, cloth_faces_, face_self_) > 0;
  }
  if (gia_ && any_self_) untangle_ = ClothUntangling(cloth_faces_, face_self_, vertex_count_);
  if (gia_) {
    cloth_neighbours_.assign(vertex_count_, {});
    vertex_collide_.assign(vertex_count_, 0);
    for (int f = 0; f < face_count; ++f)
      for (int c = 0; c < 3; ++c) {
        const int a = cloth_faces_(f, c), b = cloth_faces_(f, (c + 1) % 3);
        cloth_neighbours_[a].push_back(b);
        cloth_neighbours_[b].push_back(a);
        if (face_collide_[f]) vertex_collide_[a] = 1;
      }
    for (auto& n : cloth_neighbours_) {
      std::sort(n.begin(), n.end());
      n.erase(std::unique(n.begin(), n.end()), n.end());
    }
  }
  std::vector<int> pinch_bodies;
  for (size_t b = 0; b < bodies_.size(); ++b)
    if (bodies_[b].collide) pinch_bodies.push_back(static_cast<int>(b));
  if (gia_ && settings_.body_pinch && pinch_bodies.size() >= 2) {
    pinch_ = std::make_unique<BodyPinchTracker>(pinch_bodies, threads_);
    pinch_gripped_.assign(bodies_.size(), std::vector<char>(vertex_count_, 0));
  }
}

void CollisionSystem::pinch_grip(int i, const BodyState& state) {
  // The velocity of the closest body point (lowest face id on ties): cloth squeezed into a body
  // by another moves with it, as friction of the squeeze would hold it.
  const Vec3 p = row3(*x_, i);
  double best = std::numeric_limits<double>::infinity();
  Vec3 vb = Vec3::Zero();
  for (int f = 0; f < state.faces.rows(); ++f) {
    Vec3 bary;
    const double d = point_triangle_distance(p, row3(state.start, state.faces(f, 0)), row3(state.start, state.faces(f, 1)),
                                             row3(state.start, state.faces(f, 2)), bary);
    if (!(d < best)) continue;
    best = d;
    vb.setZero();
    for (int k = 0; k < 3; ++k) {
      const int bv = state.faces(f, k);
      vb += bary[k] * (row3(state.end, bv) - row3(state.start, bv)) / h_;
    }
  }
  v_->row(i) = vb.transpose();
  x_end_.row(i) = x_->row(i) + h_ * v_->row(i);
  ++frame_.gia_gripped_vertices;
}

void CollisionSystem::pinch_update() {
  const auto start = Clock::now();
  std::vector<const Positions*> s(bodies_.size(), nullptr), e(bodies_.size(), nullptr);
  std::vector<const Faces*> f(bodies_.size(), nullptr);
  for (size_t b = 0; b < bodies_.size(); ++b) {
    s[b] = &bodies_[b].start;
    e[b] = &bodies_[b].end;
    f[b] = &bodies_[b].faces;
  }
  const int active = pinch_->update(s, e, f);
  frame_.gia_pinched_body_pairs = std::max(frame_.gia_pinched_body_pairs, active);
  pinch_faces_.assign(bodies_.size(), {});
  pinch_held_.assign(bodies_.size(), {});
  // Cloth faces already through a body (left by a pinch: the other body's rim cuts them while
  // CCD is off) get no CCD against it either: CCD can only keep such an intersection, so after
  // the pinch opens it would lock the tangle. Exact test on the broad phase's candidates.
  triangle_boxes(cloth_faces_, *x_, x_end_, face_margin_, cloth_boxes_);
  cloth_tree_.refit(cloth_boxes_);
  for (size_t b = 0; b < bodies_.size(); ++b) {
    BodyState& state = bodies_[b];
    if (!state.collide) continue;
    body_triangle_pairs(static_cast<int>(b), false);
    for (const auto& [cf, bf] : scratch_pairs_) {
      if (!face_collide_[cf] || (!pinch_faces_[b].empty() && pinch_faces_[b][cf])) continue;
      const std::array<Vec3, 3> tc = {row3(*x_, cloth_faces_(cf, 0)), row3(*x_, cloth_faces_(cf, 1)),
                                      row3(*x_, cloth_faces_(cf, 2))};
      const std::array<Vec3, 3> tb = {row3(state.start, state.faces(bf, 0)), row3(state.start, state.faces(bf, 1)),
                                      row3(state.start, state.faces(bf, 2))};
      if (!triangles_intersect(tc, tb)) continue;
      if (pinch_faces_[b].empty()) pinch_faces_[b].assign(cloth_faces_.rows(), 0);
      pinch_faces_[b][cf] = 1;
    }
  }
  if (active > 0) {
    // Two thicknesses: cloth within one of the intersection volume touches both bodies, and
    // recovery or proximity leaves cloth one thickness outside a body face bounding the volume
    // (at the region's edge, where rounding would put it in or out step by step).
    const double margin = 2.0 * default_thickness_;
    for (size_t b = 0; b < bodies_.size(); ++b) {
      if (!bodies_[b].collide) continue;
      std::vector<char> region;
      pinch_->mark_faces(static_cast<int>(b), cloth_boxes_, margin, region);
      if (pinch_faces_[b].empty()) pinch_faces_[b].swap(region);
      else
        for (size_t f = 0; f < region.size(); ++f) pinch_faces_[b][f] |= region[f];
      pinch_->mark_vertices(static_cast<int>(b), *x_, margin, pinch_held_[b]);
    }
  }
  frame_.gia_seconds += since(start);
}

void CollisionSystem::gia_clear() {
  for (BodyState& state : bodies_) state.clear_gia();
  untangle_.clear();
}

bool CollisionSystem::gia_colour(const Positions& x) {
  const auto start = Clock::now();
  int coloured_count = 0, paths = 0, body_faces = 0;
  GiaOptions options;
  options.threads = threads_;
  for (BodyState& state : bodies_) {
    state.clear_gia();
    if (!state.collide || !state.closed) continue;
    // Cloth side: the exact inside test (ray parity). Body side: the parity colouring of the
    // body over all separating paths, so a body segment that passes wholly through the cloth
    // (a patch pushed through a thin bone) is marked even though no cloth vertex is inside.
    const GiaResult gia = analyse_intersections(x, collide_faces_, state.start, state.faces, options);
    paths += static_cast<int>(gia.paths.size());
    const GiaMeshColouring& cloth = gia.mesh[0];
    const GiaMeshColouring& body = gia.mesh[1];
    state.inside.assign(cloth.inside_other.begin(), cloth.inside_other.end());
    if (state.inside.empty()) state.inside.assign(vertex_count_, 0);
    const int faces = static_cast<int>(state.faces.rows());
    state.face_coloured.assign(faces, 0);
    for (int f = 0; f < faces; ++f) {
      int coloured_corners = 0;
      for (int k = 0; k < 3; ++k) coloured_corners += body.vertex_parity_colour[state.faces(f, k)] != 0;
      // Pierced faces with no coloured corner stay closed to the membrane (see expand_triangle_pair).
      state.face_coloured[f] = coloured_corners == 3 ? 3 : coloured_corners > 0 ? 2 : body.face_colour[f] == kGiaContour ? 1 : 0;
      body_faces += state.face_coloured[f] != 0;
    }
    state.cloth_face_contour.assign(cloth_faces_.rows(), 0);
    for (size_t k = 0; k < collide_face_ids_.size(); ++k)
      state.cloth_face_contour[collide_face_ids_[k]] = cloth.face_colour[k] == kGiaContour;
    for (int i = 0; i < vertex_count_; ++i)
      if (state.inside[i] && vertex_collide_[i]) ++coloured_count;
  }
  frame_.gia_coloured_vertices = std::max(frame_.gia_coloured_vertices, coloured_count);
  frame_.gia_paths = std::max(frame_.gia_paths, paths);
  frame_.gia_body_coloured_faces = std::max(frame_.gia_body_coloured_faces, body_faces);
  frame_.gia_seconds += since(start);
  return paths > 0 || coloured_count > 0;
}

void CollisionSystem::gia_untangle() {
  const auto start = Clock::now();
  untangle_.analyse(*x_, threads_);
  frame_.gia_self_coloured_vertices = std::max(frame_.gia_self_coloured_vertices, untangle_.coloured_count());
  frame_.gia_self_paths = std::max(frame_.gia_self_paths, untangle_.path_count());
  if (untangle_.pull(*x_, *v_, h_, inverse_mass_, vertex_thickness_) > 0) x_end_ = *x_ + h_ * *v_;
  frame_.gia_seconds += since(start);
}

void CollisionSystem::gia_recover() {
  const auto start = Clock::now();
  int pushed = 0;
  for (BodyState& state : bodies_) {
    if (state.inside.empty()) continue;
    // One exit direction per connected coloured region: the mean, over its contour, of the
    // directions from contour vertices to their uncoloured neighbours (so a region leaves on
    // one side, not spread sideways).
    UnionFind regions(vertex_count_);
    for (int i = 0; i < vertex_count_; ++i)
      if (state.inside[i])
        for (int j : cloth_neighbours_[i])
          if (state.inside[j]) regions.unite(i, j);
    // Body/body pinch (body_pinch.h): a coloured region with a vertex where this body and another
    // intersect is gripped: it moves with the body (pushed out of one body it would go into the
    // other) until they open, then leaves through the nearest face.
    const int body = static_cast<int>(&state - bodies_.data());
    std::vector<char> held;
    std::vector<char>* gripped = pinch_ ? &pinch_gripped_[body] : nullptr;
    if (gripped) {
      for (int i = 0; i < vertex_count_; ++i) {
        if (!state.inside[i]) (*gripped)[i] = 0;
        else if (pinched_vertex(i, body)) {
          if (held.empty()) held.assign(vertex_count_, 0);
          held[regions.find(i)] = 1;
        }
      }
    }
    std::vector<Vec3> region_towards(vertex_count_, Vec3::Zero());
    for (int i = 0; i < vertex_count_; ++i)
      if (state.inside[i])
        for (int j : cloth_neighbours_[i])
          if (!state.inside[j]) region_towards[regions.find(i)] += row3(*x_, j) - row3(*x_, i);
    for (int i = 0; i < vertex_count_; ++i) {
      if (!state.inside[i] || !vertex_collide_[i] || inverse_mass_[i] == 0.0) continue;
      if (!held.empty() && held[regions.find(i)]) {
        (*gripped)[i] = 1;
        pinch_grip(i, state);
        continue;
      }
      const bool released = gripped && (*gripped)[i];  // was gripped: every vertex, nearest face
      // Contour vertices only (an uncoloured neighbour); deep ones follow through the cloth.
      const bool contour = std::any_of(cloth_neighbours_[i].begin(), cloth_neighbours_[i].end(),
                                       [&](int j) { return !state.inside[j]; });
      if (!contour && !released) continue;
      // Exit on the side of the uncoloured neighbours: along the region's direction, through
      // the first body face that ray crosses; else (no such direction or face) through the
      // nearest body face. Lowest face id on ties: deterministic.
      const Vec3 p = row3(*x_, i);
      const Vec3 towards = released ? Vec3::Zero() : region_towards[regions.find(i)];
      const int body_faces = static_cast<int>(state.faces.rows());
      auto corner = [&](int f, int k) { return row3(state.start, state.faces(f, k)); };
      double best = std::numeric_limits<double>::infinity();
      int best_face = -1;
      Vec3 best_bary = Vec3::Zero();
      Vec3 n = Vec3::Zero();
      if (towards.norm() > 1e-9 * vertex_thickness_[i]) {
        const Vec3 dir = towards.normalized();
        for (int f = 0; f < body_faces; ++f) {  // Moller-Trumbore
          const Vec3 a = corner(f, 0), e1 = corner(f, 1) - a, e2 = corner(f, 2) - a;
          const Vec3 pv = dir.cross(e2);
          const double det = e1.dot(pv);
          if (std::abs(det) <= 1e-300) continue;
          const Vec3 tv = p - a;
          const double u = tv.dot(pv) / det;
          const Vec3 qv = tv.cross(e1);
          const double w = dir.dot(qv) / det;
          const double t = e2.dot(qv) / det;
          // A small tolerance so that a ray through a shared edge or corner is not missed.
          constexpr double kEdge = 1e-9;
          if (u < -kEdge || w < -kEdge || u + w > 1.0 + kEdge || !(t > 0.0) || t >= best) continue;
          best = t;
          best_face = f;
          best_bary = Vec3(1.0 - u - w, u, w).cwiseMax(0.0);
          best_bary /= best_bary.sum();
        }
        if (best_face >= 0) n = dir;
      }
      if (best_face < 0) {
        for (int f = 0; f < body_faces; ++f) {
          Vec3 bary;
          const double d = point_triangle_distance(p, corner(f, 0), corner(f, 1), corner(f, 2), bary);
          if (d < best) {
            best = d;
            best_face = f;
            best_bary = bary;
          }
        }
      }
      // Proximity gating (the seed's rule): respond only when the face the vertex would exit
      // through is itself in intersection with the cloth; exiting through a free face would
      // put the cloth on the wrong side of the body.
      // Cloth released by an opened pinch leaves through the nearest face whatever its colour:
      // it was gripped by this body, so the side it entered from is not known.
      if (best_face < 0 || (!released && !state.face_coloured[best_face])) continue;
      Vec3 q = Vec3::Zero(), vb = Vec3::Zero();
      for (int k = 0; k < 3; ++k) {
        const int bv = state.faces(best_face, k);
        q += best_bary[k] * row3(state.start, bv);
        vb += best_bary[k] * (row3(state.end, bv) - row3(state.start, bv)) / h_;
      }
      if (n.squaredNorm() == 0.0) n = q - p;
      if (n.norm() <= 1e-12) continue;  // on the surface with no direction to leave by
      n.normalize();
      const double target = kRecoveryRate * (best + vertex_thickness_[i]) / h_;
      const double vn = n.dot(row3(*v_, i) - vb);
      if (vn >= target) continue;
      v_->row(i) += ((target - vn) * n).transpose();
      x_end_.row(i) = x_->row(i) + h_ * v_->row(i);
      ++pushed;
    }
  }
  frame_.gia_pushed_vertices += pushed;
  frame_.gia_seconds += since(start);
}

Vec3 CollisionSystem::start_of(int p, int body) const {
  return p >= 0 ? row3(*x_, p) : row3(bodies_[body].start, -1 - p);
}
Vec3 CollisionSystem::end_of(int p, int body) const {
  return p >= 0 ? row3(x_end_, p) : row3(bodies_[body].end, -1 - p);
}
Vec3 CollisionSystem::velocity_of(int p, int body) const {
  return p >= 0 ? row3(*v_, p) : Vec3((row3(bodies_[body].end, -1 - p) - row3(bodies_[body].start, -1 - p)) / h_);
}

double CollisionSystem::pair_thickness(const FeaturePair& pair) const {
  double th = 0.0;
  for (int p : pair.point)
    if (p >= 0) th = std::max(th, vertex_thickness_[p]);
  return th > 0.0 ? th : default_thickness_;
}

double CollisionSystem::pair_friction(const FeaturePair& pair) const {
  double mu = 0.0;
  for (int p : pair.point)
    if (p >= 0) mu = std::max(mu, vertex_friction_[p]);
  return mu;
}

void CollisionSystem::expand_triangle_pair(int cf, int of, int body, std::vector<FeaturePair>& out) const {
  if (body < 0) {
    // Cloth/cloth GIA one-way membrane (cloth_untangling.h): triangle pairs across an
    // intersection are skipped, so regions in intersection can pass back; clean cloth cannot enter.
    if (untangle_.skip_triangle_pair(cf, of)) return;
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
  const BodyState& b = bodies_[body];
  auto bv = [](int k) { return -1 - k; };
  // GIA one-way membrane, body side (BodyState::face_coloured), so a body segment that went
  // through the cloth can come back out: a body face wholly in the body's coloured region lets
  // all cloth pass; one with some coloured corner, or only pierced, lets pass the cloth
  // triangles on the contour (pierced by the body or piercing it), so cloth away from the
  // intersection still cannot enter. Pierced-only faces stay closed in a body/body pinch
  // region: the squeezed cloth is on the contour of both bodies there, and opening a coarse
  // body's pierced faces (a box's top) let it sink into the lower box.
  const int body_colour = body_face_colour(of, body);
  const bool in_pinch = !pinch_faces_.empty() && !pinch_faces_[body].empty() && pinch_faces_[body][cf];
  if (body_colour == 3 || (body_colour >= 1 && cloth_face_contour(cf, body) && (body_colour == 2 || !in_pinch))) return;
  // GIA one-way membrane: features with a cloth vertex coloured inside this body are skipped.
  for (int v : cloth_own_.face_vertices[cf])
    if (!coloured(v, body))
      out.push_back({{v, bv(b.faces(of, 0)), bv(b.faces(of, 1)), bv(b.faces(of, 2))}, body, false});
  const bool face_coloured =
      coloured(cloth_faces_(cf, 0), body) || coloured(cloth_faces_(cf, 1), body) || coloured(cloth_faces_(cf, 2), body);
  if (!face_coloured)
    for (int k : b.own.face_vertices[of])
      out.push_back({{bv(k), cloth_faces_(cf, 0), cloth_faces_(cf, 1), cloth_faces_(cf, 2)}, body, false});
  for (const auto& e1 : cloth_own_.face_edges[cf])
    if (!coloured(e1[0], body) && !coloured(e1[1], body))
      for (const auto& e2 : b.own.face_edges[of]) out.push_back({{e1[0], e1[1], bv(e2[0]), bv(e2[1])}, body, true});
}

void CollisionSystem::body_triangle_pairs(int body, bool swept) {
  BodyState& state = bodies_[body];
  triangle_boxes(state.faces, state.start, swept ? state.end : state.start, {}, state.boxes);
  state.tree.refit(state.boxes);
  scratch_pairs_.clear();
  cloth_tree_.pairs(state.tree, scratch_pairs_);
}

void CollisionSystem::collect_pairs() {
  const auto start = Clock::now();
  triangle_boxes(cloth_faces_, *x_, x_end_, face_margin_, cloth_boxes_);
  cloth_tree_.refit(cloth_boxes_);
  pairs_.clear();
  if (any_self_) {
    scratch_pairs_.clear();
    cloth_tree_.self_pairs(scratch_pairs_);
    for (const auto& [a, b] : scratch_pairs_)
      if (face_self_[a] && face_self_[b]) expand_triangle_pair(a, b, -1, pairs_);
  }
  for (size_t b = 0; b < bodies_.size(); ++b) {
    if (!bodies_[b].collide) continue;
    body_triangle_pairs(static_cast<int>(b), true);
    const std::vector<char>* pinched = pinch_faces_.empty() || pinch_faces_[b].empty() ? nullptr : &pinch_faces_[b];
    for (const auto& [cf, bf] : scratch_pairs_) {
      if (!face_collide_[cf]) continue;
      const size_t first = pairs_.size();
      expand_triangle_pair(cf, bf, static_cast<int>(b), pairs_);
      if (pinched && (*pinched)[cf])  // cloth in a body/body pinch: proximity only, no CCD
        for (size_t k = first; k < pairs_.size(); ++k) pairs_[k].ccd = false;
    }
  }
  frame_.broad_phase_seconds += since(start);
}

void CollisionSystem::apply_impulse(const FeaturePair& pair, const std::array<double, 4>& w, const Vec3& n,
                                    double delta_vn, double friction) {
  double denominator = 0.0;
  Vec3 v_rel = Vec3::Zero();
  for (int i = 0; i < 4; ++i) {
    denominator += w[i] * w[i] * inverse_mass_of(pair.point[i]);
    v_rel += w[i] * velocity_of(pair.point[i], pair.body);
  }
  if (!(denominator > 0.0)) return;
  const Vec3 v_t = v_rel - n.dot(v_rel) * n;
  const double vt_norm = v_t.norm();
  Vec3 delta = delta_vn * n;
  if (friction > 0.0 && vt_norm > 0.0) delta += (std::max(0.0, 1.0 - friction * delta_vn / vt_norm) - 1.0) * v_t;
  for (int i = 0; i < 4; ++i) {
    const int p = pair.point[i];
    if (p < 0 || inverse_mass_[p] == 0.0) continue;
    v_->row(p) += (inverse_mass_[p] * w[i] / denominator) * delta.transpose();
    x_end_.row(p) = x_->row(p) + h_ * v_->row(p);
    changed_[p] = 1;
  }
}

namespace {

// Closest points of a pair in one configuration: weights w (sum w_i x_i is the gap vector from
// the second primitive to the first) and the distance.
double pair_weights(const std::array<Vec3, 4>& x, bool edge_edge, std::array<double, 4>& w) {
  if (edge_edge) {
    double s, t;
    const double d = segment_segment_distance(x[0], x[1], x[2], x[3], s, t);
    w = {1.0 - s, s, -(1.0 - t), -t};
    return d;
  }
  Vec3 bary;
  const double d = point_triangle_distance(x[0], x[1], x[2], x[3], bary);
  w = {1.0, -bary[0], -bary[1], -bary[2]};
  return d;
}

// Whether the boxes of the pair's two primitives (over one or two configurations) come within
// `gap` of each other: a cheap filter before distance and CCD tests.
bool boxes_within(const std::array<Vec3, 4>& s, const std::array<Vec3, 4>& e, bool edge_edge, double gap) {
  const int split = edge_edge ? 2 : 1;
  Aabb first, second;
  for (int i = 0; i < 4; ++i) {
    Aabb& box = i < split ? first : second;
    box.expand(s[i]);
    box.expand(e[i]);
  }
  first.inflate(gap);
  return first.overlaps(second);
}

Vec3 combine(const std::array<Vec3, 4>& x, const std::array<double, 4>& w) {
  return w[0] * x[0] + w[1] * x[1] + w[2] * x[2] + w[3] * x[3];
}

// A contact normal pointing from the second primitive to the first: the gap direction when the
// gap is resolvable, else the geometric normal oriented by `side` (a vector known to point to
// the first primitive's side), else -side.
Vec3 contact_normal(const std::array<Vec3, 4>& x, bool edge_edge, const Vec3& gap, double distance, double scale,
                    const Vec3& side) {
  if (distance > 1e-9 * scale) return gap / distance;
  Vec3 n = edge_edge ? Vec3((x[1] - x[0]).cross(x[3] - x[2])) : Vec3((x[2] - x[1]).cross(x[3] - x[1]));
  const double norm = n.norm();
  if (norm > 0.0) {
    n /= norm;
    return n.dot(side) < 0.0 ? Vec3(-n) : n;
  }
  const double side_norm = side.norm();
  return side_norm > 0.0 ? Vec3(side / side_norm) : Vec3(0, 0, 1);
}

}  // namespace

int CollisionSystem::proximity_pass() {
  const auto start = Clock::now();
  int count = 0;
  for (const FeaturePair& pair : pairs_) {
    const double th = pair_thickness(pair);
    std::array<Vec3, 4> s;
    for (int i = 0; i < 4; ++i) s[i] = start_of(pair.point[i], pair.body);
    if (!boxes_within(s, s, pair.edge_edge, th)) continue;
    std::array<double, 4> w;
    const double d = pair_weights(s, pair.edge_edge, w);
    if (d >= th) continue;
    Vec3 v_rel = Vec3::Zero();
    for (int i = 0; i < 4; ++i) v_rel += w[i] * velocity_of(pair.point[i], pair.body);
    const Vec3 n = contact_normal(s, pair.edge_edge, combine(s, w), d, th, -v_rel);
    const double vn = n.dot(v_rel);
    const double target = kRepulsionRate * (th - d) / h_;
    if (vn < target) {
      apply_impulse(pair, w, n, target - vn, pair_friction(pair));
      ++count;
    }
  }
  frame_.proximity_pairs += count;
  frame_.proximity_seconds += since(start);
  return count;
}

int CollisionSystem::ccd_pass(bool apply, std::vector<int>* hits, bool incremental) {
  auto start = Clock::now();
  const int count = static_cast<int>(pairs_.size());
  std::vector<char> dirty(vertex_count_, 0);
  dirty.swap(changed_);
  std::vector<char> hit(count, 0);
  std::vector<double> toi(count, 1.0);
  auto run = [&](int k) {
    const FeaturePair& pair = pairs_[k];
    if (!pair.ccd) return CcdResult{};
    if (incremental && !std::any_of(pair.point.begin(), pair.point.end(), [&](int p) { return p >= 0 && dirty[p]; }))
      return CcdResult{};
    std::array<Vec3, 4> s, e;
    for (int i = 0; i < 4; ++i) {
      s[i] = start_of(pair.point[i], pair.body);
      e[i] = end_of(pair.point[i], pair.body);
    }
    // Pairs whose points all move by the same displacement keep their shape: nothing new can
    // happen (this is what makes rigid impact zones final).
    const Vec3 d0 = e[0] - s[0];
    double spread = 0.0;
    for (int i = 1; i < 4; ++i) spread = std::max(spread, ((e[i] - s[i]) - d0).cwiseAbs().maxCoeff());
    const double th = pair_thickness(pair);
    if (spread <= 1e-9 * th) return CcdResult{};
    CcdOptions options;
    options.minimum_separation = kCcdSeparationFraction * th;
    options.absolute_tolerance = 0.1 * options.minimum_separation;
    options.max_boxes = 2000;
    if (!boxes_within(s, e, pair.edge_edge, options.minimum_separation)) return CcdResult{};
    return pair.edge_edge ? edge_edge_ccd(s, e, options) : vertex_triangle_ccd(s, e, options);
  };
#pragma omp parallel for schedule(dynamic, 64) num_threads(threads_)
  for (int k = 0; k < count; ++k) {
    const CcdResult r = run(k);
    hit[k] = r.hit;
    toi[k] = r.toi;
  }
  frame_.ccd_candidates += count;
  incremental = false;  // the serial pass re-tests hits with the velocities of the moment
  frame_.ccd_seconds += since(start);
  start = Clock::now();
  int found = 0;
  for (int k = 0; k < count; ++k) {
    if (!hit[k]) continue;
    const FeaturePair& pair = pairs_[k];
    double t = toi[k];
    if (apply && found > 0) {  // earlier impulses of this pass may have changed the pair
      const CcdResult r = run(k);
      if (!r.hit) continue;
      t = r.toi;
    }
    ++found;
    if (hits) hits->push_back(k);
    if (!apply) continue;
    const double th = pair_thickness(pair);
    std::array<Vec3, 4> s, x_toi;
    for (int i = 0; i < 4; ++i) {
      s[i] = start_of(pair.point[i], pair.body);
      x_toi[i] = s[i] + t * (end_of(pair.point[i], pair.body) - s[i]);
    }
    std::array<double, 4> w;
    const double d = pair_weights(x_toi, pair.edge_edge, w);
    const Vec3 g0 = combine(s, w);
    Vec3 v_rel = Vec3::Zero();
    for (int i = 0; i < 4; ++i) v_rel += w[i] * velocity_of(pair.point[i], pair.body);
    const Vec3 side = g0.squaredNorm() > 0.0 ? g0 : Vec3(-v_rel);
    const Vec3 n = contact_normal(x_toi, pair.edge_edge, combine(x_toi, w), d, th, side);
    const double vn = n.dot(v_rel);
    double target = (kTargetSeparationFraction * th - n.dot(g0)) / h_;
    if (frame_iteration_ >= 2) target = std::max(target, 0.0);  // plain inelastic after two passes
    if (vn < target) apply_impulse(pair, w, n, target - vn, pair_friction(pair));
  }
  frame_.ccd_hits += found;
  frame_.response_seconds += since(start);
  return found;
}

int CollisionSystem::impact_zones(std::vector<int>& hits) {
  UnionFind zones(vertex_count_);
  std::vector<char> in_zone(vertex_count_, 0);
  // Body points the zones touched: (a cloth vertex of the pair, body point start, velocity).
  struct BodyReference {
    int cloth_vertex;
    Vec3 x, v;
  };
  std::vector<BodyReference> body_references;
  int zone_count = 0;
  for (int iteration = 0; iteration < settings_.zone_iterations && !hits.empty(); ++iteration) {
    const auto start = Clock::now();
    ++frame_.iterations;
    for (int k : hits) {
      const FeaturePair& pair = pairs_[k];
      int first = -1;
      for (int p : pair.point) {
        if (p < 0) continue;
        in_zone[p] = 1;
        if (first < 0) first = p; else zones.unite(first, p);
      }
      for (int p : pair.point)
        if (p < 0 && first >= 0) body_references.push_back({first, start_of(p, pair.body), velocity_of(p, pair.body)});
    }
    // Zone velocities. A zone held by kinematic references (its pinned vertices, and the body
    // velocities at the cloth vertices that touched a body) moves with the affine velocity field
    // that fits them best (least squares; minimum norm when they are fewer than four or
    // coplanar): one reference gives a translation, several on a rotating limb give its
    // rotation, so a zone pinned along a swinging limb can follow it. The body references are
    // the body vertices of the colliding pairs (their start positions and velocities), so a
    // zone caught on a rigidly moving body moves exactly with it. Other zones translate,
    // keeping their momentum.
    std::vector<Vec3> momentum(vertex_count_, Vec3::Zero()), ref_sum(vertex_count_, Vec3::Zero()),
        ref_point(vertex_count_, Vec3::Zero());
    std::vector<double> mass(vertex_count_, 0.0);
    std::vector<int> ref_count(vertex_count_, 0);
    auto for_each_reference = [&](auto&& visit) {
      for (int i = 0; i < vertex_count_; ++i) {
        if (!in_zone[i]) continue;
        const int r = zones.find(i);
        if (inverse_mass_[i] == 0.0) visit(r, row3(*x_, i), Vec3(row3(*v_, i)));
      }
      for (const BodyReference& ref : body_references) visit(zones.find(ref.cloth_vertex), ref.x, ref.v);
    };
    for (int i = 0; i < vertex_count_; ++i) {
      if (!in_zone[i] || inverse_mass_[i] == 0.0) continue;
      const int r = zones.find(i);
      mass[r] += 1.0 / inverse_mass_[i];
      momentum[r] += row3(*v_, i) / inverse_mass_[i];
    }
    for_each_reference([&](int r, const Vec3& x, const Vec3& v) {
      ref_point[r] += x;
      ref_sum[r] += v;
      ++ref_count[r];
    });
    std::vector<Eigen::Matrix3d> spread(vertex_count_, Eigen::Matrix3d::Zero()), moment(vertex_count_, Eigen::Matrix3d::Zero());
    for_each_reference([&](int r, const Vec3& x, const Vec3& v) {
      const Vec3 d = x - ref_point[r] / ref_count[r];
      spread[r] += d * d.transpose();
      moment[r] += (v - ref_sum[r] / ref_count[r]) * d.transpose();
    });
    std::vector<Eigen::Matrix3d> gradient(vertex_count_, Eigen::Matrix3d::Zero());
    zone_count = 0;
    for (int i = 0; i < vertex_count_; ++i) {
      if (!in_zone[i] || zones.find(i) != i) continue;
      ++zone_count;
      if (ref_count[i] < 2) continue;
      // Pseudo-inverse of the references' spread (directions with no spread get no gradient).
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(spread[i]);
      const double cutoff = 1e-10 * std::max(eigen.eigenvalues().maxCoeff(), 1e-300);
      Eigen::Matrix3d inverse = Eigen::Matrix3d::Zero();
      for (int k = 0; k < 3; ++k)
        if (eigen.eigenvalues()[k] > cutoff)
          inverse += eigen.eigenvectors().col(k) * eigen.eigenvectors().col(k).transpose() / eigen.eigenvalues()[k];
      gradient[i] = moment[i] * inverse;
    }
    for (int i = 0; i < vertex_count_; ++i) {
      if (!in_zone[i] || inverse_mass_[i] == 0.0) continue;
      const int r = zones.find(i);
      Vec3 vz;
      if (ref_count[r] > 0)
        vz = ref_sum[r] / ref_count[r] + gradient[r] * (row3(*x_, i) - ref_point[r] / ref_count[r]);
      else
        vz = momentum[r] / mass[r];
      v_->row(i) = vz.transpose();
      x_end_.row(i) = x_->row(i) + h_ * v_->row(i);
      changed_[i] = 1;
    }
    frame_.response_seconds += since(start);
    collect_pairs();
    hits.clear();
    ccd_pass(false, &hits, true);
  }
  frame_.impact_zones += zone_count;
  frame_.unresolved += static_cast<int>(hits.size());
  return zone_count;
}

void CollisionSystem::body_positions(const std::vector<KinematicBody>& bodies, double alpha0, double alpha1) {
  for (size_t b = 0; b < bodies_.size(); ++b) {
    if (!bodies_[b].collide) continue;
    bodies[b].positions_at(alpha0, bodies_[b].start);
    bodies[b].positions_at(alpha1, bodies_[b].end);
  }
}

void CollisionSystem::constrain_contacts(const Positions& x, const Positions& v, double h,
                                         const std::vector<KinematicBody>& bodies, double alpha0, double alpha1,
                                         ConstraintFilter& filter) {
  solve_contacts_.clear();
  if (!settings_.contact_constraints || !any_body_) return;
  const auto start = Clock::now();
  body_positions(bodies, alpha0, alpha1);
  triangle_boxes(cloth_faces_, x, x, face_margin_, cloth_boxes_);
  cloth_tree_.refit(cloth_boxes_);
  // Closest collidable body face within the thickness, per cloth vertex.
  std::vector<double> best(vertex_count_, std::numeric_limits<double>::infinity());
  std::vector<SolveContact> contact(vertex_count_);
  for (size_t b = 0; b < bodies_.size(); ++b) {
    BodyState& state = bodies_[b];
    if (!state.collide) continue;
    body_triangle_pairs(static_cast<int>(b), false);
    for (const auto& [cf, bf] : scratch_pairs_) {
      if (!face_collide_[cf]) continue;
      const Vec3 a = row3(state.start, state.faces(bf, 0)), bb = row3(state.start, state.faces(bf, 1)),
                 c = row3(state.start, state.faces(bf, 2));
      for (int vtx : cloth_own_.face_vertices[cf]) {
        if (inverse_mass_[vtx] == 0.0) continue;
        Vec3 bary;
        const Vec3 p = row3(x, vtx);
        const double d = point_triangle_distance(p, a, bb, c, bary);
        if (d >= vertex_thickness_[vtx] || d >= best[vtx] || d <= 1e-12 * vertex_thickness_[vtx]) continue;
        best[vtx] = d;
        Vec3 vb = Vec3::Zero();
        for (int k = 0; k < 3; ++k) {
          const int bv = state.faces(bf, k);
          vb += bary[k] * (row3(state.end, bv) - row3(state.start, bv)) / h;
        }
        contact[vtx] = {vtx, static_cast<int>(b), (p - (bary[0] * a + bary[1] * bb + bary[2] * c)) / d, vb, 0.0};
      }
    }
  }
  for (int i = 0; i < vertex_count_; ++i) {
    if (!std::isfinite(best[i]) || filter.projection[i] != Mat3::Identity()) continue;
    SolveContact c = contact[i];
    const double target = kRepulsionRate * (vertex_thickness_[i] - best[i]) / h;
    const double vn = (row3(v, i) - c.body_velocity).dot(c.normal);
    if (vn > target) continue;  // leaving: no constraint
    c.delta_vn = target - vn;
    filter.constrain_direction(i, c.normal, c.delta_vn);
    solve_contacts_.push_back(c);
  }
  frame_.proximity_pairs += static_cast<int>(solve_contacts_.size());
  frame_.proximity_seconds += since(start);
}

void CollisionSystem::contact_friction() {
  for (const SolveContact& c : solve_contacts_) {
    const double mu = vertex_friction_[c.vertex];
    if (mu <= 0.0) continue;
    const Vec3 v_rel = row3(*v_, c.vertex) - c.body_velocity;
    const Vec3 v_t = v_rel - c.normal.dot(v_rel) * c.normal;
    const double vt_norm = v_t.norm();
    if (vt_norm <= 0.0) continue;
    const double scale = std::max(0.0, 1.0 - mu * c.delta_vn / vt_norm);
    v_->row(c.vertex) += ((scale - 1.0) * v_t).transpose();
    x_end_.row(c.vertex) = x_->row(c.vertex) + h_ * v_->row(c.vertex);
  }
}

void CollisionSystem::respond(const Positions& x, Positions& v, double h, const std::vector<KinematicBody>& bodies,
                              double alpha0, double alpha1) {
  x_ = &x;
  v_ = &v;
  h_ = h;
  x_end_ = x + h * v;
  body_positions(bodies, alpha0, alpha1);
  changed_.assign(vertex_count_, 0);
  contact_friction();
  if (pinch_) pinch_update();
  const int unresolved_before = frame_.unresolved;
  bool tangled = false;
  if (gia_ && gia_due_) {
    tangled = gia_colour(x);
    gia_recover();
    if (any_self_) {
      gia_untangle();
      tangled = tangled || untangle_.any();
    }
  } else if (gia_) {
    gia_clear();
  }
  collect_pairs();
  proximity_pass();
  if (settings_.ccd) {
    std::vector<int> hits;
    for (frame_iteration_ = 0; frame_iteration_ < settings_.ccd_iterations; ++frame_iteration_) {
      collect_pairs();
      ++frame_.iterations;
      if (ccd_pass(true, nullptr, frame_iteration_ > 0) == 0) break;
    }
    if (frame_iteration_ == settings_.ccd_iterations) {
      collect_pairs();
      ccd_pass(false, &hits, true);
      if (!hits.empty()) impact_zones(hits);
    }
  }
  const bool ccd_skipped = !settings_.ccd || std::any_of(pairs_.begin(), pairs_.end(), [](const FeaturePair& p) { return !p.ccd; });
  gia_due_ = tangled || ccd_skipped || frame_.unresolved > unresolved_before || (pinch_ && pinch_->active_pairs() > 0);
  x_ = nullptr;
  v_ = nullptr;
}

int CollisionSystem::count_intersections(const Positions& x, const std::vector<KinematicBody>& bodies) const {
  int total = 0;
  if (any_self_) total += count_self_intersections(x, cloth_faces_, face_self_);
  for (size_t b = 0; b < bodies_.size(); ++b)
    if (bodies_[b].collide) total += weft::count_intersections(x, cloth_faces_, bodies[b].frame_end(), bodies_[b].faces, face_collide_);
  return total;
}

CollisionTelemetry CollisionSystem::end_frame(const Positions& x, const std::vector<KinematicBody>& bodies) {
  if (settings_.count_intersections) {
    const auto start = Clock::now();
    frame_.intersections = count_intersections(x, bodies);
    if (frame_.intersections > 0) gia_due_ = true;
    frame_.intersection_seconds += since(start);
  }
  return frame_;
}

}  // namespace weft
