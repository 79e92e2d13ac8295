// Strain limiting (Provot 1995, "Deformation constraints in a mass-spring model"; Bridson,
// Fedkiw & Anderson 2002): the velocity changes of the collision stage act per vertex (friction
// holding a vertex on a limb that swings at metres per second, repulsion, impulses), so the
// implicit solve's elasticity only sees them a step later. Before CCD, every cloth edge that the
// step would stretch beyond its allowed length is shortened by moving its ends' end-of-step
// positions towards each other, weighted by inverse mass; Gauss-Seidel over the edges in a
// fixed order, up to kStrainLimitPasses passes, stopping at the first pass that corrects
// nothing. After the first pass only the edges at a vertex that moved in the previous or the
// current pass are measured again (the others cannot have changed): the result of full passes,
// the lengths measured only where something is still in play. A corrected edge is shortened to
// a hair (kStrainLimitSlack) under its allowed length, so the next edge's correction along the
// same line of vertices does not put it straight back over. A pull on a ribbon spreads one edge
// further per pass: four passes (the default until the thirty-first session) stopped with up to
// 146 edges still 4% over on the articulated dress (docs/collisions.md). CCD runs after it, so
// the step stays collision-free, and its impulses can stretch an edge past the limit again. The
// allowed length is `max_strain` times the rest length, or, for an edge that starts the step
// longer than that, the limit plus half of its excess: a stretch that a pin or a body forces is
// given back gradually instead of being yanked back in one step (it is forced again where the
// cause persists), and a stretch the CCD impulses left relaxes towards the limit instead of
// ratcheting up from step to step. A vertex the contact constraints held on a body this step
// is moved along the body, not into it: on a tight dress over swinging thighs, friction drags
// held hem vertices and the limit pulled them back along the edge's chord, into the leg, where
// CCD pushed them out again by 1-2.5 mm and stretched the edge past the limit once more
// (docs/collisions.md, thirty-fourth session).
#pragma once

#include <array>
#include <vector>

#include "weft/collision/collision_step.h"

namespace weft {

// Gauss-Seidel passes at most, per step.
constexpr int kStrainLimitPasses = 16;
// A corrected edge ends this fraction under its allowed length.
constexpr double kStrainLimitSlack = 1e-3;

class StrainLimit {
 public:
  StrainLimit() = default;
  // The unique edges of `faces` with rest lengths from the triangles' rest frames (per face, the
  // rest lengths of edges (0,1), (1,2), (2,0)); max_strain <= 1 switches the limit off.
  StrainLimit(const Faces& faces, const std::vector<std::array<double, 3>>& face_rest_lengths, double max_strain,
              int passes = kStrainLimitPasses);
  // Adjusts step.v (and step.x_end) of free vertices; returns the number of edge corrections.
  // contact_normals (per cloth vertex, or null): the outward normal of the body a vertex is held
  // on this step, zero where none; such a vertex's share of a correction loses its part into
  // the body (it slides along the body instead of being pulled into it).
  int apply(CollisionStep& step, const ContactProperties& props,
            const std::vector<Vec3>* contact_normals = nullptr) const;
  bool enabled() const { return !edges_.empty(); }
  // Whether moving the end positions of some vertices by end_change (per cloth vertex; the step's
  // x_end is after the move) lengthened an edge at one of them to beyond its allowed length.
  bool lengthened_beyond(const CollisionStep& step, const std::vector<Vec3>& end_change) const;

 private:
  // Edge k's allowed length for a step from x: the limit, or the limit plus kKeptExcess of the
  // excess it starts with.
  double allowed_length(size_t k, const Positions& x) const;

  std::vector<std::array<int, 2>> edges_;
  std::vector<double> limit_;  // max_strain x rest length, per edge
  int passes_ = kStrainLimitPasses;
};

// Of an edge's length beyond the limit at the step's start, the fraction the step may keep.
constexpr double kKeptExcess = 0.5;

}  // namespace weft
