// ContactDetection::point_pairs (contact_detection.h): the proximity list against a body that
// the contact constraints looked at, found point by point (cloth vertices, body corners, body
// edges that reach) instead of by expanding triangle pairs.
#include <algorithm>
#include <cstdint>

#include "weft/collision/contact_detection.h"
#include "weft/common/ordered_append.h"

namespace weft {

void ContactDetection::point_pairs(const Positions& x, const CollisionStep& step, std::vector<FeaturePair>& pairs) {
  const std::vector<Positions>& body_x = step.body_start;
  // Each cloth vertex once (from the face that owns it), each of vertex_bodies_ in order: the
  // body faces whose boxes come within the face's margin of it and whose plane does not keep
  // it farther (the plane test of collect, for a point).
  const auto face_count = static_cast<std::int64_t>(cloth_faces_.rows());
  ordered_append(face_count, kExpandChunk, threads_, pairs, chunk_pairs_, [&](std::int64_t cf, std::vector<FeaturePair>& out) {
    if (!face_collide_[cf]) return;
    const double gap = face_margin_[cf];
    const double limit = gap * (1.0 + kPlaneSlack);
    for (int v : cloth_own_.face_vertices[cf]) {
      if (step.clear_vertices && (*step.clear_vertices)[v]) continue;  // no face it could act with
      const Vec3 p = row3(x, v);
      Aabb box;
      box.lo = p - Vec3::Constant(gap);
      box.hi = p + Vec3::Constant(gap);
      for (int body : vertex_bodies_) {
        const Body& b = bodies_[body];
        b.tree.query(box, [&](int bf) {
          const Vec3& n = b.planes.normal[bf];
          if (n != Vec3::Zero() && std::abs(n.dot(p - b.planes.origin[bf])) > limit) return;
          out.push_back({{v, -1 - b.faces(bf, 0), -1 - b.faces(bf, 1), -1 - b.faces(bf, 2)}, body, false});
        });
      }
    }
  });
  // Each body corner (of vertex_bodies_, in order) with the cloth faces whose boxes (grown by
  // their margin) hold it and whose plane does not keep it farther than that margin. All the
  // bodies' corners in one parallel pass (a part of a character has fewer corners than one
  // chunk), listed body after body as one pass per body would.
  point_start_.assign(1, 0);
  for (int body : vertex_bodies_) point_start_.push_back(point_start_.back() + bodies_[body].vertex_count);
  auto body_at = [](const std::vector<std::int64_t>& start, std::int64_t k) {
    return static_cast<size_t>(std::upper_bound(start.begin(), start.end(), k) - start.begin() - 1);
  };
  ordered_append(point_start_.back(), kExpandChunk, threads_, pairs, chunk_pairs_, [&](std::int64_t k, std::vector<FeaturePair>& out) {
    const size_t slot = body_at(point_start_, k);
    const int body = vertex_bodies_[slot];
    const int corner = static_cast<int>(k - point_start_[slot]);
    const Vec3 q = row3(body_x[body], corner);
    Aabb point;
    point.lo = point.hi = q;
    cloth_tree_.query(point, [&](int cf) {
      if (!face_collide_[cf]) return;
      const Vec3& n = cloth_planes_.normal[cf];
      if (n != Vec3::Zero() && std::abs(n.dot(q - cloth_planes_.origin[cf])) > face_margin_[cf] * (1.0 + kPlaneSlack))
        return;
      out.push_back({{-1 - corner, cloth_faces_(cf, 0), cloth_faces_(cf, 1), cloth_faces_(cf, 2)}, body, false});
    });
  });
  // Each body edge that can reach a cloth edge between two vertices kept off (sharp_edges.h)
  // with the cloth edges whose boxes, grown by their face's margin, overlap its box: its sharp
  // edges, and its blunt ones advancing along their normal by more than half a separation over
  // the step. (Measured against the cloth's own motion instead, a sheet dragged by a fast limb
  // lost the pairs that held it: weft regress's thin limb tore, strain 1.5 -> 4.4.) Every
  // body's edges in one parallel pass, body after body.
  reach_edges_.clear();
  point_start_.assign(1, 0);
  for (int body : vertex_bodies_) {
    const SharpEdges& sharp = (*step.sharp_edges)[body];
    for (int leaf = 0; leaf < sharp.size(); ++leaf) reach_edges_.push_back(sharp.edge(leaf));
    sharp.advancing(body_x[body], step.body_end[body], 0.5 * sharp.separation(), reach_edges_);
    point_start_.push_back(static_cast<std::int64_t>(reach_edges_.size()));
  }
  ordered_append(point_start_.back(), kExpandChunk, threads_, pairs, chunk_pairs_, [&](std::int64_t k, std::vector<FeaturePair>& out) {
    const int body = vertex_bodies_[body_at(point_start_, k)];
    const Positions& bx = body_x[body];
    const std::array<int, 2>& be = reach_edges_[static_cast<size_t>(k)];
    Aabb edge;
    edge.lo = edge.hi = row3(bx, be[0]);
    edge.expand(row3(bx, be[1]));
    cloth_tree_.query(edge, [&](int cf) {
      if (!face_collide_[cf]) return;
      for (const auto& ce : cloth_own_.face_edges[cf]) {
        Aabb near;
        near.lo = near.hi = row3(x, ce[0]);
        near.expand(row3(x, ce[1]));
        near.inflate(face_margin_[cf]);
        if (near.overlaps(edge)) out.push_back({{ce[0], ce[1], -1 - be[0], -1 - be[1]}, body, true});
      }
    });
  });
}

}  // namespace weft
