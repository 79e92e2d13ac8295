// Cloth topology and rest-state data: triangles with their rest (u,v) frames, hinges
// (pairs of triangles sharing an interior edge) and lumped per-vertex rest areas.
#pragma once

#include <stdexcept>
#include <string>

#include "weft/common/types.h"

namespace weft {

// A hinge is two triangles sharing the edge (v[0], v[1]); v[2] is the opposite vertex of
// the first triangle (oriented v0, v1, v2) and v[3] that of the second (oriented v1, v0, v3).
using Hinge = std::array<int, 4>;

struct ClothMesh {
  int vertex_count = 0;
  Faces faces;

  // Per triangle (structure of arrays): inverse of the rest (u,v) edge matrix
  // Dm = [uv1 - uv0, uv2 - uv0], and the rest area in m^2.
  std::vector<Mat2> rest_dm_inverse;
  std::vector<double> rest_area;
  // Per triangle, the rest lengths of its edges (v0,v1), (v1,v2), (v2,v0).
  std::vector<std::array<double, 3>> rest_edge_length;

  // Per hinge: vertices, rest dihedral angle (radians), and the discrete-shell weight
  // 3 |e|^2 / (A_0 + A_1) from the rest state.
  std::vector<Hinge> hinges;
  std::vector<std::array<int, 2>> hinge_faces;
  std::vector<double> hinge_rest_angle;
  std::vector<double> hinge_weight;

  // Lumped rest area per vertex: one third of each incident triangle's rest area.
  std::vector<double> vertex_rest_area;

  // Edges that bound more than two triangles get no bending term; counted for reporting.
  int nonmanifold_edge_count = 0;
};

// Thrown for malformed meshes; the message names the offending element.
struct MeshError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

// face_uv: F x 6 row-major (u0 v0 u1 v1 u2 v2 per triangle, metres).
// rest_positions: either empty (flat rest shape, rest dihedral angles zero) or N x 3; rows that
// are not finite mark vertices of flat (uv) rest shapes, whose hinges rest at angle zero.
using FaceUVs = Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>;
ClothMesh build_cloth_mesh(int vertex_count, const Faces& faces, const FaceUVs& face_uv,
                           const Positions& rest_positions);

// Largest ratio of an edge's length in x to its rest length (from the triangles' rest frames),
// over every edge of every triangle: 1 at rest, 1.5 for an edge stretched by half.
double max_edge_strain(const ClothMesh& mesh, const Positions& x, int threads = 1);
// Whether some edge (per face side, as max_edge_strain) is at most `start_bound` times its rest
// length at `start` and more than `end_bound` times it at `end`: stretched that far within one step.
bool edge_overstretched(const ClothMesh& mesh, const Positions& start, const Positions& end, double start_bound,
                        double end_bound);

// Signed dihedral angle of a hinge in the convention used by the bending force.
double hinge_angle(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec3& x3);

}  // namespace weft
