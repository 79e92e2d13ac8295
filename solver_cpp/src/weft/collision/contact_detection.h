// Contact detection, the first part of the collision stage (collision_system.h): refit the AABB
// trees, collect the overlapping triangle pairs cloth/body and cloth/cloth, and expand each
// into vertex-triangle and edge-edge feature pairs, each pair once (representative-triangle
// ownership, closest_points.h). Two lists, each with boxes no larger than its test needs:
// proximity pairs at the step's start within one thickness, CCD pairs over the step (boxes
// swept from x to x_end) within CCD's minimum separation. Tree nodes whose cloth cannot touch
// itself are culled (self_culling.h), triangle pairs that a triangle's plane keeps apart over
// the step are dropped before expansion, and feature pairs whose boxes do not come within the
// gap are not listed (the responses' own first test). The GIA membranes and pinch regions skip
// pairs through a ContactFilter.
#pragma once

#include <array>
#include <cstdint>
#include <utility>
#include <vector>

#include "weft/bodies/bodies.h"
#include "weft/collision/collision_step.h"
#include "weft/collision/contact_filter.h"
#include "weft/collision/self_culling.h"
#include "weft/collision/sweep_frame.h"
#include "weft/collision/swept_planes.h"
#include "weft/geometry/aabb_tree.h"
#include "weft/geometry/closest_points.h"

namespace weft {

// The configuration (start and end positions) something was last computed from, kept to tell
// whether a recomputation would give the same: a body standing still, or the same body state
// asked for twice in a step (the contact constraints and the proximity list both at the step's
// start), is then not refitted again. Compared bit for bit.
class FittedAt {
 public:
  bool same(const Positions& start, const Positions& end) const;
  void set(const Positions& start, const Positions& end);

 private:
  Positions start_, end_;
  bool valid_ = false;
};

class ContactDetection {
 public:
  struct Body {
    bool collide = false;
    int vertex_count = 0;
    Faces faces;
    FeatureOwnership own;
    AabbTree tree;
    std::vector<Aabb> boxes;              // over the step (start and end)
    std::vector<Aabb> start_boxes, end_boxes;  // of a moving refit (start and end not the same object)
    FittedAt boxes_at;   // boxes and tree
    SweptPlanes planes;  // collect(), collect_changed()
    FittedAt planes_at;
  };

  // face_collide / face_self: per cloth face; face_margin: per cloth face, its box growth (the
  // largest thickness of its vertices); body_collide: per body. Trees are built at x and at
  // the bodies' frame start.
  ContactDetection(const Faces& cloth_faces, const Positions& x, std::vector<char> face_collide,
                   std::vector<char> face_self, std::vector<double> face_margin,
                   const std::vector<KinematicBody>& bodies, const std::vector<char>& body_collide,
                   bool self_culling = true);

