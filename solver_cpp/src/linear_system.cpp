#include "linear_system.h"

namespace weft {

namespace {
template <int K, class Visitor>
void for_each_block(const int* vertices, const Eigen::Matrix<double, 3 * K, 3 * K>& m, Visitor&& visit) {
  for (int a = 0; a < K; ++a)
    for (int b = 0; b < K; ++b) visit(vertices[a], vertices[b], m.template block<3, 3>(3 * a, 3 * b));
}

void add_block(SparseMatrix& m, int row_vertex, int col_vertex, const Mat3& block) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m.coeffRef(3 * row_vertex + r, 3 * col_vertex + c) += block(r, c);
}

SparseMatrix make_pattern(const ClothMesh& mesh) {
  std::vector<Eigen::Triplet<double>> entries;
  auto add_pairs = [&](const int* v, int k) {
    for (int a = 0; a < k; ++a)
      for (int b = 0; b < k; ++b)
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) entries.emplace_back(3 * v[a] + r, 3 * v[b] + c, 0.0);
  };
  for (int f = 0; f < mesh.faces.rows(); ++f) {
    const int v[3] = {mesh.faces(f, 0), mesh.faces(f, 1), mesh.faces(f, 2)};
    add_pairs(v, 3);
  }
  for (const Hinge& h : mesh.hinges) add_pairs(h.data(), 4);
  for (int i = 0; i < mesh.vertex_count; ++i) add_pairs(&i, 1);
  SparseMatrix m(3 * mesh.vertex_count, 3 * mesh.vertex_count);
  m.setFromTriplets(entries.begin(), entries.end());
  m.makeCompressed();
  return m;
}
}  // namespace

ReferenceAssembler::ReferenceAssembler(const ClothMesh& mesh) : mesh_(mesh), matrix_(make_pattern(mesh)) {}

void ReferenceAssembler::assemble(const ElementBuffers& e, const std::vector<double>& vertex_mass, const Positions& v,
                                  double h) {
  const int n = mesh_.vertex_count;
  std::fill(matrix_.valuePtr(), matrix_.valuePtr() + matrix_.nonZeros(), 0.0);
  rhs_.setZero(3 * n);
  diagonal_blocks_.assign(n, Mat3::Zero());
  const auto vflat = flat(v);

  auto scatter = [&](const int* vertices, auto k_const, const auto& force, const auto& stiffness,
                     const auto& damping) {
    constexpr int K = decltype(k_const)::value;
    Eigen::Matrix<double, 3 * K, 1> v_local;
    for (int a = 0; a < K; ++a) v_local.template segment<3>(3 * a) = vflat.segment<3>(3 * vertices[a]);
    const Eigen::Matrix<double, 3 * K, 1> local_rhs = h * (force - h * (stiffness * v_local));
    const Eigen::Matrix<double, 3 * K, 3 * K> local_matrix = h * h * stiffness + h * damping;
    for (int a = 0; a < K; ++a) rhs_.segment<3>(3 * vertices[a]) += local_rhs.template segment<3>(3 * a);
    for_each_block<K>(vertices, local_matrix, [&](int r, int c, const auto& block) {
      add_block(matrix_, r, c, block);
      if (r == c) diagonal_blocks_[r] += block;
    });
  };

  for (int f = 0; f < mesh_.faces.rows(); ++f) {
    const int vertices[3] = {mesh_.faces(f, 0), mesh_.faces(f, 1), mesh_.faces(f, 2)};
    scatter(vertices, std::integral_constant<int, 3>{}, e.membrane_force[f], e.membrane_stiffness[f],
            e.membrane_damping[f]);
  }
  for (size_t k = 0; k < mesh_.hinges.size(); ++k)
    scatter(mesh_.hinges[k].data(), std::integral_constant<int, 4>{}, e.hinge_force[k], e.hinge_stiffness[k],
            e.hinge_damping[k]);
  for (int i = 0; i < n; ++i) {
    const Mat3 block = (vertex_mass[i] + h * e.vertex_damping[i]) * Mat3::Identity();
    add_block(matrix_, i, i, block);
    diagonal_blocks_[i] += block;
    rhs_.segment<3>(3 * i) += h * e.vertex_force[i];
  }
}

GlobalJacobians assemble_jacobians(const ClothMesh& mesh, const ElementBuffers& e) {
  const int n = mesh.vertex_count;
  GlobalJacobians g;
  g.force.setZero(3 * n);
  std::vector<Eigen::Triplet<double>> dx, dv;
  auto scatter = [&](const int* vertices, int k, const auto& force, const auto& stiffness, const auto& damping) {
    for (int a = 0; a < k; ++a) {
      g.force.segment<3>(3 * vertices[a]) += force.template segment<3>(3 * a);
      for (int b = 0; b < k; ++b)
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) {
            dx.emplace_back(3 * vertices[a] + r, 3 * vertices[b] + c, -stiffness(3 * a + r, 3 * b + c));
            dv.emplace_back(3 * vertices[a] + r, 3 * vertices[b] + c, -damping(3 * a + r, 3 * b + c));
          }
    }
  };
  for (int f = 0; f < mesh.faces.rows(); ++f) {
    const int vertices[3] = {mesh.faces(f, 0), mesh.faces(f, 1), mesh.faces(f, 2)};
    scatter(vertices, 3, e.membrane_force[f], e.membrane_stiffness[f], e.membrane_damping[f]);
  }
  for (size_t k = 0; k < mesh.hinges.size(); ++k)
    scatter(mesh.hinges[k].data(), 4, e.hinge_force[k], e.hinge_stiffness[k], e.hinge_damping[k]);
  for (int i = 0; i < n; ++i) {
    g.force.segment<3>(3 * i) += e.vertex_force[i];
    for (int r = 0; r < 3; ++r) dv.emplace_back(3 * i + r, 3 * i + r, -e.vertex_damping[i]);
  }
  g.force_dx.resize(3 * n, 3 * n);
  g.force_dv.resize(3 * n, 3 * n);
  g.force_dx.setFromTriplets(dx.begin(), dx.end());
  g.force_dv.setFromTriplets(dv.begin(), dv.end());
  return g;
}

}  // namespace weft
