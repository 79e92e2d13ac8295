#include "weft/gia/intersection_analysis.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <unordered_map>
#include <utility>

#include <omp.h>

#include "weft/common/timer.h"
#include "weft/geometry/aabb_tree.h"
#include "weft/geometry/exact_predicates.h"
#include "weft/gia/gia_regions.h"
#include "weft/mesh/mesh.h"

namespace weft {
namespace {

// ---------------------------------------------------------------------------------------------
// Input checks and topology

void check_positions(const Positions& x, const char* name) {
  if (!x.allFinite()) throw MeshError(std::string(name) + ": positions must be finite");
}

// ---------------------------------------------------------------------------------------------
// Triangle boxes in an AABB tree (aabb_tree.h).

// Triangle pairs whose boxes overlap (closed boxes: touching counts, so exact contact is never
// missed). Self mode (a == b) lists each unordered pair once, (lower, higher).
std::vector<std::pair<int, int>> overlapping_pairs(const AabbTree& a, const AabbTree& b, bool self) {
  std::vector<std::pair<int, int>> pairs;
  if (self) a.self_pairs(pairs);
  else a.pairs(b, pairs);
  std::sort(pairs.begin(), pairs.end());  // deterministic order, independent of traversal
  return pairs;
}

// ---------------------------------------------------------------------------------------------
// Narrow phase

struct MeshRef {
  const Positions* x;
  const Faces* f;
  const GiaTopology* topo;
  std::int64_t key_offset;
  KeyedPoint point(int v) const { return {x->data() + 3 * static_cast<std::ptrdiff_t>(v), key_offset + v}; }
};

// A hit key: edge mesh in bit 63, edge in bits 32..62, triangle in bits 0..31.
inline std::uint64_t hit_key(int edge_mesh, int edge, int tri) {
  return (static_cast<std::uint64_t>(edge_mesh) << 63) | (static_cast<std::uint64_t>(edge) << 32) |
         static_cast<std::uint32_t>(tri);
}

bool edge_crosses_triangle(const MeshRef& em, int e, const MeshRef& tm, int t) {
  const int v0 = em.topo->edges(e, 0), v1 = em.topo->edges(e, 1);
  const Faces& f = *tm.f;
  return segment_crosses_triangle(em.point(v0), em.point(v1), tm.point(f(t, 0)), tm.point(f(t, 1)),
                                  tm.point(f(t, 2)));
}

bool face_has_vertex(const Faces& f, int t, int v) { return f(t, 0) == v || f(t, 1) == v || f(t, 2) == v; }

struct PairHits {
  std::array<std::uint64_t, 6> keys;
  int count = 0;
  int shared_vertex = -1;  // self mode: the one vertex the two triangles share, if any
};

// The hits of one triangle pair: edges of s (mesh ms) against t (mesh mt) and vice versa.
// Self mode skips edges that share a vertex with the other triangle.
PairHits pair_hits(const MeshRef& ms, int s, int mesh_s, const MeshRef& mt, int t, int mesh_t, bool self) {
  PairHits out;
  const Faces& fs = *ms.f;
  const Faces& ft = *mt.f;
  auto test_edges = [&](const MeshRef& em, int tri_e, int mesh_e, const MeshRef& tm, int tri) {
    for (int k = 0; k < 3; ++k) {
      const int e = em.topo->face_edges[tri_e][k];
      if (self) {
        const int v0 = em.topo->edges(e, 0), v1 = em.topo->edges(e, 1);
        if (face_has_vertex(*tm.f, tri, v0) || face_has_vertex(*tm.f, tri, v1)) continue;
      }
      if (edge_crosses_triangle(em, e, tm, tri)) out.keys[out.count++] = hit_key(mesh_e, e, tri);
    }
  };
  if (self) {
    int shared = 0;
    for (int i = 0; i < 3; ++i)
      if (face_has_vertex(ft, t, fs(s, i))) {
        ++shared;
        out.shared_vertex = fs(s, i);
      }
    if (shared >= 2) return out;  // neighbours across an edge cannot cross each other
  }
  test_edges(ms, s, mesh_s, mt, t);
  test_edges(mt, t, mesh_t, ms, s);
  return out;
}

// ---------------------------------------------------------------------------------------------
// Path tracing

struct HitGraph {
  std::vector<std::array<int, 2>> links;  // pairs of hit ids joined by a triangle pair
  std::vector<int> link_vertex;           // self mode: vertex a link passes through, else -1
  std::vector<int> end_vertex;            // per hit: shared vertex its path ends at, else -1
  std::vector<int> offset, adjacency;     // CSR hit -> link ids
  int degree(int h) const { return offset[h + 1] - offset[h]; }
};

void build_adjacency(HitGraph& g, int hit_count) {
  g.offset.assign(hit_count + 1, 0);
  for (const auto& l : g.links) {
    ++g.offset[l[0] + 1];
    ++g.offset[l[1] + 1];
  }
  for (int h = 0; h < hit_count; ++h) g.offset[h + 1] += g.offset[h];
  g.adjacency.resize(g.offset.back());
  std::vector<int> fill(g.offset.begin(), g.offset.end() - 1);
  for (int l = 0; l < static_cast<int>(g.links.size()); ++l) {
    g.adjacency[fill[g.links[l][0]]++] = l;
    g.adjacency[fill[g.links[l][1]]++] = l;
  }
}

GiaEndKind end_kind(const GiaResult& r, const std::array<const GiaTopology*, 2>& topo, const HitGraph& g, int h,
                    int& end_mesh) {
  const GiaHit& hit = r.hits[h];
  end_mesh = -1;
  if (g.degree(h) > 2) return GiaEndKind::kNonManifold;
  if (topo[hit.edge_mesh]->edge_face_count(hit.edge) == 1) {
    end_mesh = hit.edge_mesh;
    return GiaEndKind::kBoundary;
  }
  return g.end_vertex[h] >= 0 ? GiaEndKind::kSharedVertex : GiaEndKind::kDangling;
}

void trace_paths(GiaResult& r, const HitGraph& g, const std::array<const GiaTopology*, 2>& topo) {
  const int hit_count = static_cast<int>(r.hits.size());
  std::vector<char> used(g.links.size(), 0);
  auto other = [&](int link, int h) { return g.links[link][0] == h ? g.links[link][1] : g.links[link][0]; };
  auto next_link = [&](int h, int came) {
    for (int k = g.offset[h]; k < g.offset[h + 1]; ++k)
      if (g.adjacency[k] != came) return g.adjacency[k];
    return came;  // a hit joined twice by the same link cannot happen; stay put
  };
  // Open paths start at hits whose degree is not 2.
  for (int h = 0; h < hit_count; ++h) {
    if (g.degree(h) == 2) continue;
    auto finish = [&](GiaPath& p) {
      p.end_kind[0] = end_kind(r, topo, g, p.hits.front(), p.end_mesh[0]);
      p.end_kind[1] = end_kind(r, topo, g, p.hits.back(), p.end_mesh[1]);
      if (p.hits.size() == 1 && p.end_kind[0] == GiaEndKind::kBoundary && g.end_vertex[h] >= 0) {
        p.end_kind[1] = GiaEndKind::kSharedVertex;  // one hit between a boundary and a vertex
        p.end_mesh[1] = -1;
      }
      for (int k = 0; k < 2; ++k) {
        const int end = k == 0 ? p.hits.front() : p.hits.back();
        if (g.end_vertex[end] >= 0 && (k == 0 || p.hits.size() > 1)) p.vertices.push_back(g.end_vertex[end]);
      }
      r.paths.push_back(std::move(p));
    };
    if (g.degree(h) == 0) {
      GiaPath p;
      p.hits = {h};
      finish(p);
      continue;
    }
    for (int k = g.offset[h]; k < g.offset[h + 1]; ++k) {
      int link = g.adjacency[k];
      if (used[link]) continue;
      GiaPath p;
      p.hits = {h};
      int cur = h;
      while (true) {
        used[link] = 1;
        if (g.link_vertex[link] >= 0) p.vertices.push_back(g.link_vertex[link]);
        cur = other(link, cur);
        p.hits.push_back(cur);
        if (g.degree(cur) != 2) break;
        link = next_link(cur, link);
      }
      finish(p);
    }
  }
  // The remaining links form closed loops through degree-2 hits.
  for (int l = 0; l < static_cast<int>(g.links.size()); ++l) {
    if (used[l]) continue;
    GiaPath p;
    p.closed = true;
    const int start = g.links[l][0];
    p.hits = {start};
    int cur = start, link = l;
    while (true) {
      used[link] = 1;
      if (g.link_vertex[link] >= 0) p.vertices.push_back(g.link_vertex[link]);
      cur = other(link, cur);
      if (cur == start) break;
      p.hits.push_back(cur);
      link = next_link(cur, link);
      if (used[link]) break;  // defensive: never loops forever
    }
    r.paths.push_back(std::move(p));
  }
  for (const GiaPath& p : r.paths) (p.closed ? r.closed_path_count : r.open_path_count)++;
}

// ---------------------------------------------------------------------------------------------
// Colouring (lumped_vertex_area, odd_crossed_edges, FloodFill: gia_regions.h)

// Parity colouring of one mesh over all separating paths together: regions of the mesh cut by
// every wall alternate in/out across walls, so each connected group of regions is two-coloured
// and its class of smaller area is coloured. A group whose walls do not two-colour (odd cycle)
// is left uncoloured and counted in parity_conflicts.
void parity_colour(GiaResult& r, int m, FloodFill& ff) {
  GiaMeshColouring& out = r.mesh[m];
  const int nv = static_cast<int>(ff.vertex_area.size());
  const int stamp = static_cast<int>(r.paths.size());
  out.vertex_parity_colour.assign(nv, 0);
  std::vector<int> hits;
  for (const GiaPath& path : r.paths) {
    if (!path.separates[m]) continue;
    hits.insert(hits.end(), path.hits.begin(), path.hits.end());
    for (int v : path.vertices) ff.block(v, stamp);
  }
  const std::vector<int> walls = odd_crossed_edges(r, hits, m);
  if (walls.empty()) return;
  for (int e : walls) ff.wall_stamp[e] = stamp;
  std::vector<int> seeds(nv);
  for (int v = 0; v < nv; ++v) seeds[v] = v;
  std::vector<double> region_area;
  std::vector<int> region_seed;
  ff.fill(seeds, stamp, region_area, region_seed);
  const int regions = static_cast<int>(region_area.size());
  // Region graph across walls (CSR), then a breadth-first two-colouring per group.
  std::vector<std::array<int, 2>> adjacent;
  for (int e : walls) {
    const int a = ff.region[ff.topo.edges(e, 0)], b = ff.region[ff.topo.edges(e, 1)];
    if (a >= 0 && b >= 0) adjacent.push_back({a, b});
  }
  std::vector<int> offset(regions + 1, 0), next(2 * adjacent.size());
  for (const auto& ab : adjacent) {
    ++offset[ab[0] + 1];
    ++offset[ab[1] + 1];
  }
  for (int i = 0; i < regions; ++i) offset[i + 1] += offset[i];
  std::vector<int> fill(offset.begin(), offset.end() - 1);
  for (const auto& ab : adjacent) {
    next[fill[ab[0]]++] = ab[1];
    next[fill[ab[1]]++] = ab[0];
  }
  std::vector<int> side(regions, -1), coloured_side(regions, -1), group;
  for (int root = 0; root < regions; ++root) {
    if (side[root] >= 0 || offset[root] == offset[root + 1]) continue;
    group.assign(1, root);
    side[root] = 0;
    double class_area[2] = {0.0, 0.0};
    bool conflict = false;
    for (size_t q = 0; q < group.size(); ++q) {
      const int g = group[q];
      class_area[side[g]] += region_area[g];
      for (int k = offset[g]; k < offset[g + 1]; ++k) {
        const int h = next[k];
        if (side[h] < 0) {
          side[h] = 1 - side[g];
          group.push_back(h);
        } else if (side[h] == side[g]) {
          conflict = true;
        }
      }
    }
    r.mesh[m].parity_conflicts += conflict;
    // Ties keep the class of the group's lowest region (lowest seed vertex) uncoloured.
    const int colour = conflict ? -1 : (class_area[1] <= class_area[0] ? 1 : 0);
    for (int g : group) coloured_side[g] = side[g] == colour ? 1 : 0;
  }
  for (int v = 0; v < nv; ++v) {
    const int g = ff.region[v];
    out.vertex_parity_colour[v] = g >= 0 && coloured_side[g] == 1;
  }
}

// Colours one mesh: for each path, the mesh edges it crosses an odd number of times are walls;
// the flood fill through the other edges splits the walls' connected component into regions. If
// there are two or more, the path separates the mesh and every region but the largest (by
// current lumped area; ties keep the region of the lowest vertex uncoloured) is coloured.
void colour_mesh(GiaResult& r, int m, const Positions& x, const Faces& f, const GiaTopology& topo) {
  GiaMeshColouring& out = r.mesh[m];
  const int nv = static_cast<int>(x.rows());
  const int ne = static_cast<int>(topo.edges.rows());
  out.vertex_colour.assign(nv, 0);
  out.vertex_path.assign(nv, -1);
  const std::vector<double> area = lumped_vertex_area(x, f);
  FloodFill ff(topo, area);
  for (int p = 0; p < static_cast<int>(r.paths.size()); ++p) {
    GiaPath& path = r.paths[p];
    const std::vector<int> walls = odd_crossed_edges(r, path.hits, m);
    if (walls.empty()) continue;
    for (int e : walls) ff.wall_stamp[e] = p;
    // Vertices the path runs through (self mode, shared vertices) belong to no region; the flood
    // starts from their neighbours and from the walls' endpoints.
    std::vector<int> seeds;
    for (int v : path.vertices) {
      ff.block(v, p);
      for (int k = topo.vertex_offset[v]; k < topo.vertex_offset[v + 1]; ++k) seeds.push_back(topo.vertex_neighbour[k]);
    }
    for (int e : walls) seeds.insert(seeds.end(), {topo.edges(e, 0), topo.edges(e, 1)});
    std::vector<double> region_area;
    std::vector<int> region_seed;
    ff.fill(seeds, p, region_area, region_seed);
    const int regions = static_cast<int>(region_area.size());
    path.separates[m] = regions >= 2;
    if (regions < 2) continue;
    // The region kept uncoloured: the largest (ties: the one with the lowest seed vertex).
    int keep = 0;
    for (int i = 1; i < regions; ++i)
      if (region_area[i] > region_area[keep] ||
          (region_area[i] == region_area[keep] && region_seed[i] < region_seed[keep]))
        keep = i;
    for (int v = 0; v < nv; ++v) {
      if (ff.region_stamp[v] != p || ff.region[v] == keep || ff.region[v] < 0) continue;
      ++path.coloured_vertices[m];
      out.vertex_colour[v] = 1;
      if (out.vertex_path[v] < 0) out.vertex_path[v] = p;
    }
  }
  parity_colour(r, m, ff);
  out.coloured_vertex_count = static_cast<int>(std::count(out.vertex_colour.begin(), out.vertex_colour.end(), 1));
  // Edge and face states.
  out.edge_colour.assign(ne, kGiaFree);
  out.face_colour.assign(f.rows(), kGiaFree);
  for (int e = 0; e < ne; ++e)
    if (out.vertex_colour[topo.edges(e, 0)] && out.vertex_colour[topo.edges(e, 1)]) out.edge_colour[e] = kGiaInside;
  for (const GiaHit& h : r.hits) {
    if (h.edge_mesh == m) out.edge_colour[h.edge] = kGiaContour;
    if (h.tri_mesh == m) out.face_colour[h.tri] = kGiaContour;
  }
  for (int t = 0; t < f.rows(); ++t) {
    if (out.face_colour[t] == kGiaContour) continue;
    bool contour = false, inside = true;
    for (int k = 0; k < 3; ++k) {
      contour = contour || out.edge_colour[topo.face_edges[t][k]] == kGiaContour;
      inside = inside && out.vertex_colour[f(t, k)];
    }
    out.face_colour[t] = contour ? kGiaContour : (inside ? kGiaInside : kGiaFree);
  }
}

// Ray parity: segment from each point (key point_key_offset + i) along +x to a point beyond the
// mesh's box (key far_key), counted against the mesh's triangles with the perturbed predicate.
std::vector<std::int8_t> inside_by_parity(const Positions& points, std::int64_t point_key_offset, const MeshRef& mesh,
                                          const AabbTree& tree, std::int64_t far_key, int threads) {
  const int n = static_cast<int>(points.rows());
  std::vector<std::int8_t> inside(n, 0);
  if (tree.empty()) return inside;
  const Aabb& root = tree.bounds();
  const double far_x = root.hi.x() + 1.0 + std::fabs(root.hi.x());
  const Faces& f = *mesh.f;
#pragma omp parallel for schedule(dynamic, 256) num_threads(threads > 0 ? threads : omp_get_max_threads())
  for (int i = 0; i < n; ++i) {
    const Vec3 p = row3(points, i);
    if (!root.contains(p)) continue;  // strictly outside the closed box: outside
    const double far[3] = {far_x, p.y(), p.z()};
    const KeyedPoint kp{points.data() + 3 * static_cast<std::ptrdiff_t>(i), point_key_offset + i};
    const KeyedPoint kq{far, far_key};
    Aabb seg;
    seg.expand(p);
    seg.expand(Vec3(far_x, p.y(), p.z()));
    int crossings = 0;  // a sum: the visiting order does not matter
    tree.query(seg, [&](int t) {
      crossings += segment_crosses_triangle(kp, kq, mesh.point(f(t, 0)), mesh.point(f(t, 1)), mesh.point(f(t, 2)));
    });
    inside[i] = crossings % 2;
  }
  return inside;
}

// Shared driver: mesh 0 against mesh 1 (self: mesh 1 is mesh 0, tree1 unused), with AABB trees
// over their triangles.
GiaResult analyse(const std::array<MeshRef, 2>& mesh, const AabbTree& tree0, const AabbTree& tree1, bool self,
                  const GiaOptions& options) {
  const Timer timer;
  const int threads = options.threads > 0 ? options.threads : omp_get_max_threads();
  GiaResult r;
  r.self = self;
  const std::vector<std::pair<int, int>> pairs = overlapping_pairs(tree0, tree1, self);
  r.candidate_pairs = static_cast<long long>(pairs.size());

  // Narrow phase in parallel; each pair writes its own slot.
  std::vector<PairHits> pair_result(pairs.size());
  const MeshRef& m1 = self ? mesh[0] : mesh[1];
  const int mesh1 = self ? 0 : 1;
#pragma omp parallel for schedule(dynamic, 64) num_threads(threads)
  for (long long i = 0; i < static_cast<long long>(pairs.size()); ++i)
    pair_result[i] = pair_hits(mesh[0], pairs[i].first, 0, m1, pairs[i].second, mesh1, self);

  // Hits numbered in order of first appearance (pairs are sorted: deterministic); each pair with
  // two hits links them.
  std::unordered_map<std::uint64_t, int> hit_id;
  HitGraph graph;
  std::vector<std::array<int, 2>> vertex_halves;  // (shared vertex, hit)
  for (size_t i = 0; i < pairs.size(); ++i) {
    const PairHits& ph = pair_result[i];
    if (ph.count == 0) continue;
    ++r.intersecting_pairs;
    std::array<int, 6> ids{};
    for (int k = 0; k < ph.count; ++k) {
      const std::uint64_t key = ph.keys[k];
      auto [it, inserted] = hit_id.emplace(key, static_cast<int>(r.hits.size()));
      if (inserted) {
        GiaHit h;
        h.edge_mesh = static_cast<int>(key >> 63);
        h.edge = static_cast<int>((key >> 32) & 0x7fffffffu);
        h.tri = static_cast<int>(key & 0xffffffffu);
        h.tri_mesh = self ? 0 : 1 - h.edge_mesh;
        r.hits.push_back(h);
      }
      ids[k] = it->second;
    }
    if (ph.count == 2) {
      graph.links.push_back({ids[0], ids[1]});
      graph.link_vertex.push_back(-1);
    } else if (ph.count == 1 && ph.shared_vertex >= 0) {
      vertex_halves.push_back({ph.shared_vertex, ids[0]});
    } else {
      ++r.inconsistent_pairs;
      for (int k = 0; k + 1 < ph.count; k += 2) {
        graph.links.push_back({ids[k], ids[k + 1]});
        graph.link_vertex.push_back(-1);
      }
    }
  }
  // Self mode: a pair sharing one vertex intersects in a segment from that vertex to its one hit.
  // Two such half segments at a vertex join there; otherwise the path ends at the vertex.
  graph.end_vertex.assign(r.hits.size(), -1);
  std::sort(vertex_halves.begin(), vertex_halves.end());
  for (size_t i = 0; i < vertex_halves.size();) {
    size_t j = i;
    while (j < vertex_halves.size() && vertex_halves[j][0] == vertex_halves[i][0]) ++j;
    const int v = vertex_halves[i][0];
    if (j - i == 2 && vertex_halves[i][1] != vertex_halves[i + 1][1]) {
      graph.links.push_back({vertex_halves[i][1], vertex_halves[i + 1][1]});
      graph.link_vertex.push_back(v);
    } else {
      for (size_t k = i; k < j; ++k)
        if (graph.end_vertex[vertex_halves[k][1]] < 0) graph.end_vertex[vertex_halves[k][1]] = v;
    }
    i = j;
  }
  // Approximate crossing points, for reporting.
  for (GiaHit& h : r.hits) {
    const MeshRef& em = mesh[h.edge_mesh];
    const MeshRef& tm = mesh[h.tri_mesh];
    const KeyedPoint p = em.point(em.topo->edges(h.edge, 0)), q = em.point(em.topo->edges(h.edge, 1));
    const Faces& f = *tm.f;
    const double* a = tm.point(f(h.tri, 0)).p;
    const double* b = tm.point(f(h.tri, 1)).p;
    const double* c = tm.point(f(h.tri, 2)).p;
    const double sp = orient3d_approx(a, b, c, p.p), sq = orient3d_approx(a, b, c, q.p);
    h.edge_t = sp == sq ? 0.5 : std::clamp(sp / (sp - sq), 0.0, 1.0);
    const Vec3 xp(p.p[0], p.p[1], p.p[2]), xq(q.p[0], q.p[1], q.p[2]);
    h.point = (1.0 - h.edge_t) * xp + h.edge_t * xq;
  }
  build_adjacency(graph, static_cast<int>(r.hits.size()));
  trace_paths(r, graph, {mesh[0].topo, mesh[self ? 0 : 1].topo});
  r.intersecting = !r.hits.empty();

  const int mesh_count = self ? 1 : 2;
  for (int m = 0; m < mesh_count; ++m) {
    GiaMeshColouring& out = r.mesh[m];
    out.edges = mesh[m].topo->edges;
    out.boundary_edge_count = mesh[m].topo->boundary_edge_count;
    out.closed = mesh[m].topo->closed;
    if (options.colour) colour_mesh(r, m, *mesh[m].x, *mesh[m].f, *mesh[m].topo);
  }
  if (!self && options.inside_test) {
    const std::int64_t far_key = mesh[1].key_offset + mesh[1].x->rows();
    for (int m = 0; m < 2; ++m) {
      const MeshRef& other = mesh[1 - m];
      if (!other.topo->closed) continue;
      r.mesh[m].inside_other =
          inside_by_parity(*mesh[m].x, mesh[m].key_offset, other, m == 0 ? tree1 : tree0, far_key, threads);
    }
  }
  r.seconds = timer.seconds();
  return r;
}

// Mesh A against mesh B, positions already checked.
GiaResult analyse_pair(const GiaMesh& a, const GiaMesh& b, const GiaOptions& options) {
  const MeshRef ma{&a.x, &a.f, &a.topology, 0};
  const MeshRef mb{&b.x, &b.f, &b.topology, static_cast<std::int64_t>(a.x.rows())};
  return analyse({ma, mb}, a.tree, b.tree, false, options);
}

}  // namespace

AabbTree gia_triangle_tree(const Positions& x, const Faces& f) {
  std::vector<Aabb> boxes;
  triangle_boxes(f, x, x, {}, boxes);
  AabbTree tree;
  tree.build(boxes);
  return tree;
}

GiaResult analyse_intersections(const Positions& xa, const Faces& fa, const Positions& xb, const Faces& fb,
                                const GiaOptions& options) {
  check_positions(xa, "mesh A");
  check_positions(xb, "mesh B");
  const GiaTopology ta = build_gia_topology(static_cast<int>(xa.rows()), fa);
  const GiaTopology tb = build_gia_topology(static_cast<int>(xb.rows()), fb);
  const AabbTree tree_a = gia_triangle_tree(xa, fa), tree_b = gia_triangle_tree(xb, fb);
  return analyse_pair(GiaMesh{xa, fa, ta, tree_a}, GiaMesh{xb, fb, tb, tree_b}, options);
}

GiaResult analyse_intersections(const GiaMesh& a, const GiaMesh& b, const GiaOptions& options) {
  check_positions(a.x, "mesh A");
  check_positions(b.x, "mesh B");
  return analyse_pair(a, b, options);
}

GiaResult analyse_self_intersections(const Positions& x, const Faces& f, const GiaOptions& options) {
  check_positions(x, "mesh");
  const GiaTopology t = build_gia_topology(static_cast<int>(x.rows()), f);
  const MeshRef m{&x, &f, &t, 0};
  const AabbTree tree = gia_triangle_tree(x, f);
  return analyse({m, m}, tree, tree, true, options);
}

std::vector<std::int8_t> points_inside_closed_mesh(const Positions& points, const Positions& x, const Faces& f,
                                                   int threads) {
  check_positions(points, "points");
  check_positions(x, "mesh");
  const GiaTopology topo = build_gia_topology(static_cast<int>(x.rows()), f);
  if (!topo.closed) throw MeshError("points_inside_closed_mesh: the mesh is not closed (watertight, manifold)");
  const AabbTree tree = gia_triangle_tree(x, f);
  const std::int64_t offset = points.rows();
  const MeshRef mesh{&x, &f, &topo, offset};
  return inside_by_parity(points, 0, mesh, tree, offset + x.rows(), threads);
}

}  // namespace weft
