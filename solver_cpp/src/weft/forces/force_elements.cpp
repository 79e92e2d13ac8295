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
  const double h2 = h * h;

  // Per element, from the factored forms (forces.h), never forming 12x12 matrices:
  //   rhs = h (f - h K v) = -h grad E + h f_vertex - B v,   B = h^2 K + h D (the blocks).
#pragma omp parallel for schedule(dynamic, 256) num_threads(threads)
  for (int e = 0; e < element_count; ++e) {
    const int count = layout.count[e];
    const auto& vs = layout.vertices[e];
    Vec3 vel[4], rhs[4];
    for (int a = 0; a < count; ++a) {
      vel[a] = row3(v, vs[a]);
      rhs[a].setZero();
    }
    // Hinge: B = beta g g^T with beta = h^2 k + h c.
    HingeLinearization hinge;
    double hinge_beta = 0.0;
    if (layout.hinge[e] >= 0) {
      hinge = model.hinge_linearization(layout.hinge[e], x);
      if (hinge.active) {
        hinge_beta = h2 * hinge.bend + h * hinge.damping;
        double gv = 0.0;
        for (int a = 0; a < 4; ++a) gv += hinge.g.segment<3>(3 * a).dot(vel[a]);
        const double scale = -h * hinge.bend_force - hinge_beta * gv;
        for (int a = 0; a < 4; ++a) rhs[a] += scale * hinge.g.segment<3>(3 * a);
      }
    }
    // Membrane: B_ij = a_u[i] a_u[j] H_u + a_v[i] a_v[j] H_v + s sg_i sg_j^T.
    MembraneLinearization m;
    Mat3 big_u, big_v;
    double shear_beta = 0.0;
    int corner_of_slot[4] = {-1, -1, -1, -1};
    const bool has_face = layout.face[e] >= 0;
    if (has_face) {
      m = model.membrane_linearization(layout.face[e], x);
      big_u = h2 * m.stretch_u + h * m.damp_u;
      big_v = h2 * m.stretch_v + h * m.damp_v;
      shear_beta = h2 * m.shear + h * m.shear_damping;
      const auto& slot = layout.face_slot[e];
      Vec3 vu = Vec3::Zero(), vv = Vec3::Zero();
      double sv = 0.0;
      for (int i = 0; i < 3; ++i) {
        corner_of_slot[slot[i]] = i;
        vu += m.a_u[i] * vel[slot[i]];
        vv += m.a_v[i] * vel[slot[i]];
        sv += m.shear_gradient[i].dot(vel[slot[i]]);
      }
      const Vec3 bu = big_u * vu, bv = big_v * vv;
      for (int i = 0; i < 3; ++i)
        rhs[slot[i]] -= h * m.gradient[i] + m.a_u[i] * bu + m.a_v[i] * bv + (shear_beta * sv) * m.shear_gradient[i];
    }
    double vertex_damping[4] = {0.0, 0.0, 0.0, 0.0};
    for (int a = 0; a < count; ++a)
      if (layout.owned[e] & (1u << a)) {
        const VertexForce p = model.vertex(vs[a], v, wind, kAllForces);
        rhs[a] += h * p.force;
        vertex_damping[a] = h * p.damping;
      }
    double* rhs_out = out.rhs.data() + static_cast<size_t>(e) * 12;
    for (int a = 0; a < count; ++a)
      for (int k = 0; k < 3; ++k) rhs_out[3 * a + k] = rhs[a][k];
    // The blocks coefficient by coefficient in plain scalars (Eigen's 3x3 temporaries cost store
    // forwarding stalls here), in the same order of operations as the matrix expressions
    //   hinge_beta g_a g_b^T + ((a_u[i] a_u[j] H_u + a_v[i] a_v[j] H_v) + shear_beta sg_i sg_j^T)
    // plus the vertex damping on the diagonal: the same values.
    double hinge_scaled[4][3] = {}, shear_scaled[3][3] = {};
    if (hinge.active)
      for (int a = 0; a < count; ++a)
        for (int r = 0; r < 3; ++r) hinge_scaled[a][r] = hinge_beta * hinge.g[3 * a + r];
    if (has_face)
      for (int i = 0; i < 3; ++i)
        for (int r = 0; r < 3; ++r) shear_scaled[i][r] = shear_beta * m.shear_gradient[i][r];
    // Each block's terms in turn over its nine coefficients (the tests hoisted out of the
    // coefficient loops): every coefficient gets the same operations in the same order.
    Scalar* blocks = out.blocks.data() + static_cast<size_t>(e) * kElementSlots * 9;
    for (int a = 0; a < count; ++a)
      for (int b = a; b < count; ++b) {
        const int i = corner_of_slot[a], j = corner_of_slot[b];
        double value[3][3];
        if (hinge.active) {
          for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) value[r][c] = hinge_scaled[a][r] * hinge.g[3 * b + c];
        } else {
          for (auto& row : value) row[0] = row[1] = row[2] = 0.0;
        }
        if (i >= 0 && j >= 0) {
          const double su = m.a_u[i] * m.a_u[j], sv = m.a_v[i] * m.a_v[j];
          for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c)
              value[r][c] += (su * big_u(r, c) + sv * big_v(r, c)) + shear_scaled[i][r] * m.shear_gradient[j][c];
        }
        if (a == b)
          for (int r = 0; r < 3; ++r) value[r][r] += vertex_damping[a];
        Scalar* dst = blocks + 9 * element_slot(a, b);
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) dst[3 * r + c] = static_cast<Scalar>(value[r][c]);
      }
  }
}

template void compute_force_elements<float>(const ForceModel&, const ForceElementLayout&, const Positions&,
                                            const Positions&, double, double, int, ForceElementStorage<float>&);
template void compute_force_elements<double>(const ForceModel&, const ForceElementLayout&, const Positions&,
                                             const Positions&, double, double, int, ForceElementStorage<double>&);

}  // namespace weft
