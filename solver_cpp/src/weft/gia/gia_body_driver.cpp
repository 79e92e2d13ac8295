#include "weft/gia/gia_body_driver.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "weft/common/timer.h"
#include "weft/common/union_find.h"
#include "weft/geometry/closest_points.h"
#include "weft/gia/intersection_analysis.h"
#include "weft/gia/pinch_driver.h"

namespace weft {

namespace {
// A contour vertex inside a body gets an outward normal velocity (relative to the body) of at
// least this fraction of (depth + thickness) per step.
constexpr double kRecoveryRate = 1.0;
}  // namespace

GiaBodyDriver::GiaBodyDriver(const ContactDetection& detection, int vertex_count)
    : detection_(detection), vertex_count_(vertex_count), bodies_(detection.bodies().size()) {
  for (size_t b = 0; b < bodies_.size(); ++b) {
    const ContactDetection::Body& body = detection.bodies()[b];
    if (!body.collide) continue;
    bodies_[b].topology = build_gia_topology(body.vertex_count, body.faces);
    bodies_[b].closed = bodies_[b].topology.closed;
  }
  const Faces& cloth_faces = detection.cloth_faces();
  const std::vector<char>& face_collide = detection.face_collide();
  const int face_count = static_cast<int>(cloth_faces.rows());
  for (int f = 0; f < face_count; ++f)
    if (face_collide[f]) collide_face_ids_.push_back(f);
  collide_faces_.resize(static_cast<Eigen::Index>(collide_face_ids_.size()), 3);
  for (size_t k = 0; k < collide_face_ids_.size(); ++k) collide_faces_.row(k) = cloth_faces.row(collide_face_ids_[k]);
  cloth_topology_ = build_gia_topology(vertex_count_, collide_faces_);
  cloth_neighbours_.assign(vertex_count_, {});
  vertex_collide_.assign(vertex_count_, 0);
  for (int f = 0; f < face_count; ++f)
    for (int c = 0; c < 3; ++c) {
      const int a = cloth_faces(f, c), b = cloth_faces(f, (c + 1) % 3);
      cloth_neighbours_[a].push_back(b);
      cloth_neighbours_[b].push_back(a);
      if (face_collide[f]) vertex_collide_[a] = 1;
    }
  for (auto& n : cloth_neighbours_) {
    std::sort(n.begin(), n.end());
    n.erase(std::unique(n.begin(), n.end()), n.end());
  }
}

void GiaBodyDriver::fit_tree(AabbTree& tree, std::vector<Aabb>& boxes, const Positions& x, const Faces& faces) {
  triangle_boxes(faces, x, x, {}, boxes);
  if (tree.empty())
    tree.build(boxes);
  else
    tree.refit(boxes);
}

bool GiaBodyDriver::intersects(int body) const {
  const Body& b = bodies_[body];
  auto any = [](const std::vector<char>& v) { return std::any_of(v.begin(), v.end(), [](char c) { return c != 0; }); };
  return any(b.inside) || any(b.face_coloured) || any(b.cloth_face_contour);
}

void GiaBodyDriver::clear() {
  for (Body& body : bodies_) body.clear();
}

bool GiaBodyDriver::colour(const CollisionStep& step, int threads, CollisionTelemetry& frame,
                           const std::vector<char>* only) {
  const Timer timer;
  int coloured_count = 0, paths = 0, body_faces = 0;
  GiaOptions options;
  options.threads = threads;
  const Faces& cloth_faces = detection_.cloth_faces();
  // The cloth's tree once for every body; a body whose box misses every cloth vertex and face
  // has nothing in intersection with the cloth (no vertex inside, no triangle through).
  const Positions& x = *step.x;
  fit_tree(cloth_tree_, cloth_boxes_, x, collide_faces_);
  const AabbTree& cloth_tree = cloth_tree_;
  Aabb cloth_box;
  for (Eigen::Index i = 0; i < x.rows(); ++i) cloth_box.expand(row3(x, static_cast<int>(i)));
  for (size_t b = 0; b < bodies_.size(); ++b) {
    Body& state = bodies_[b];
    state.clear();
    if (!state.closed) continue;
    const Faces& faces = detection_.bodies()[b].faces;
    const Positions& body_x = step.body_start[b];
    fit_tree(state.tree, state.boxes, body_x, faces);
    const AabbTree& body_tree = state.tree;
    if (body_tree.empty() || !body_tree.bounds().overlaps(cloth_box)) continue;
    if (only != nullptr && !(*only)[b]) {  // known clear of the cloth: what an analysis finds then
      state.inside.assign(vertex_count_, 0);
      state.face_coloured.assign(faces.rows(), 0);
      state.cloth_face_contour.assign(cloth_faces.rows(), 0);
      state.contour_corner.assign(vertex_count_, 0);
      continue;
    }
    // Cloth side: the exact inside test (ray parity). Body side: the parity colouring of the
    // body over all separating paths, so a body segment that passes wholly through the cloth
    // (a patch pushed through a thin bone) is marked even though no cloth vertex is inside.
    const GiaResult gia = analyse_intersections(GiaMesh{x, collide_faces_, cloth_topology_, cloth_tree},
                                                GiaMesh{body_x, faces, state.topology, body_tree}, options);
    paths += static_cast<int>(gia.paths.size());
    const GiaMeshColouring& cloth = gia.mesh[0];
    const GiaMeshColouring& body = gia.mesh[1];
    state.inside.assign(cloth.inside_other.begin(), cloth.inside_other.end());
    if (state.inside.empty()) state.inside.assign(vertex_count_, 0);
    const int face_count = static_cast<int>(faces.rows());
    state.face_coloured.assign(face_count, 0);
    for (int f = 0; f < face_count; ++f) {
      int coloured_corners = 0;
      for (int k = 0; k < 3; ++k) coloured_corners += body.vertex_parity_colour[faces(f, k)] != 0;
      // Pierced faces with no coloured corner stay closed to the membrane (contact_detection.cpp).
      state.face_coloured[f] = coloured_corners == 3 ? 3 : coloured_corners > 0 ? 2 : body.face_colour[f] == kGiaContour ? 1 : 0;
      body_faces += state.face_coloured[f] != 0;
    }
    state.cloth_face_contour.assign(cloth_faces.rows(), 0);
    state.contour_corner.assign(vertex_count_, 0);
    for (size_t k = 0; k < collide_face_ids_.size(); ++k) {
      const bool contour = cloth.face_colour[k] == kGiaContour;
      state.cloth_face_contour[collide_face_ids_[k]] = contour;
      if (contour)
        for (int c = 0; c < 3; ++c) state.contour_corner[cloth_faces(collide_face_ids_[k], c)] = 1;
    }
    for (int i = 0; i < vertex_count_; ++i)
      if (state.inside[i] && vertex_collide_[i]) ++coloured_count;
  }
  frame.gia_coloured_vertices = std::max(frame.gia_coloured_vertices, coloured_count);
  frame.gia_paths = std::max(frame.gia_paths, paths);
  frame.gia_body_coloured_faces = std::max(frame.gia_body_coloured_faces, body_faces);
  frame.gia_seconds += timer.seconds();
  return paths > 0 || coloured_count > 0;
}

void GiaBodyDriver::recover(CollisionStep& step, const ContactProperties& props, PinchDriver* pinch,
                            CollisionTelemetry& frame) {
  const Timer timer;
  const Positions& x = *step.x;
  Positions& v = *step.v;
  int pushed = 0;
  for (size_t b = 0; b < bodies_.size(); ++b) {
    Body& state = bodies_[b];
    if (state.inside.empty()) continue;
    const Faces& faces = detection_.bodies()[b].faces;
    const Positions& start = step.body_start[b];
    const Positions& end = step.body_end[b];
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
    const int body = static_cast<int>(b);
    std::vector<char> held;
    std::vector<char>* gripped = pinch ? &pinch->gripped(body) : nullptr;
    if (gripped) {
      for (int i = 0; i < vertex_count_; ++i) {
        if (!state.inside[i]) (*gripped)[i] = 0;
        else if (pinch->held(i, body)) {
          if (held.empty()) held.assign(vertex_count_, 0);
          held[regions.find(i)] = 1;
        }
      }
    }
    std::vector<Vec3> region_towards(vertex_count_, Vec3::Zero());
    for (int i = 0; i < vertex_count_; ++i)
      if (state.inside[i])
        for (int j : cloth_neighbours_[i])
          if (!state.inside[j]) region_towards[regions.find(i)] += row3(x, j) - row3(x, i);
    for (int i = 0; i < vertex_count_; ++i) {
      if (!state.inside[i] || !vertex_collide_[i] || props.inverse_mass[i] == 0.0) continue;
      if (pinch && pinch->squeezed(i, body)) continue;  // a part passing over squeezed cloth
      if (!held.empty() && held[regions.find(i)]) {
        (*gripped)[i] = 1;
        pinch->grip(i, faces, start, end, step, frame);
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
      const Vec3 p = row3(x, i);
      const Vec3 towards = released ? Vec3::Zero() : region_towards[regions.find(i)];
      const int body_faces = static_cast<int>(faces.rows());
      auto corner = [&](int f, int k) { return row3(start, faces(f, k)); };
      double best = std::numeric_limits<double>::infinity();
      int best_face = -1;
      Vec3 best_bary = Vec3::Zero();
      Vec3 n = Vec3::Zero();
      if (towards.norm() > 1e-9 * props.thickness[i]) {
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
        const int bv = faces(best_face, k);
        q += best_bary[k] * row3(start, bv);
        vb += best_bary[k] * (row3(end, bv) - row3(start, bv)) / step.h;
      }
      if (n.squaredNorm() == 0.0) n = q - p;
      if (n.norm() <= 1e-12) continue;  // on the surface with no direction to leave by
      n.normalize();
      const double target = kRecoveryRate * (best + props.thickness[i]) / step.h;
      const double vn = n.dot(row3(v, i) - vb);
      if (vn >= target) continue;
      v.row(i) += ((target - vn) * n).transpose();
      step.moved(i);
      ++pushed;
    }
    if (step.sharp_edges != nullptr && b < step.sharp_edges->size())
      pushed += push_corner_cuts(step, props, pinch, body, (*step.sharp_edges)[b]);
  }
  std::sort(step.corner_cuts.begin(), step.corner_cuts.end());
  frame.gia_pushed_vertices += pushed;
  frame.gia_seconds += timer.seconds();
}

// A cloth edge that cuts a body's corner (SharpEdges::corner_cut: in through one face of a
// convex body edge, out through the other) has no vertex inside, so the loop above has nothing
// to push, while its triangles, on the contour, pass the membrane: nothing brings it out. Held
// by friction against one of the faces, a sheet caught so on the bottom edge of a box was
// carried up with the box (the regression box_pinch at 1.07x its thickness). Both ends of such
// an edge move away from the body edge, at the recovery rate of the depth at which the edge's
// nearest point lies below it (plus the thickness), and the edge goes into step.corner_cuts.
int GiaBodyDriver::push_corner_cuts(CollisionStep& step, const ContactProperties& props, PinchDriver* pinch, int body,
                                    const SharpEdges& sharp) {
  const Body& state = bodies_[body];
  if (state.contour_corner.empty() || sharp.tree().empty()) return 0;
  const Positions& x = *step.x;
  Positions& v = *step.v;
  const Positions& start = step.body_start[body];
  const Positions& end = step.body_end[body];
  auto free_end = [&](int i) {
    return state.contour_corner[i] && !state.inside[i] && vertex_collide_[i] && !(pinch && pinch->squeezed(i, body));
  };
  int pushed = 0;
  for (int i = 0; i < vertex_count_; ++i) {
    if (!free_end(i)) continue;
    for (int j : cloth_neighbours_[i]) {
      if (j <= i || !free_end(j)) continue;
      if (props.inverse_mass[i] == 0.0 && props.inverse_mass[j] == 0.0) continue;
      const Vec3 pa = row3(x, i), pb = row3(x, j);
      // The body edge's point lies within half the cloth edge's length plus the depth of its
      // midpoint: a search radius of three half lengths finds cuts up to a length deep.
      double radius = 1.5 * (pb - pa).norm();
      double depth = 0.0, along = 0.0, at = 0.0;
      int cut = -1;
      sharp.tree().nearest(0.5 * (pa + pb), radius, [&](int leaf) {
        const std::array<int, 2>& be = sharp.edge(leaf);
        const Vec3 q0 = row3(start, be[0]), q1 = row3(start, be[1]);
        double s_cloth, t_body;
        const double d = segment_segment_distance(pa, pb, q0, q1, s_cloth, t_body);
        if (!(s_cloth > 0.0 && s_cloth < 1.0 && t_body > 0.0 && t_body < 1.0) || d <= depth) return;
        if (!sharp.corner_cut(leaf, (1.0 - t_body) * q0 + t_body * q1, pa, pb, (1.0 - s_cloth) * pa + s_cloth * pb))
          return;
        depth = d;
        along = s_cloth;
        at = t_body;
        cut = leaf;
      });
      if (cut < 0) continue;
      // A body edge with a face in intersection (a coloured body vertex): the body segment that
      // went wholly through the cloth is coloured, and the cloth goes back across it (point 4).
      const std::array<int, 2> edge_faces = sharp.faces(cut);
      if (state.face_coloured[edge_faces[0]] >= 2 || state.face_coloured[edge_faces[1]] >= 2) continue;
      step.corner_cuts.push_back({i, j, body});
      const std::array<int, 2>& be = sharp.edge(cut);
      const Vec3 q0 = row3(start, be[0]), q1 = row3(start, be[1]);
      const Vec3 on_edge = (1.0 - at) * q0 + at * q1;
      const Vec3 n = (on_edge - ((1.0 - along) * pa + along * pb)) / depth;
      const Vec3 vb = ((1.0 - at) * (row3(end, be[0]) - q0) + at * (row3(end, be[1]) - q1)) / step.h;
      const double th = std::max(props.thickness[i], props.thickness[j]);
      const double target = kRecoveryRate * (depth + th) / step.h;
      const double vn = n.dot((1.0 - along) * row3(v, i) + along * row3(v, j) - vb);
      if (vn >= target) continue;
      for (int k : {i, j}) {
        if (props.inverse_mass[k] == 0.0) continue;
        v.row(k) += ((target - vn) * n).transpose();
        step.moved(k);
        ++pushed;
      }
    }
  }
  return pushed;
}

}  // namespace weft
