// Fixed force elements (the seed's FFEs): every persistent force aggregated into elements of up
// to four particles. Each hinge element (bending over two triangles, four particles) also carries
// the stretch and shear of one of its two triangles; triangles left over become three-particle
// elements; every particle's own forces (gravity, drag) are assigned to exactly one element that
// contains it. Each element writes its force and Jacobian blocks, already combined into the
// implicit system's local contributions
//     A_e = h^2 K_e + h D_e,    b_e = h (f_e - h K_e v_e),
// into its own slots, so all elements run in parallel without locks. Only the upper 3x3 blocks
// (a <= b) of the symmetric A_e are stored.
#pragma once

#include <cstdint>

#include "weft/forces/forces.h"

namespace weft {

constexpr int kElementSlots = 10;  // upper blocks of a 4x4 block matrix

inline int element_slot(int a, int b) {  // a <= b < 4
  return a * 4 - a * (a - 1) / 2 + (b - a);
}

struct ForceElementLayout {
  std::vector<std::array<int, 4>> vertices;     // original vertex indices; count[e] of them used
  std::vector<std::uint8_t> count;              // 3 or 4
  std::vector<int> hinge;                       // hinge index or -1
  std::vector<int> face;                        // face index or -1
  std::vector<std::array<std::int8_t, 3>> face_slot;  // local positions of the face's corners
  std::vector<std::uint8_t> owned;              // bit a: element owns vertex a's particle forces
  // One element per force (a triangle's stretch, its shear, a hinge's bending, a particle's
  // gravity and its drag) against the aggregated count.
  long long per_force_elements = 0;
  int size() const { return static_cast<int>(vertices.size()); }
};

// pins: particles with prescribed motion; counted as per-particle forces in per_force_elements
// (they are constraints of the filtered solve here, not forces).
ForceElementLayout build_force_elements(const ClothMesh& mesh, bool has_drag, int pinned_vertices);

// Reorders the elements: element k becomes the old element order[k].
void permute_elements(ForceElementLayout& layout, const std::vector<int>& order);

template <class Scalar>
struct ForceElementStorage {
  std::vector<Scalar> blocks;     // element e, slot s: 9 values at (e * kElementSlots + s) * 9
  std::vector<double> rhs;        // element e, local vertex a: 3 values at (e * 4 + a) * 3
};

// Computes every element for state (x, v) at time `time` and step h, in parallel.
template <class Scalar>
void compute_force_elements(const ForceModel& model, const ForceElementLayout& layout, const Positions& x,
                            const Positions& v, double time, double h, int threads, ForceElementStorage<Scalar>& out);

}  // namespace weft
