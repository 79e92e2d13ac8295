#include "weft/gia/cloth_untangling.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "weft/common/union_find.h"
#include "weft/gia/gia_regions.h"
#include "weft/gia/intersection_analysis.h"
#include "weft/geometry/closest_points.h"

namespace weft {

ClothUntangling::ClothUntangling(const Faces& cloth_faces, const std::vector<char>& face_self, int vertex_count)
    : cloth_faces_(cloth_faces), vertex_count_(vertex_count) {
  const int face_count = static_cast<int>(cloth_faces.rows());
  for (int f = 0; f < face_count; ++f)
    if (!face_self.empty() && face_self[f]) face_id_.push_back(f);
  faces_.resize(static_cast<Eigen::Index>(face_id_.size()), 3);
  for (size_t k = 0; k < face_id_.size(); ++k) faces_.row(static_cast<Eigen::Index>(k)) = cloth_faces.row(face_id_[k]);
  topo_ = build_gia_topology(vertex_count_, faces_);
  UnionFind components(vertex_count_);
  for (int e = 0; e < topo_.edges.rows(); ++e) components.unite(topo_.edges(e, 0), topo_.edges(e, 1));
  component_.resize(vertex_count_);
  for (int v = 0; v < vertex_count_; ++v) component_[v] = components.find(v);
  colour_.assign(vertex_count_, 0);
  tangled_vertex_.assign(vertex_count_, 0);
  tangled_face_.assign(face_count, 0);
  patch_.assign(vertex_count_, -1);
  interlock_face_.assign(face_count, 0);
}

// BWK's per-path colouring, per connected component: for each path, the edges it crosses an odd
// number of times are walls (vertices it runs through, in shared-vertex cases, are blocked); a
// flood fill through the other edges splits the walls' components into regions, and in each
// component that splits, every region but the largest (current lumped area; ties: lowest seed
// vertex) is coloured. Per component matters because cloth pieces are components of one mesh:
// a small sheet pushed partly through a large one must colour its pushed part, not all of it
// (the whole-mesh rule of GiaMeshColouring::vertex_colour keeps only the large sheet).
void ClothUntangling::colour(const GiaResult& r, const Positions& x) {
  const std::vector<double> area = lumped_vertex_area(x, faces_);
  FloodFill fill(topo_, area);
  std::vector<int> seeds, region_seed;
  std::vector<double> region_area;
  for (int p = 0; p < static_cast<int>(r.paths.size()); ++p) {
    const GiaPath& path = r.paths[p];
    seeds.clear();
    for (int e : odd_crossed_edges(r, path.hits, 0)) {
      fill.wall_stamp[e] = p;
      seeds.push_back(topo_.edges(e, 0));
      seeds.push_back(topo_.edges(e, 1));
    }
    if (seeds.empty()) continue;
    for (int v : path.vertices) {
      fill.block(v, p);
      for (int k = topo_.vertex_offset[v]; k < topo_.vertex_offset[v + 1]; ++k) seeds.push_back(topo_.vertex_neighbour[k]);
    }
    region_area.clear();
    region_seed.clear();
    fill.fill(seeds, p, region_area, region_seed);
    // Per component: the region kept uncoloured.
    const int regions = static_cast<int>(region_area.size());
    std::vector<int> keep(regions, 0);
    for (int i = 0; i < regions; ++i) {
      int best = i;
      for (int j = 0; j < regions; ++j) {
        if (component_[region_seed[j]] != component_[region_seed[i]]) continue;
        if (region_area[j] > region_area[best] ||
            (region_area[j] == region_area[best] && region_seed[j] < region_seed[best]))
          best = j;
      }
      keep[i] = best == i;
    }
    for (int v = 0; v < vertex_count_; ++v)
      if (fill.region_stamp[v] == p && fill.region[v] >= 0 && !keep[fill.region[v]]) colour_[v] = 1;
  }
}

// Per path whose crossing edges have no coloured end: every pair of its edges that cross a
// face around each other (Interlock), each pair once.
void ClothUntangling::find_interlocks(const GiaResult& r) {
  auto has_edge = [&](int tri, int e) {  // face `tri` (a faces_ row) has both ends of edge e
    int ends = 0;
    for (int c = 0; c < 3; ++c) ends += faces_(tri, c) == topo_.edges(e, 0) || faces_(tri, c) == topo_.edges(e, 1);
    return ends == 2;
  };
  auto around = [&](int e) {
    std::array<int, 2> faces = {-1, -1};
    for (int k = topo_.edge_face_offset[e], slot = 0; k < topo_.edge_face_offset[e + 1] && slot < 2; ++k, ++slot)
      faces[slot] = face_id_[topo_.edge_faces[k]];
    return faces;
  };
  for (const GiaPath& path : r.paths) {
    bool free_path = true;
    for (int k : path.hits) {
      const int e = r.hits[k].edge;
      free_path = free_path && !colour_[topo_.edges(e, 0)] && !colour_[topo_.edges(e, 1)];
    }
    if (!free_path) continue;
    const size_t first = interlocks_.size();
    for (int k1 : path.hits) {
      const int e = r.hits[k1].edge;
      for (int k2 : path.hits) {
        const int f = r.hits[k2].edge;
        if (e >= f || !has_edge(r.hits[k1].tri, f) || !has_edge(r.hits[k2].tri, e)) continue;
        const std::array<int, 2> a = {topo_.edges(e, 0), topo_.edges(e, 1)}, b = {topo_.edges(f, 0), topo_.edges(f, 1)};
        if (std::any_of(interlocks_.begin() + static_cast<std::ptrdiff_t>(first), interlocks_.end(),
                        [&](const Interlock& lock) { return lock.a == a && lock.b == b; }))
          continue;
        Interlock lock;
        lock.a = a;
        lock.b = b;
        int slot = 0;
        for (int k : path.hits)
          if (r.hits[k].edge == e && has_edge(r.hits[k].tri, f) && slot < 2) lock.b_faces[slot++] = face_id_[r.hits[k].tri];
        lock.a_around = around(e);
        lock.b_around = around(f);
        interlocks_.push_back(lock);
      }
    }
  }
  for (const Interlock& lock : interlocks_)
    for (int f : {lock.a_around[0], lock.a_around[1], lock.b_around[0], lock.b_around[1]})
      if (f >= 0) interlock_face_[f] = 1;
}

bool ClothUntangling::interlock_pair(int a, int b) const {
  auto in = [](int f, const std::array<int, 2>& faces) { return f == faces[0] || f == faces[1]; };
  return std::any_of(interlocks_.begin(), interlocks_.end(), [&](const Interlock& lock) {
    return (in(a, lock.a_around) && in(b, lock.b_around)) || (in(b, lock.a_around) && in(a, lock.b_around));
  });
}

double ClothUntangling::analyse(const Positions& x, int threads) {
  hits_.clear();
  interlocks_.clear();
  std::fill(interlock_face_.begin(), interlock_face_.end(), 0);
  coloured_count_ = 0;
  path_count_ = 0;
  std::fill(colour_.begin(), colour_.end(), 0);
  std::fill(tangled_vertex_.begin(), tangled_vertex_.end(), 0);
  std::fill(tangled_face_.begin(), tangled_face_.end(), 0);
  std::fill(patch_.begin(), patch_.end(), -1);
  if (faces_.rows() == 0) return 0.0;
  GiaOptions options;
  options.colour = false;  // coloured here, per component (colour())
  options.inside_test = false;
  options.threads = threads;
  const GiaResult r = analyse_self_intersections(x, faces_, options);
  if (r.hits.empty()) return r.seconds;
  path_count_ = static_cast<int>(r.paths.size());
  // Per-path colouring (BWK's rule), not the parity colouring: in a fold pushed through the
  // same sheet, the pierced layer's walls form a slit whose two sides are one region, which the
  // parity colouring reads as an odd cycle and leaves the whole sheet uncoloured (tested).
  colour(r, x);
  for (int v = 0; v < vertex_count_; ++v) {
    coloured_count_ += colour_[v];
    tangled_vertex_[v] = colour_[v];
  }
  // Contour faces: pierced by a hit or with a crossing edge.
  for (const GiaHit& h : r.hits) {
    for (int c = 0; c < 3; ++c) tangled_vertex_[faces_(h.tri, c)] = 1;
    tangled_vertex_[topo_.edges(h.edge, 0)] = 1;
    tangled_vertex_[topo_.edges(h.edge, 1)] = 1;
  }
  // Tangled faces and their patches (connected through shared vertices), labelled by the
  // patch's lowest vertex.
  UnionFind patches(vertex_count_);
  for (int f = 0; f < static_cast<int>(cloth_faces_.rows()); ++f) {
    for (int c = 0; c < 3; ++c) tangled_face_[f] = tangled_face_[f] || tangled_vertex_[cloth_faces_(f, c)];
    if (tangled_face_[f]) {
      patches.unite(cloth_faces_(f, 0), cloth_faces_(f, 1));
      patches.unite(cloth_faces_(f, 0), cloth_faces_(f, 2));
    }
  }
  std::vector<char> in_patch(vertex_count_, 0);
  for (int f = 0; f < static_cast<int>(cloth_faces_.rows()); ++f)
    if (tangled_face_[f])
      for (int c = 0; c < 3; ++c) in_patch[cloth_faces_(f, c)] = 1;
  for (int v = 0; v < vertex_count_; ++v) patch_[v] = in_patch[v] ? patches.find(v) : -1;
  for (const GiaHit& h : r.hits) {
    const int a = topo_.edges(h.edge, 0), b = topo_.edges(h.edge, 1);
    if (colour_[a] == colour_[b]) continue;  // no coloured side to pull back (e.g. a slit's edges)
    hits_.push_back({colour_[a] ? a : b, colour_[a] ? b : a, face_id_[h.tri]});
  }
  find_interlocks(r);
  return r.seconds;
}

int ClothUntangling::push_interlocks(const Positions& x, Positions& v, double h, const std::vector<double>& inverse_mass,
                                     const std::vector<double>& vertex_thickness) const {
  int corrected = 0;
  for (const Interlock& lock : interlocks_) {
    const Vec3 a0 = row3(x, lock.a[0]), a1 = row3(x, lock.a[1]), b0 = row3(x, lock.b[0]), b1 = row3(x, lock.b[1]);
    // The side of b's surface that a's ends are on: a crosses each face around b it crosses
    // once, between its closest approach to b (under b) and the end beyond that face.
    double s = 0.0, t = 0.0;
    segment_segment_distance(a0, a1, b0, b1, s, t);
    Vec3 up = Vec3::Zero();
    for (int f : lock.b_faces) {
      if (f < 0) continue;
      const Vec3 corner = row3(x, cloth_faces_(f, 0));
      const Vec3 n = (row3(x, cloth_faces_(f, 1)) - corner).cross(row3(x, cloth_faces_(f, 2)) - corner);
      const double d0 = n.dot(a0 - corner), d1 = n.dot(a1 - corner);
      if (d0 == d1 || !(n.squaredNorm() > 0.0)) continue;
      const double at = d0 / (d0 - d1);  // where a crosses the face's plane
      const double beyond = at < s ? d0 : d1;
      up += (beyond >= 0.0 ? 1.0 : -1.0) * n.normalized();
    }
    const double up_norm = up.norm();
    if (!(up_norm > 0.0)) continue;
    up /= up_norm;
    const double depth = up.dot((b0 + t * (b1 - b0)) - (a0 + s * (a1 - a0)));  // a below b by this much
    const std::array<int, 4> point = {lock.a[0], lock.a[1], lock.b[0], lock.b[1]};
    const std::array<double, 4> weight = {1.0 - s, s, -(1.0 - t), -t};
    double th = 0.0, vn = 0.0, inverse = 0.0;
    for (int k = 0; k < 4; ++k) {
      th = std::max(th, vertex_thickness[point[k]]);
      vn += weight[k] * up.dot(row3(v, point[k]));
      inverse += weight[k] * weight[k] * inverse_mass[point[k]];
    }
    const double target = (std::max(depth, 0.0) + th) / h;
    if (vn >= target || !(inverse > 0.0)) continue;
    const double impulse = (target - vn) / inverse;
    for (int k = 0; k < 4; ++k) v.row(point[k]) += (weight[k] * inverse_mass[point[k]] * impulse * up).transpose();
    ++corrected;
  }
  return corrected;
}

int ClothUntangling::pull(const Positions& x, Positions& v, double h, const std::vector<double>& inverse_mass,
                          const std::vector<double>& vertex_thickness) const {
  int corrected = 0;
  // Recoil per connected component of the crossed triangles: momentum given to coloured
  // endpoints, taken back from the component's free (uncoloured, unpinned) vertices at the end.
  std::vector<Vec3> recoil;
  std::vector<int> recoil_component;
  for (const UntangleHit& hit : hits_) {
    const double im = inverse_mass[hit.coloured];
    if (!(im > 0.0)) continue;  // a pinned endpoint does not move
    std::array<int, 3> t = {cloth_faces_(hit.face, 0), cloth_faces_(hit.face, 1), cloth_faces_(hit.face, 2)};
    const Vec3 a = row3(x, t[0]), b = row3(x, t[1]), c = row3(x, t[2]);
    Vec3 n = (b - a).cross(c - a);
    const double norm = n.norm();
    if (!(norm > 0.0)) continue;
    n /= norm;
    const Vec3 pc = row3(x, hit.coloured), pf = row3(x, hit.free);
    const double sc = n.dot(pc - a), sf = n.dot(pf - a);
    // The exact analysis says the edge crosses; rounding may put an endpoint on the plane.
    const double side = sf != 0.0 ? (sf > 0.0 ? 1.0 : -1.0) : (sc > 0.0 ? -1.0 : 1.0);
    const Vec3 d = side * n;  // towards the free endpoint's side
    if (d.dot(pc - a) > 0.0) continue;  // already across (rounding)
    // Barycentric weights of the crossing point (closest point of the triangle to it).
    const double denom_t = sc - sf;
    const double s = denom_t != 0.0 ? std::clamp(sc / denom_t, 0.0, 1.0) : 0.5;
    Vec3 bary;
    point_triangle_distance(pc + s * (pf - pc), a, b, c, bary);
    const double th = std::max({vertex_thickness[hit.coloured], vertex_thickness[t[0]], vertex_thickness[t[1]],
                                vertex_thickness[t[2]]});
    const double target = (std::abs(d.dot(pc - a)) + th) / h;
    Vec3 v_rel = row3(v, hit.coloured);
    for (int k = 0; k < 3; ++k) v_rel -= bary[k] * row3(v, t[k]);
    const double vn = d.dot(v_rel);
    if (vn >= target) continue;
    const Vec3 impulse = ((target - vn) / im) * d;
    v.row(hit.coloured) += (im * impulse).transpose();
    const int comp = component_[t[0]];
    const auto at = std::find(recoil_component.begin(), recoil_component.end(), comp);
    if (at == recoil_component.end()) {
      recoil_component.push_back(comp);
      recoil.push_back(-impulse);
    } else {
      recoil[at - recoil_component.begin()] -= impulse;
    }
    ++corrected;
  }
  for (size_t k = 0; k < recoil_component.size(); ++k) {
    double mass = 0.0;
    for (int i = 0; i < vertex_count_; ++i)
      if (component_[i] == recoil_component[k] && !colour_[i] && inverse_mass[i] > 0.0) mass += 1.0 / inverse_mass[i];
    if (!(mass > 0.0)) continue;  // all pinned: the pins take the recoil
    const Vec3 dv = recoil[k] / mass;
    for (int i = 0; i < vertex_count_; ++i)
      if (component_[i] == recoil_component[k] && !colour_[i] && inverse_mass[i] > 0.0) v.row(i) += dv.transpose();
  }
  return corrected + push_interlocks(x, v, h, inverse_mass, vertex_thickness);
}

}  // namespace weft
