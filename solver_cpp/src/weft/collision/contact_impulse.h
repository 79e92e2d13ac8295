// Geometry and impulses shared by proximity and CCD response: closest-point weights of a
// feature pair, a cheap box filter, contact normals, and the impulse (with Coulomb friction)
// that changes a pair's relative normal velocity. Kinematic bodies and pinned vertices have
// infinite mass.
#pragma once

#include <array>

#include "weft/collision/collision_step.h"

namespace weft {

// Closest points of a pair in one configuration: weights w (sum w_i x_i is the gap vector from
// the second primitive to the first) and the distance.
double pair_weights(const std::array<Vec3, 4>& x, bool edge_edge, std::array<double, 4>& w);

// Whether the boxes of the pair's two primitives (over one or two configurations) come within
// `gap` of each other: a cheap filter before distance and CCD tests.
bool boxes_within(const std::array<Vec3, 4>& s, const std::array<Vec3, 4>& e, bool edge_edge, double gap);

// sum w_i x_i
Vec3 combine(const std::array<Vec3, 4>& x, const std::array<double, 4>& w);

// A contact normal pointing from the second primitive to the first: the gap direction when the
// gap is resolvable, else the geometric normal oriented by `side` (a vector known to point to
// the first primitive's side), else -side.
Vec3 contact_normal(const std::array<Vec3, 4>& x, bool edge_edge, const Vec3& gap, double distance, double scale,
                    const Vec3& side);

// Changes the pair's relative normal velocity (along n, weights w) by delta_vn, with friction
// reducing the tangential relative velocity; updates step.v, step.x_end and step.changed.
void apply_impulse(CollisionStep& step, const ContactProperties& props, const FeaturePair& pair,
                   const std::array<double, 4>& w, const Vec3& n, double delta_vn, double friction);

}  // namespace weft