  // Cloth boxes over start..end (the same object: static boxes), widened by `fraction` of each
  // face's margin. moving: the tree also keeps the start and end boxes (AabbTree::moving), for
  // the traversals in a body's sweep frame.
  void refit_cloth(const Positions& start, const Positions& end, double fraction = 1.0, bool moving = false);
  // Refit body `body`'s tree over start..end (the same object: static) and return its
  // overlapping (cloth face, body face) pairs against the cloth tree as last refitted.
  const std::vector<std::pair<int, int>>& body_pairs(int body, const Positions& start, const Positions& end);
  // The same, appended to out.
  void body_pairs(int body, const Positions& start, const Positions& end, std::vector<std::pair<int, int>>& out);
  // Refit body `body`'s boxes and tree over start..end (the same object: static) and return it:
  // the contact constraints query it vertex by vertex. Nothing is recomputed when start and end
  // are those of the last refit (Body::boxes_at). Moving (start and end not the same object),
  // the tree keeps its start and end boxes (AabbTree::moving) for a shifted traversal.
  const Body& refit_body(int body, const Positions& start, const Positions& end);
  // refit_body and fit_body_planes for every colliding body over the step (swept: start to
  // end, else at the start), the bodies in parallel: what collect() and the contact
  // constraints then ask of a body is already fitted.
  void refit_bodies(const CollisionStep& step, bool swept);
  // Broad phase. swept: over the step from step.x to step.x_end within the CCD minimum
  // separation, into step.pairs; else at step.x within one thickness, into
  // step.proximity_pairs. Cloth in a pinch region gets no CCD. The swept list's cloth/body
  // pairs are those whose boxes come within the gap in the body's sweep frame (sweep_frame.h;
  // body_shift()), chosen here for the step's CCD passes.
  void collect(CollisionStep& step, const ContactFilter& filter, CollisionTelemetry& frame, bool swept);
  // The CCD list of a pass after the first (collision_system.cpp): only triangle pairs with a
  // face that has a vertex in step.changed (velocity changed since the last pass), found by
  // querying those faces' swept boxes against the trees instead of traversing them whole. Every
  // feature pair with a changed point comes from such a triangle pair (each feature belongs to a
  // face that holds its points), and the same culling, plane test and filter apply, so the
  // pairs an incremental CCD pass examines are those of a full collect(.., true), in another
  // order (in the sweep frames the swept collect chose). After the step's swept collect(), only
  // the changed faces' boxes, planes and culling are redone (the rest of x_end has not moved);
  // the body trees are not refitted again.
  void collect_changed(CollisionStep& step, const ContactFilter& filter, CollisionTelemetry& frame);
  // Candidates for the exact intersection count at the static configuration x: triangle pairs
  // with overlapping boxes (no margin), without the self-pairs of tree nodes that cannot
  // intersect themselves (self_culling.h at margin 0). Refits the trees (collect refits anew).
  const std::vector<std::pair<int, int>>& self_intersection_candidates(const Positions& x);

  // Where a triangle pair's points are over the step (cloth start and end; the other face's:
  // the cloth's again, or its body's), the gap within which two features' boxes must come
  // for their pair to be listed, optionally the pair's plane test, and the frame the boxes are
  // swept in (end positions less `shift`, sweep_frame.h; null: the world).
  struct Sweep {
    const Positions* cloth_start;
    const Positions* cloth_end;
    const Positions* other_start;
    const Positions* other_end;
    double gap;
    const PlaneSides* planes = nullptr;
    const Vec3* shift = nullptr;
  };
  // Feature pairs of cloth face `cloth_face` against `other_face`, a cloth face (body < 0) or a
  // face of body `body`, appended to out. With a sweep, pairs whose two features' boxes over
  // the step (the first feature's grown by sweep->gap) do not overlap are left out: that is
  // boxes_within, the first test of the proximity and CCD responses, computed the same way, and
  // collect() passes a gap no smaller than theirs, so what they do is unchanged; most feature
  // pairs of a triangle pair are such. With the sweep's plane test (triangles_apart's
  // distances, corner by corner), pairs that either face's plane keeps farther apart than the
  // test's limit are left out too: for the proximity list more than the gap (its response acts
  // only within the gap: on the resting drape of `weft bench contact`, about a quarter fewer
  // pairs listed), for CCD's lists more than sqrt(3) gaps plus the plane's motion (a feature
  // whose corners stay so far beyond stays farther than the gap in CCD's norm for the whole
  // step, as the triangle pair's own test argues for all corners: on the standing dress a fifth
  // fewer CCD candidates, positions bitwise unchanged). Pairs in a pinch region (no CCD) are
  // always listed.
  void expand_triangle_pair(int cloth_face, int other_face, int body, const ContactFilter& filter,
                            std::vector<FeaturePair>& out, const Sweep* sweep = nullptr) const;

  const Faces& cloth_faces() const { return cloth_faces_; }
  // The cloth tree's quality at x (boxes grown by the proximity margins): the surface cost of the
  // tree refitted there and of one built afresh there. The tree is built once, from the shot's
  // first positions, and refitted ever after (a rebuild would also make a run resumed from a cache
  // differ from the uninterrupted one); `python -m bench.tree_quality` follows the ratio.
  std::pair<double, double> cloth_tree_quality(const Positions& x) const;
  const std::vector<char>& face_collide() const { return face_collide_; }
  const std::vector<char>& face_self() const { return face_self_; }
  const std::vector<Aabb>& cloth_boxes() const { return cloth_boxes_; }
  const FeatureOwnership& cloth_ownership() const { return cloth_own_; }
  const std::vector<Body>& bodies() const { return bodies_; }
  bool any_self() const { return any_self_; }
  // Body b's sweep frame in the last swept collect (zero: the world's).
  const Vec3& body_shift(int b) const { return body_shift_[b]; }
  bool any_body() const { return any_body_; }
  // The bodies that collide, in order.
  const std::vector<int>& colliding() const { return colliding_; }
  // Threads of the narrow filtering and expansion in collect(); its lists are the same for any count.
  void set_threads(int threads) { threads_ = threads; }
  int threads() const { return threads_; }

