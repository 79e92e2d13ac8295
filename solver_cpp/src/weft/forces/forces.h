// Cloth force model: Baraff-Witkin stretch and shear on the rest (u,v) frame with separate
// warp/weft stiffness, dihedral-angle bending across interior edges, stiffness-proportional
// damping along each condition's gradient, gravity and linear air drag with wind.
//
// Energies (per triangle of rest area A, deformation gradient columns w_u, w_v):
//   E_stretch = A (k_warp/2 (|w_u|-1)^2 + k_weft/2 (|w_v|-1)^2)          [k in N/m]
//     biphasic: + A (ratio-1) k/2 (s - knee)^2 for a strain s = |w|-1 past the knee
//   E_shear   = A  k_shear/2 (w_u . w_v)^2                                [N/m]
//   E_bend    = k_bend w_e/2 (theta - theta_rest)^2, w_e = 3|e|^2/(A0+A1) [k_bend in N m]
// Damping force of a condition C with stiffness k: -beta k A grad(C) grad(C)^T v (beta in s).
// Drag: -c a_i (v_i - wind(t)) with c in kg/(m^2 s) and a_i the vertex's lumped area.
//
// Every element writes its force and Jacobian blocks to its own slot in ElementBuffers, so
// elements run in parallel without locks. "Stiffness" below means the Hessian of the energy
// (= -dF/dx); "damping" means -dF/dv. With project_spd the indefinite parts are dropped
// (compressed-stretch curvature, shear cross term, bending angle curvature) so that the
// implicit system stays symmetric positive definite.
#pragma once

#include <limits>

#include "weft/mesh/mesh.h"

namespace weft {

enum ForceTerm : unsigned {
  kStretch = 1u << 0,
  kShear = 1u << 1,
  kBend = 1u << 2,
  kDamping = 1u << 3,
  kGravity = 1u << 4,
  kDrag = 1u << 5,
  kAllForces = (1u << 6) - 1,
};

struct ClothMaterials {  // structure of arrays
  std::vector<double> face_stretch_warp, face_stretch_weft, face_shear, face_damping;
  // Biphasic stretch (both directions): past the strain face_stretch_knee the stretch stiffness
  // is face_stretch_ratio times higher (both empty: linear everywhere).
  std::vector<double> face_stretch_knee, face_stretch_ratio;
  std::vector<double> hinge_bend;
  std::vector<double> vertex_mass;
};

struct Environment {
  Vec3 gravity = Vec3(0.0, -9.81, 0.0);
  double air_drag = 0.0;
  Vec3 wind_velocity = Vec3::Zero();
  double gust_amplitude = 0.0;
  double gust_frequency = 0.0;
  Vec3 wind_at(double time) const;
};

using Vec9 = Eigen::Matrix<double, 9, 1>;
using Mat9 = Eigen::Matrix<double, 9, 9>;
using Vec12 = Eigen::Matrix<double, 12, 1>;
using Mat12 = Eigen::Matrix<double, 12, 12>;

struct ElementBuffers {
  std::vector<Vec9> membrane_force;
  std::vector<Mat9> membrane_stiffness;
  std::vector<Mat9> membrane_damping;
  std::vector<Vec12> hinge_force;
  std::vector<Mat12> hinge_stiffness;
  std::vector<Mat12> hinge_damping;
  std::vector<Vec3> vertex_force;      // gravity + drag
  std::vector<double> vertex_damping;  // drag: -dF/dv = vertex_damping * I
  double elastic_energy = 0.0;
};

// A stretch direction's response: linear up to the strain `knee`, `ratio` times stiffer beyond.
struct StretchCurve {
  double knee = std::numeric_limits<double>::infinity();
  double ratio = 1.0;
};

// Single-element kernels, exposed for unit tests.
struct MembraneResult {
  double energy = 0.0;
  Vec9 gradient = Vec9::Zero();
  Mat9 hessian = Mat9::Zero();
  Mat9 gauss_newton = Mat9::Zero();
};
MembraneResult membrane_element(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Mat2& dm_inverse,
                                double area, double k_warp, double k_weft, double k_shear, bool project_spd,
                                const StretchCurve& curve = {});

struct HingeResult {
  double energy = 0.0;
  Vec12 gradient = Vec12::Zero();
  Mat12 hessian = Mat12::Zero();
  Mat12 gauss_newton = Mat12::Zero();
};
HingeResult hinge_element(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec3& x3, double rest_angle,
                          double weight, double k_bend, bool project_spd);

// One force element's contribution: force, stiffness (-dF/dx) and damping (-dF/dv) blocks.
struct MembraneBlocks {
  double energy;
  Vec9 force;
  Mat9 stiffness, damping;
};
struct HingeBlocks {
  double energy;
  Vec12 force;
  Mat12 stiffness, damping;
};
struct VertexForce {  // gravity + drag; -dF/dv = damping * I
  Vec3 force;
  double damping;
};

// The same forces and SPD-projected Jacobians as membrane()/hinge() with every term, in their
// factored form, for the fast assembly (force_elements.cpp), which never forms the 9x9 / 12x12
// matrices. A hinge's Jacobians have rank one:
//   force = -bend_force g - damping g (g . v),  stiffness = bend g g^T,  damping = damping g g^T
// (g = d theta / dx). A membrane's blocks, for its corners i, j:
//   stiffness_ij = a_u[i] a_u[j] stretch_u + a_v[i] a_v[j] stretch_v + shear sg_i sg_j^T
//   damping_ij   = a_u[i] a_u[j] damp_u    + a_v[i] a_v[j] damp_v    + shear_damping sg_i sg_j^T
//   force_i      = -gradient_i - sum_j damping_ij v_j
// (a_u, a_v: dw_u/dx_i, dw_v/dx_i; sg_i = d(w_u . w_v)/dx_i; area included in every term).
struct HingeLinearization {
  bool active = false;  // false: no force and no Jacobian (zero bending stiffness)
  Vec12 g = Vec12::Zero();
  double bend_force = 0.0, bend = 0.0, damping = 0.0;
};
struct MembraneLinearization {
  double a_u[3] = {0.0, 0.0, 0.0}, a_v[3] = {0.0, 0.0, 0.0};
  Vec3 gradient[3];
  Vec3 shear_gradient[3];
  Mat3 stretch_u = Mat3::Zero(), stretch_v = Mat3::Zero(), damp_u = Mat3::Zero(), damp_v = Mat3::Zero();
  double shear = 0.0, shear_damping = 0.0;
};

class ForceModel {
 public:
  ForceModel(const ClothMesh& mesh, ClothMaterials materials, Environment environment);

