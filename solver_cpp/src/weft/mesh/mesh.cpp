#include "weft/mesh/mesh.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

namespace weft {

double hinge_angle(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec3& x3) {
  const Vec3 e = x1 - x0;
  const Vec3 n_a = e.cross(x2 - x0);
  const Vec3 n_b = (x3 - x0).cross(e);
  const double sin_part = n_a.cross(n_b).dot(e) / e.norm();
  const double cos_part = n_a.dot(n_b);
  return std::atan2(sin_part, cos_part);
}

ClothMesh build_cloth_mesh(int vertex_count, const Faces& faces, const FaceUVs& face_uv,
                           const Positions& rest_positions) {
  ClothMesh mesh;
  mesh.vertex_count = vertex_count;
  mesh.faces = faces;
  const int face_count = static_cast<int>(faces.rows());
  if (vertex_count <= 0) throw MeshError("mesh has no vertices");
  if (face_count <= 0) throw MeshError("mesh has no faces");
  if (face_uv.rows() != face_count)
    throw MeshError("face_uv has " + std::to_string(face_uv.rows()) + " rows, expected one per face (" +
                    std::to_string(face_count) + ")");
  const bool has_rest_positions = rest_positions.rows() > 0;
  if (has_rest_positions && rest_positions.rows() != vertex_count)
    throw MeshError("rest_positions has " + std::to_string(rest_positions.rows()) + " rows, expected " +
                    std::to_string(vertex_count));

  mesh.rest_dm_inverse.resize(face_count);
  mesh.rest_area.resize(face_count);
  mesh.rest_edge_length.resize(face_count);
  mesh.vertex_rest_area.assign(vertex_count, 0.0);
  for (int f = 0; f < face_count; ++f) {
    for (int c = 0; c < 3; ++c) {
      const int v = faces(f, c);
      if (v < 0 || v >= vertex_count)
        throw MeshError("face " + std::to_string(f) + " references vertex " + std::to_string(v) +
                        " but the mesh has " + std::to_string(vertex_count) + " vertices");
    }
    const Vec2 uv0(face_uv(f, 0), face_uv(f, 1));
    const Vec2 uv1(face_uv(f, 2), face_uv(f, 3));
    const Vec2 uv2(face_uv(f, 4), face_uv(f, 5));
    Mat2 dm;
    dm.col(0) = uv1 - uv0;
    dm.col(1) = uv2 - uv0;
    const double det = dm.determinant();
    const double scale = std::max({dm.col(0).squaredNorm(), dm.col(1).squaredNorm(), 1e-300});
    if (!(std::abs(det) > 1e-12 * scale))
      throw MeshError("face " + std::to_string(f) + " has zero rest area");
    mesh.rest_dm_inverse[f] = dm.inverse();
    mesh.rest_area[f] = 0.5 * std::abs(det);
    mesh.rest_edge_length[f] = {dm.col(0).norm(), (dm.col(1) - dm.col(0)).norm(), dm.col(1).norm()};
    for (int c = 0; c < 3; ++c) mesh.vertex_rest_area[faces(f, c)] += mesh.rest_area[f] / 3.0;
  }

  // Hinges: key each undirected edge, remember the faces and the opposite corners.
  std::map<std::pair<int, int>, std::vector<std::pair<int, int>>> edge_faces;  // edge -> (face, corner)
  for (int f = 0; f < face_count; ++f) {
    for (int c = 0; c < 3; ++c) {
      const int a = faces(f, (c + 1) % 3), b = faces(f, (c + 2) % 3);
      edge_faces[{std::min(a, b), std::max(a, b)}].push_back({f, c});
    }
  }
  for (const auto& [edge, incident] : edge_faces) {
    if (incident.size() > 2) {
      ++mesh.nonmanifold_edge_count;
      continue;
    }
    if (incident.size() != 2) continue;
    const auto [f0, c0] = incident[0];
    const auto [f1, c1] = incident[1];
    // Orient the hinge along the first face: edge (v0, v1) as it runs in f0.
    const int v0 = faces(f0, (c0 + 1) % 3), v1 = faces(f0, (c0 + 2) % 3);
    const int v2 = faces(f0, c0), v3 = faces(f1, c1);
    if (v2 == v3) continue;  // duplicated triangle: nothing to bend
    mesh.hinges.push_back({v0, v1, v2, v3});
    mesh.hinge_faces.push_back({f0, f1});
    // Rest edge length from the first face's rest (u,v) corners; rest angle from the 3D rest
    // positions where all four are given (non-finite rows mark flat rest shapes).
    const int ca = (c0 + 1) % 3, cb = (c0 + 2) % 3;
    const Vec2 d(face_uv(f0, 2 * cb) - face_uv(f0, 2 * ca), face_uv(f0, 2 * cb + 1) - face_uv(f0, 2 * ca + 1));
    const double rest_edge_length_sq = d.squaredNorm();
    double rest_angle = 0.0;
    if (has_rest_positions) {
      const Vec3 x0 = row3(rest_positions, v0), x1 = row3(rest_positions, v1);
      const Vec3 x2 = row3(rest_positions, v2), x3 = row3(rest_positions, v3);
      if (x0.allFinite() && x1.allFinite() && x2.allFinite() && x3.allFinite())
        rest_angle = hinge_angle(x0, x1, x2, x3);
    }
    mesh.hinge_rest_angle.push_back(rest_angle);
    mesh.hinge_weight.push_back(3.0 * rest_edge_length_sq / (mesh.rest_area[f0] + mesh.rest_area[f1]));
  }
  return mesh;
}

double max_edge_strain(const ClothMesh& mesh, const Positions& x, int threads) {
  // A maximum does not depend on the order it is taken in: the same for any thread count.
  const auto& rest = mesh.rest_edge_length;
  const auto face_count = static_cast<int>(mesh.faces.rows());
  double strain = 0.0;
#pragma omp parallel for schedule(static) reduction(max : strain) num_threads(threads) if (threads > 1)
  for (int f = 0; f < face_count; ++f)
    for (int c = 0; c < 3; ++c) {
      const double length = (row3(x, mesh.faces(f, (c + 1) % 3)) - row3(x, mesh.faces(f, c))).norm();
      if (rest[f][c] > 0.0) strain = std::max(strain, length / rest[f][c]);
    }
  return strain;
}

bool edge_overstretched(const ClothMesh& mesh, const Positions& start, const Positions& end, double start_bound,
                        double end_bound) {
  const auto& rest = mesh.rest_edge_length;
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      if (!(rest[f][c] > 0.0)) continue;
      const int a = mesh.faces(f, c), b = mesh.faces(f, (c + 1) % 3);
      if ((row3(end, b) - row3(end, a)).norm() > end_bound * rest[f][c] &&
          (row3(start, b) - row3(start, a)).norm() <= start_bound * rest[f][c])
        return true;
    }
  return false;
}

}  // namespace weft
