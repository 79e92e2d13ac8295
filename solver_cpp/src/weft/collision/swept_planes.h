// The broad phase's plane test (ContactDetection::collect): a triangle pair whose corners lie
// all beyond one face's plane, farther than the gap plus that face's motion over the step, can
// never come within the gap, nor can any of its feature pairs whose corners lie so. Kept per
// face (SweptPlanes) and per triangle pair (PlaneSides, read feature by feature).
#pragma once

#include <array>
#include <vector>

#include "weft/common/types.h"

namespace weft {

// Relative slack of the plane test's limit for the proximity list. Resting contact holds cloth
// at exactly the thickness, where a point's distance to a plane and its distance to the face
// (computed by other arithmetic: point_triangle_distance, segment_segment_distance) can differ
// in the last bits; a pair at the gap is listed rather than dropped on rounding.
inline constexpr double kPlaneSlack = 1e-6;

// Per face, over a step: the unit normal of its start plane (zero when degenerate), a point of
// that plane (corner 0 at the start) and its largest corner displacement. The plane test reads
// them instead of recomputing them for every triangle pair.
struct SweptPlanes {
  std::vector<Vec3> normal, origin;
  std::vector<double> motion;
  void compute(const Faces& faces, const Positions& start, const Positions& end, int threads);
  // The same for the listed faces only (the others keep theirs).
  void compute_faces(const Faces& faces, const Positions& start, const Positions& end, const std::vector<int>& list);

 private:
  void compute_face(const Faces& faces, const Positions& start, const Positions& end, int f);
};

// A triangle pair's plane test, corner by corner: the lowest and highest signed distance over
// the step (start and end) of each face's corners to the other face's start plane, and how far
// beyond that plane a point must stay to remain more than the gap from the other face (gap plus
// that face's largest corner displacement; infinite where the face is degenerate and has no
// plane). Every point of a moving face stays within its largest corner displacement of its start
// plane, and a feature's points over the step are convex combinations of its corners' start and
// end positions, so a feature whose corners all lie beyond on one side stays more than the gap
// from the whole other face, hence from each of its features.
struct PlaneSides {
  std::array<double, 3> cloth_lo, cloth_hi;  // the cloth face's corners against the other's plane
  std::array<double, 3> other_lo, other_hi;  // the other face's corners against the cloth face's
  double cloth_limit = 0.0, other_limit = 0.0;
  // Corners by bit (1 << corner, in the faces' own order): whether either plane keeps the cloth
  // face's corners `cloth_mask` and the other face's `other_mask` apart.
  bool apart(int cloth_mask, int other_mask) const;
};

// The plane test of triangle pair (a of fa, b of fb) over a step (as..ae and bs..be; the same
// object: static): true when either plane keeps the whole triangles apart (then `sides` may be
// half filled: B's corners against A's plane are measured first, and a separating plane ends
// the test). `exact`: the pair's list is the proximity list, whose response acts exactly within
// the gap (the limit gets kPlaneSlack); for CCD's lists (not exact) the gap is taken sqrt(3)
// times: CCD measures its minimum separation in the infinity norm of the gap vector, down to
// 1/sqrt(3) of the Euclidean distance bounded here. With a shift the test is
// made in the frame that moves by `shift` over the step (sweep_frame.h): end positions less
// the shift, each face's motion measured there.
bool triangles_apart(const SweptPlanes& pa, int a, const Faces& fa, const Positions& as, const Positions& ae,
                     const SweptPlanes& pb, int b, const Faces& fb, const Positions& bs, const Positions& be,
                     double gap, bool exact, PlaneSides& sides, const Vec3* shift = nullptr);

}  // namespace weft