 private:
  // The proximity pairs against vertex_bodies_ (collect()), appended to pairs: every collidable
  // cloth vertex at x with the body faces within its face's margin, then every body corner with
  // the cloth faces within theirs, then every body edge that can reach the cloth (sharp or
  // pushing this step; CollisionStep::sharp_edges) with the cloth edges within their margin.
  // Body features at step.body_start.
  void point_pairs(const Positions& x, const CollisionStep& step, std::vector<FeaturePair>& pairs);
  // The cloth's sweep frame for its pairs with itself (self_shift_) and, per body, the body's
  // (body_shift_, its tree refitted over the step moving); whether any is not the world's.
  bool choose_sweep_frames(const CollisionStep& step);
  // Cloth face f's box over the step in the frame moving by `shift` (the tree moving).
  Aabb shifted_cloth_box(int f, const Vec3& shift) const;
  // Body::planes over start..end, unless those of the last call (Body::planes_at).
  void fit_body_planes(int body, const Positions& start, const Positions& end);

  Faces cloth_faces_;
  std::vector<char> face_collide_, face_self_;
  std::vector<double> face_margin_, scaled_margin_;
  double largest_margin_ = 0.0;
  // The smallest margin of a self-colliding face: each box of a self pair is grown by its face's
  // margin, and a pair is wanted within the larger of the two, so the self traversals ask the
  // boxes to overlap by this much (AabbTree::self_pairs' shrink), not to merely touch.
  double self_shrink_ = 0.0;
  bool any_self_ = false, any_body_ = false;
  bool self_culling_ = true;
  SelfCollisionCulling culling_;  // with self-collision and self_culling_
  FeatureOwnership cloth_own_;
  AabbTree cloth_tree_;
  std::vector<Aabb> cloth_boxes_;
  std::vector<Aabb> cloth_start_boxes_, cloth_end_boxes_;  // of a moving refit, as Body's
  SweepFrame sweep_frame_;        // collect(): picks self_shift_
  std::vector<SweepFrame> body_sweep_frames_;  // collect(): per body, picks its body_shift_
  std::vector<Vec3> body_shift_;  // per body: the sweep frame of the step's swept lists
  Vec3 self_shift_ = Vec3::Zero();  // the cloth's with itself
  SweptPlanes cloth_planes_;  // collect(), collect_changed()
  std::vector<Body> bodies_;
  std::vector<std::pair<int, int>> scratch_pairs_;
  std::vector<int> changed_faces_, leaf_culled_top_;  // collect_changed()
  std::vector<char> face_changed_;
  // The cloth's boxes, planes and culling are those of the last swept collect() (at the CCD
  // fraction, over step.x .. step.x_end), updated by collect_changed() since: a later
  // collect_changed() of the same step redoes only the changed faces'. Any other refit clears it.
  bool swept_cloth_current_ = false;
  std::vector<std::vector<FeaturePair>> chunk_pairs_;  // collect(): per chunk of triangle pairs
  std::vector<std::vector<std::pair<int, int>>> body_candidates_;  // collect(): per body, (cloth, body face)
  std::vector<std::int64_t> candidate_start_;  // collect(): body b's candidates start at this index of all
  std::vector<char> body_plain_;               // per body: the filter skips nothing against it
  std::vector<int> vertex_bodies_;             // collect(): bodies whose proximity pairs are found per vertex
  std::vector<std::array<int, 2>> reach_edges_;  // point_pairs(): the bodies' edges that get edge pairs
  // Triangle pairs (or points) per parallel chunk of the plane test and expansion (collect).
  static constexpr std::int64_t kExpandChunk = 512;
  std::vector<int> colliding_;  // the bodies that collide, in order
  std::vector<std::int64_t> point_start_;  // point_pairs(): where each of vertex_bodies_ starts in a pass
  int threads_ = 1;
};

}  // namespace weft
