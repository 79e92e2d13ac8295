// Strain limiting (Provot 1995, "Deformation constraints in a mass-spring model"; Bridson,
// Fedkiw & Anderson 2002): the velocity changes of the collision stage act per vertex (friction
// holding a vertex on a limb that swings at metres per second, repulsion, impulses), so the
// implicit solve's elasticity only sees them a step later. Before CCD, every cloth edge that the
// step would stretch beyond its allowed length is shortened by moving its ends' end-of-step
// positions towards each other, weighted by inverse mass; Gauss-Seidel over the edges in a
// fixed order, a few passes. CCD runs after it, so the step stays collision-free. Its impulses
// stop single vertices (at a body, at other cloth) and leave their neighbours going on, which
// stretches the edges between them past the limit again; once CCD has found the step
// collision-free the limit runs one more round, holding what the impulses moved (CcdMoved
// below), and CCD's passes go on over what that round moved (collision_system.cpp). The
// allowed length is `max_strain` times the rest length, or, for an edge that starts the step
// longer than that, the limit plus half of its excess: a stretch that a pin or a body forces is
// given back gradually instead of being yanked back in one step (it is forced again where the
// cause persists), and a stretch the CCD impulses left relaxes towards the limit instead of
// ratcheting up from step to step.
#pragma once

#include <array>
#include <vector>

#include "weft/collision/collision_step.h"

namespace weft {

// Per cloth vertex, what moved it in a step's CCD passes. The strain limit's round after CCD
// leaves a vertex a cloth/cloth impulse moved where it is (a layer pulled back towards the
// layer it was pushed off meets it again), holds one a body impulse moved while the edge's
// other end is free (the free end follows it: cloth beside a vertex stopped on a body is
// dragged along instead of torn from it), and shares the correction by inverse mass between
// two vertices body impulses moved (a patch stopped unevenly on a body).
enum class CcdMoved : char { kNo = 0, kByBody = 1, kByCloth = 2 };

class StrainLimit {
 public:
  StrainLimit() = default;
  // The unique edges of `faces` with rest lengths from the triangles' rest frames (per face, the
  // rest lengths of edges (0,1), (1,2), (2,0)); max_strain <= 1 switches the limit off.
  StrainLimit(const Faces& faces, const std::vector<std::array<double, 3>>& face_rest_lengths, double max_strain,
              int passes = 4);
  // Adjusts step.v (and step.x_end) of free vertices; returns the number of edge corrections.
  // ccd_moved (per cloth vertex; the round after CCD): the vertices it holds, as CcdMoved says.
  int apply(CollisionStep& step, const ContactProperties& props,
            const std::vector<CcdMoved>* ccd_moved = nullptr) const;
  bool enabled() const { return !edges_.empty(); }

 private:
  std::vector<std::array<int, 2>> edges_;
  std::vector<double> limit_;  // max_strain x rest length, per edge
  int passes_ = 4;
};

// Of an edge's length beyond the limit at the step's start, the fraction the step may keep.
constexpr double kKeptExcess = 0.5;

}  // namespace weft
