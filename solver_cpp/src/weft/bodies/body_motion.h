// How far a kinematic body moves through the cloth it can reach within one substep, measured
// against its own thickness: the step-size estimate made at the start of each frame.
//
// The contacts in the solve are linearized at a substep's start. A body that moves more than
// its own thickness relative to the cloth within one substep (a thin limb at metres per
// second) sweeps through cloth that was beyond the contact band at the start: CCD and its
// impulses catch it after the solve, on a strip of vertices as narrow as the body, and tear
// the edges beside it. Adaptive substepping then halves the step after the fact, paying for
// the abandoned attempt each time; a frame whose bodies are known to move that fast starts
// its substeps halved instead (Simulation::advance_frame, SubstepLevel's floor).
//
// Thickness of a closed body: twice its volume over its area (a tube's radius, a plate's
// thickness, two thirds of a sphere's radius). Open bodies have no thickness and never ask
// for halvings. Motion is relative to the cloth it meets: a body vertex against each cloth
// vertex whose way over the frame (the body vertex between its keyframes, the cloth vertex at
// its velocity) passes within the contact band and half a cloth edge of its own (a sleeve
// carried by its limb moves little relative to it; cloth falling onto a still bar does). The
// estimate looks at body vertices only: a coarse body whose face sweeps cloth that its corners
// pass far from (a box foot's long faces) asks for nothing, and the halvings after the fact
// still catch what that misses. Growing the reach by half a body edge instead made the
// walking character's box feet ask for halvings on trousers and a loose skirt that no step
// needed (8% dearer trousers, no strain or contact changed).
#pragma once

#include <vector>

#include "weft/common/types.h"

namespace weft {

// Every edge of the triangle mesh is shared by exactly two of its faces.
bool closed_surface(const Faces& faces);

// 2 |volume| / area of a closed triangle mesh (0 for a mesh of no area).
double body_thickness(const Positions& x, const Faces& faces);

struct BodyMotion {
  const Positions* frame_start = nullptr;  // body vertices at the frame's start and end
  const Positions* frame_end = nullptr;
  double thickness = 0.0;  // body_thickness; <= 0: never asks for halvings (open, not colliding)
};

// Halvings (0..max_halvings) after which no body moves, relative to the cloth within its
// reach, by more than its thickness in one piece of a substep. `cloth_x`, `cloth_v`: the
// cloth at the frame's start; `band`: how near cloth must come to count (the contact band);
// `cloth_edge`: the cloth's longest edge (a body vertex passing between cloth vertices); the
// frame is `substeps` substeps of `frame_duration` in all.
int motion_halvings(const Positions& cloth_x, const Positions& cloth_v, double band, double cloth_edge,
                    const std::vector<BodyMotion>& bodies, int substeps, double frame_duration, int max_halvings);

}  // namespace weft
