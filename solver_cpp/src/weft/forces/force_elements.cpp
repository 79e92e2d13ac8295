#include "weft/forces/force_elements.h"

namespace weft {

ForceElementLayout build_force_elements(const ClothMesh& mesh, bool has_drag, int pinned_vertices) {
  ForceElementLayout layout;
  const int face_count = static_cast<int>(mesh.faces.rows());
  std::vector<char> face_taken(face_count, 0), vertex_owned(mesh.vertex_count, 0);
  auto add = [&](const int* vertices, int count, int hinge, int face) {
    std::array<int, 4> vs{-1, -1, -1, -1};
    std::uint8_t owned = 0;
    for (int a = 0; a < count; ++a) {
      vs[a] = vertices[a];
      if (!vertex_owned[vertices[a]]) {
        vertex_owned[vertices[a]] = 1;
        owned |= static_cast<std::uint8_t>(1u << a);
      }
    }
    std::array<std::int8_t, 3> slots{-1, -1, -1};
    if (face >= 0)
      for (int c = 0; c < 3; ++c)
        for (int a = 0; a < count; ++a)
          if (vs[a] == mesh.faces(face, c)) slots[c] = static_cast<std::int8_t>(a);
    layout.vertices.push_back(vs);
    layout.count.push_back(static_cast<std::uint8_t>(count));
    layout.hinge.push_back(hinge);
    layout.face.push_back(face);
    layout.face_slot.push_back(slots);
    layout.owned.push_back(owned);
  };
  // Greedy: each hinge takes the first of its two triangles not yet taken.
  for (size_t k = 0; k < mesh.hinges.size(); ++k) {
    int face = -1;
    for (int f : mesh.hinge_faces[k])
      if (face < 0 && !face_taken[f]) face = f;
    if (face >= 0) face_taken[face] = 1;
    add(mesh.hinges[k].data(), 4, static_cast<int>(k), face);
  }
  for (int f = 0; f < face_count; ++f) {
    if (face_taken[f]) continue;
    const int vs[3] = {mesh.faces(f, 0), mesh.faces(f, 1), mesh.faces(f, 2)};
    add(vs, 3, -1, f);
  }
  layout.per_force_elements = 2LL * face_count + static_cast<long long>(mesh.hinges.size()) +
                              static_cast<long long>(mesh.vertex_count) * (has_drag ? 2 : 1) + pinned_vertices;
  return layout;
}

void permute_elements(ForceElementLayout& layout, const std::vector<int>& order) {
  auto apply = [&](auto& v) {
    auto copy = v;
    for (size_t k = 0; k < order.size(); ++k) v[k] = copy[order[k]];
  };
  apply(layout.vertices);
  apply(layout.count);
  apply(layout.hinge);
  apply(layout.face);
  apply(layout.face_slot);
  apply(layout.owned);
}

template <class Scalar>
void compute_force_elements(const ForceModel& model, const ForceElementLayout& layout, const Positions& x,
                            const Positions& v, double time, double h, int threads, ForceElementStorage<Scalar>& out) {
  const int element_count = layout.size();
  out.blocks.resize(static_cast<size_t>(element_count) * kElementSlots * 9);
  out.rhs.resize(static_cast<size_t>(element_count) * 12);
  const Vec3 wind = model.environment().wind_at(time);
  constexpr bool project_spd = true;

#pragma omp parallel for schedule(static) num_threads(threads)
  for (int e = 0; e < element_count; ++e) {
    const int count = layout.count[e];
    const auto& vs = layout.vertices[e];
    Vec12 force = Vec12::Zero();
    Mat12 stiffness, damping;
    if (layout.hinge[e] >= 0) {
      const HingeBlocks b = model.hinge(layout.hinge[e], x, v, kAllForces, project_spd);
      force = b.force;
      stiffness = b.stiffness;
      damping = b.damping;
    } else {
      stiffness.setZero();
      damping.setZero();
    }
    if (layout.face[e] >= 0) {
      const MembraneBlocks m = model.membrane(layout.face[e], x, v, kAllForces, project_spd);
      const auto& slot = layout.face_slot[e];
      for (int i = 0; i < 3; ++i) {
        force.segment<3>(3 * slot[i]) += m.force.segment<3>(3 * i);
        for (int j = 0; j < 3; ++j) {
          stiffness.block<3, 3>(3 * slot[i], 3 * slot[j]) += m.stiffness.block<3, 3>(3 * i, 3 * j);
          damping.block<3, 3>(3 * slot[i], 3 * slot[j]) += m.damping.block<3, 3>(3 * i, 3 * j);
        }
      }
    }
    for (int a = 0; a < count; ++a)
      if (layout.owned[e] & (1u << a)) {
        const VertexForce p = model.vertex(vs[a], v, wind, kAllForces);
        force.segment<3>(3 * a) += p.force;
        damping.block<3, 3>(3 * a, 3 * a).diagonal().array() += p.damping;
      }
    Vec12 v_local = Vec12::Zero();
    for (int a = 0; a < count; ++a) v_local.segment<3>(3 * a) = row3(v, vs[a]);
    const Vec12 rhs = h * (force - h * (stiffness * v_local));
    double* rhs_out = out.rhs.data() + static_cast<size_t>(e) * 12;
    for (int k = 0; k < 3 * count; ++k) rhs_out[k] = rhs[k];
    Scalar* blocks = out.blocks.data() + static_cast<size_t>(e) * kElementSlots * 9;
    for (int a = 0; a < count; ++a)
      for (int b = a; b < count; ++b) {
        Scalar* dst = blocks + 9 * element_slot(a, b);
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j)
            dst[3 * i + j] = static_cast<Scalar>(h * h * stiffness(3 * a + i, 3 * b + j) +
                                                 h * damping(3 * a + i, 3 * b + j));
      }
  }
}

template void compute_force_elements<float>(const ForceModel&, const ForceElementLayout&, const Positions&,
                                            const Positions&, double, double, int, ForceElementStorage<float>&);
template void compute_force_elements<double>(const ForceModel&, const ForceElementLayout&, const Positions&,
                                             const Positions&, double, double, int, ForceElementStorage<double>&);

}  // namespace weft