  // Fills buffers for state (x, v) at time t. terms selects what is included.
  void compute(const Positions& x, const Positions& v, double time, unsigned terms, bool project_spd,
               int threads, ElementBuffers& out) const;

  // Single elements (what compute() runs per face, hinge and vertex); also used by the fast
  // linear system's aggregated force elements. wind = environment().wind_at(time).
  MembraneBlocks membrane(int face, const Positions& x, const Positions& v, unsigned terms, bool project_spd) const;
  HingeBlocks hinge(int hinge, const Positions& x, const Positions& v, unsigned terms, bool project_spd) const;
  VertexForce vertex(int vertex, const Positions& v, const Vec3& wind, unsigned terms) const;
  // Every term, SPD-projected, factored (see HingeLinearization / MembraneLinearization).
  MembraneLinearization membrane_linearization(int face, const Positions& x) const;
  HingeLinearization hinge_linearization(int hinge, const Positions& x) const;

  // Fixed-order sums on `threads` threads (ordered_sum.h): the same bits for any count.
  double elastic_energy(const Positions& x, unsigned terms, int threads = 1) const;
  double gravity_energy(const Positions& x, int threads = 1) const;

  const ClothMesh& mesh() const { return mesh_; }
  const ClothMaterials& materials() const { return materials_; }
  const Environment& environment() const { return environment_; }

 private:
  StretchCurve curve(int f) const {
    return materials_.face_stretch_knee.empty() ? StretchCurve{}
                                                : StretchCurve{materials_.face_stretch_knee[f], materials_.face_stretch_ratio[f]};
  }
  const ClothMesh& mesh_;
  ClothMaterials materials_;
  Environment environment_;
  std::vector<double> hinge_damping_;  // mean damping time of the two faces
};

}  // namespace weft
