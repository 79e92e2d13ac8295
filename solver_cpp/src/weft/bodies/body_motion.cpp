#include "weft/bodies/body_motion.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "weft/geometry/aabb_tree.h"

namespace weft {

bool closed_surface(const Faces& faces) {
  std::vector<std::pair<int, int>> edges;
  edges.reserve(3 * static_cast<size_t>(faces.rows()));
  for (int f = 0; f < faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = faces(f, k), b = faces(f, (k + 1) % 3);
      edges.emplace_back(std::min(a, b), std::max(a, b));
    }
  std::sort(edges.begin(), edges.end());
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j] == edges[i]) ++j;
    if (j - i != 2) return false;
    i = j;
  }
  return !edges.empty();
}

double body_thickness(const Positions& x, const Faces& faces) {
  double six_volume = 0.0, twice_area = 0.0;
  for (int f = 0; f < faces.rows(); ++f) {
    const Vec3 a = row3(x, faces(f, 0)), b = row3(x, faces(f, 1)), c = row3(x, faces(f, 2));
    six_volume += a.dot(b.cross(c));
    twice_area += (b - a).cross(c - a).norm();
  }
  // 2 V / A = 2 (six_volume / 6) / (twice_area / 2)
  return twice_area > 0.0 ? 2.0 * std::abs(six_volume) / (3.0 * twice_area) : 0.0;
}

int motion_halvings(const Positions& cloth_x, const Positions& cloth_v, double band, double cloth_edge,
                    const std::vector<BodyMotion>& bodies, int substeps, double frame_duration, int max_halvings) {
  if (max_halvings <= 0 || substeps < 1 || cloth_x.rows() == 0 || !(frame_duration > 0.0)) return 0;
  const int cloth_count = static_cast<int>(cloth_x.rows());
  const double h = frame_duration / substeps;
  // Each cloth vertex's way over the frame (at its velocity), grown by the band and half a
  // cloth edge: a body vertex whose own way overlaps none of these boxes passes near no cloth
  // vertex. Built on the first body that needs it.
  std::vector<Aabb> cloth_ways;
  AabbTree cloth_tree;
  double fastest = 0.0;  // the most a cloth vertex moves per substep
  for (int i = 0; i < cloth_count; ++i) fastest = std::max(fastest, h * Vec3(row3(cloth_v, i)).norm());
  int halvings = 0;
  std::vector<std::pair<double, int>> fast;  // (bound on the relative motion per substep, body vertex)
  for (const BodyMotion& body : bodies) {
    if (!(body.thickness > 0.0) || body.frame_start == nullptr || body.frame_end == nullptr) continue;
    const Positions& start = *body.frame_start;
    const Positions& end = *body.frame_end;
    const int count = static_cast<int>(start.rows());
    // Body vertices that could move, relative to some cloth vertex, by more than the level
    // reached so far allows, in order of that bound: the search stops once no pair can beat
    // what is found.
    double found = body.thickness * static_cast<double>(1 << halvings);
    fast.clear();
    for (int k = 0; k < count; ++k) {
      const double bound = (Vec3(row3(end, k)) - Vec3(row3(start, k))).norm() / substeps + fastest;
      if (bound > found) fast.emplace_back(bound, k);
    }
    if (fast.empty()) continue;
    std::sort(fast.begin(), fast.end(),
              [](const auto& a, const auto& b) { return a.first > b.first || (a.first == b.first && a.second < b.second); });
    if (cloth_tree.empty()) {
      cloth_ways.resize(cloth_count);
      for (int i = 0; i < cloth_count; ++i) {
        Aabb& way = cloth_ways[i];
        way.expand(Vec3(row3(cloth_x, i)));
        way.expand(Vec3(Vec3(row3(cloth_x, i)) + frame_duration * Vec3(row3(cloth_v, i))));
        way.inflate(band + 0.5 * cloth_edge);
      }
      cloth_tree.build(cloth_ways);
    }
    const double within = band + 0.5 * cloth_edge;
    // A body vertex and a cloth vertex move relative to each other by `relative` per substep;
    // the pair counts when, moving linearly over the frame (the body vertex between its
    // keyframes, the cloth vertex at its velocity), they pass within the band and half a cloth
    // edge of each other. The fastest such pair decides the body's level.
    for (const auto& [bound, k] : fast) {
      if (bound <= found) break;
      const Vec3 p = row3(start, k);
      const Vec3 body_step = (Vec3(row3(end, k)) - p) / substeps;
      Aabb way;
      way.expand(p);
      way.expand(Vec3(row3(end, k)));
      cloth_tree.query(way, [&](int i) {
        const Vec3 step = body_step - h * Vec3(row3(cloth_v, i));  // the body vertex's, seen from the cloth vertex
        const double relative = step.norm();
        if (relative <= found) return;
        // Nearest approach over the frame of the body vertex's relative path to the cloth vertex.
        const Vec3 gap = p - Vec3(row3(cloth_x, i));
        const Vec3 travel = substeps * step;
        const double t = std::clamp(-gap.dot(travel) / travel.squaredNorm(), 0.0, 1.0);
        if ((gap + t * travel).norm() <= within) found = relative;
      });
    }
    const double pieces = found / body.thickness;  // pieces a substep needs
    while (halvings < max_halvings && pieces > static_cast<double>(1 << halvings)) ++halvings;
  }
  return halvings;
}

}  // namespace weft
