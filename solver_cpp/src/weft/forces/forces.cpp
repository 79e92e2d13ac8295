#include "weft/forces/forces.h"

#include "weft/common/ordered_sum.h"

#include <cmath>

#include "weft/common/dual.h"

namespace weft {

namespace {
constexpr double kPi = 3.14159265358979323846;

double wrap_angle(double a) {
  while (a > kPi) a -= 2.0 * kPi;
  while (a <= -kPi) a += 2.0 * kPi;
  return a;
}

// Gradient of the signed dihedral angle (see hinge_angle) with respect to the hinge's four
// vertices (Bridson, Marino & Fedkiw 2003, in our sign convention). Templated so that running it
// on dual numbers yields the exact Hessian.
template <class T>
void dihedral_gradient(const V3<T> x[4], V3<T> g[4]) {
  const V3<T> e = x[1] - x[0];
  const V3<T> n_a = cross(e, x[2] - x[0]);
  const V3<T> n_b = cross(x[3] - x[0], e);
  const T e_len_sq = dot(e, e);
  using std::sqrt;
  const T e_len = sqrt(e_len_sq);
  g[2] = n_a * (-e_len / dot(n_a, n_a));
  g[3] = n_b * (-e_len / dot(n_b, n_b));
  const T s_a = dot(x[2] - x[0], e) / e_len_sq;
  const T s_b = dot(x[3] - x[0], e) / e_len_sq;
  const T one(1.0);
  g[0] = (g[2] * (one - s_a) + g[3] * (one - s_b)) * T(-1.0);
  g[1] = (g[2] * s_a + g[3] * s_b) * T(-1.0);
}

// One stretch direction's energy density psi(s) of the strain s = |w| - 1 and its first two
// derivatives: k s^2 / 2, plus (ratio - 1) k (s - knee)^2 / 2 beyond the knee (biphasic: soft to
// the knee, ratio times stiffer past it; C1, so forces are continuous).
struct StretchResponse {
  double energy, slope, curvature;
};
StretchResponse stretch_response(double strain, double k, const StretchCurve& curve) {
  StretchResponse r{0.5 * k * strain * strain, k * strain, k};
  if (strain > curve.knee) {
    const double extra = (curve.ratio - 1.0) * k, beyond = strain - curve.knee;
    r.energy += 0.5 * extra * beyond * beyond;
    r.slope += extra * beyond;
    r.curvature += extra;
  }
  return r;
}

// Hessian block of psi(|w|) in w: psi'' w_hat w_hat^T + psi'/|w| (I - w_hat w_hat^T). The
// second part is indefinite under compression (psi' < 0); dropping it there keeps the block
// positive semi-definite.
Mat3 stretch_block(const Vec3& w_hat, double length, const StretchResponse& psi, bool project_spd) {
  const Mat3 outer = w_hat * w_hat.transpose();
  double transverse = psi.slope / length;
  if (project_spd && transverse < 0.0) transverse = 0.0;
  return psi.curvature * outer + transverse * (Mat3::Identity() - outer);
}
// Columns w_u, w_v of the deformation gradient on the rest (u,v) frame.
void deformation_columns(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Mat2& dm_inverse, Vec3& w_u,
                         Vec3& w_v) {
  const Vec3 d1 = x1 - x0, d2 = x2 - x0;
  w_u = d1 * dm_inverse(0, 0) + d2 * dm_inverse(1, 0);
  w_v = d1 * dm_inverse(0, 1) + d2 * dm_inverse(1, 1);
}

double membrane_energy_density(double len_u, double len_v, double shear, double k_warp, double k_weft,
                               double k_shear, const StretchCurve& curve) {
  return stretch_response(len_u - 1.0, k_warp, curve).energy + stretch_response(len_v - 1.0, k_weft, curve).energy +
         0.5 * k_shear * shear * shear;
}
}  // namespace

Vec3 Environment::wind_at(double time) const {
  if (gust_amplitude == 0.0) return wind_velocity;
  return wind_velocity * (1.0 + gust_amplitude * std::sin(2.0 * kPi * gust_frequency * time));
}

MembraneResult membrane_element(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Mat2& dm_inverse,
                                double area, double k_warp, double k_weft, double k_shear, bool project_spd,
                                const StretchCurve& curve) {
  MembraneResult r;
  Vec3 w_u, w_v;
  deformation_columns(x0, x1, x2, dm_inverse, w_u, w_v);
  // dw_u/dx_i = a_u[i] I, dw_v/dx_i = a_v[i] I
  const double a_u[3] = {-(dm_inverse(0, 0) + dm_inverse(1, 0)), dm_inverse(0, 0), dm_inverse(1, 0)};
  const double a_v[3] = {-(dm_inverse(0, 1) + dm_inverse(1, 1)), dm_inverse(0, 1), dm_inverse(1, 1)};
  const double len_u = w_u.norm(), len_v = w_v.norm();
  const double shear = w_u.dot(w_v);
  const Vec3 u_hat = len_u > 0.0 ? Vec3(w_u / len_u) : Vec3::Zero();
  const Vec3 v_hat = len_v > 0.0 ? Vec3(w_v / len_v) : Vec3::Zero();

  const StretchResponse psi_u = stretch_response(len_u - 1.0, k_warp, curve);
  const StretchResponse psi_v = stretch_response(len_v - 1.0, k_weft, curve);
  r.energy = (psi_u.energy + psi_v.energy + 0.5 * k_shear * shear * shear) * area;

  const Vec3 grad_wu = area * (psi_u.slope * u_hat + k_shear * shear * w_v);
  const Vec3 grad_wv = area * (psi_v.slope * v_hat + k_shear * shear * w_u);
  const Mat3 h_u = len_u > 0.0 ? stretch_block(u_hat, len_u, psi_u, project_spd) : Mat3::Zero();
  const Mat3 h_v = len_v > 0.0 ? stretch_block(v_hat, len_v, psi_v, project_spd) : Mat3::Zero();
  const Mat3 gn_u = psi_u.curvature * u_hat * u_hat.transpose();
  const Mat3 gn_v = psi_v.curvature * v_hat * v_hat.transpose();
  Vec3 shear_grad[3];
  for (int i = 0; i < 3; ++i) shear_grad[i] = w_v * a_u[i] + w_u * a_v[i];

  for (int i = 0; i < 3; ++i) {
    r.gradient.segment<3>(3 * i) = a_u[i] * grad_wu + a_v[i] * grad_wv;
    for (int j = 0; j < 3; ++j) {
      const Mat3 shear_outer = k_shear * shear_grad[i] * shear_grad[j].transpose();
      Mat3 block = a_u[i] * a_u[j] * h_u + a_v[i] * a_v[j] * h_v + shear_outer;
      if (!project_spd) block += k_shear * shear * (a_u[i] * a_v[j] + a_v[i] * a_u[j]) * Mat3::Identity();
      r.hessian.block<3, 3>(3 * i, 3 * j) = area * block;
      r.gauss_newton.block<3, 3>(3 * i, 3 * j) =
          area * (a_u[i] * a_u[j] * gn_u + a_v[i] * a_v[j] * gn_v + shear_outer);
    }
  }
  return r;
}

HingeResult hinge_element(const Vec3& x0, const Vec3& x1, const Vec3& x2, const Vec3& x3, double rest_angle,
                          double weight, double k_bend, bool project_spd) {
  HingeResult r;
  const double theta = hinge_angle(x0, x1, x2, x3);
  const double delta = wrap_angle(theta - rest_angle);
  const double k = k_bend * weight;
  r.energy = 0.5 * k * delta * delta;

  const Vec3* xs[4] = {&x0, &x1, &x2, &x3};
  V3<double> xd[4], gd[4];
  for (int i = 0; i < 4; ++i) xd[i] = {(*xs[i])[0], (*xs[i])[1], (*xs[i])[2]};
  dihedral_gradient(xd, gd);
  Vec12 grad_theta;
  for (int i = 0; i < 4; ++i) grad_theta.segment<3>(3 * i) = Vec3(gd[i].x, gd[i].y, gd[i].z);

  r.gradient = k * delta * grad_theta;
  r.gauss_newton = k * grad_theta * grad_theta.transpose();
  r.hessian = r.gauss_newton;
  if (!project_spd && delta != 0.0) {
    using D = Dual<12>;
    V3<D> xv[4], gv[4];
    for (int i = 0; i < 4; ++i)
      xv[i] = {D::variable(xd[i].x, 3 * i), D::variable(xd[i].y, 3 * i + 1), D::variable(xd[i].z, 3 * i + 2)};
    dihedral_gradient(xv, gv);
    Mat12 theta_hessian;
    for (int i = 0; i < 4; ++i) {
      theta_hessian.row(3 * i) = gv[i].x.d.transpose();
      theta_hessian.row(3 * i + 1) = gv[i].y.d.transpose();
      theta_hessian.row(3 * i + 2) = gv[i].z.d.transpose();
    }
    r.hessian += k * delta * 0.5 * (theta_hessian + theta_hessian.transpose());
  }
  return r;
}

ForceModel::ForceModel(const ClothMesh& mesh, ClothMaterials materials, Environment environment)
    : mesh_(mesh), materials_(std::move(materials)), environment_(environment) {
  const size_t face_count = mesh.faces.rows();
  auto check = [&](const std::vector<double>& a, size_t n, const char* name) {
    if (a.size() != n)
      throw std::invalid_argument(std::string("materials.") + name + " has " + std::to_string(a.size()) +
                                  " entries, expected " + std::to_string(n));
  };
  check(materials_.face_stretch_warp, face_count, "face_stretch_warp");
  check(materials_.face_stretch_weft, face_count, "face_stretch_weft");
  if (!materials_.face_stretch_knee.empty() || !materials_.face_stretch_ratio.empty()) {
    check(materials_.face_stretch_knee, face_count, "face_stretch_knee");
    check(materials_.face_stretch_ratio, face_count, "face_stretch_ratio");
    for (int f = 0; f < face_count; ++f)
      if (!(materials_.face_stretch_knee[f] >= 0.0) || !(materials_.face_stretch_ratio[f] >= 1.0))
        throw std::invalid_argument("stretch knee must be >= 0 and its stiffness ratio >= 1");
  }
  check(materials_.face_shear, face_count, "face_shear");
  check(materials_.face_damping, face_count, "face_damping");
  check(materials_.hinge_bend, mesh.hinges.size(), "hinge_bend");
  check(materials_.vertex_mass, static_cast<size_t>(mesh.vertex_count), "vertex_mass");
  hinge_damping_.resize(mesh.hinges.size());
  for (size_t h = 0; h < mesh.hinges.size(); ++h)
    hinge_damping_[h] = 0.5 * (materials_.face_damping[mesh.hinge_faces[h][0]] +
                               materials_.face_damping[mesh.hinge_faces[h][1]]);
}

MembraneBlocks ForceModel::membrane(int f, const Positions& x, const Positions& v, unsigned terms,
                                    bool project_spd) const {
  const bool stretch = terms & kStretch, shear = terms & kShear, damping = terms & kDamping;
  const auto face = mesh_.faces.row(f);
  const Vec3 x0 = row3(x, face[0]), x1 = row3(x, face[1]), x2 = row3(x, face[2]);
  const double kw = stretch ? materials_.face_stretch_warp[f] : 0.0;
  const double kf = stretch ? materials_.face_stretch_weft[f] : 0.0;
  const double ks = shear ? materials_.face_shear[f] : 0.0;
  const MembraneResult m =
      membrane_element(x0, x1, x2, mesh_.rest_dm_inverse[f], mesh_.rest_area[f], kw, kf, ks, project_spd, curve(f));
  MembraneBlocks out;
  out.energy = m.energy;
  out.force = -m.gradient;
  out.damping.setZero();
  if (damping && materials_.face_damping[f] > 0.0) {
    // Damping acts along every condition's gradient whether or not its elastic force is
    // selected (terms subsets are for verification; the integrator selects all).
    const bool all_elastic = stretch && shear;
    const Mat9& gauss_newton =
        all_elastic ? m.gauss_newton
                    : membrane_element(x0, x1, x2, mesh_.rest_dm_inverse[f], mesh_.rest_area[f],
                                       materials_.face_stretch_warp[f], materials_.face_stretch_weft[f],
                                       materials_.face_shear[f], true, curve(f))
                          .gauss_newton;
    out.damping = materials_.face_damping[f] * gauss_newton;
    Vec9 v_local;
    for (int i = 0; i < 3; ++i) v_local.segment<3>(3 * i) = row3(v, face[i]);
    out.force -= out.damping * v_local;
  }
  out.stiffness = m.hessian;
  return out;
}

HingeBlocks ForceModel::hinge(int h, const Positions& x, const Positions& v, unsigned terms, bool project_spd) const {
  const bool bend = terms & kBend, damping = terms & kDamping;
  const Hinge& hv = mesh_.hinges[h];
  const bool damp_hinge = damping && hinge_damping_[h] > 0.0;
  HingeBlocks out;
  if ((!bend && !damp_hinge) || materials_.hinge_bend[h] == 0.0) {
    out.energy = 0.0;
    out.force.setZero();
    out.stiffness.setZero();
    out.damping.setZero();
    return out;
  }
  HingeResult b = hinge_element(row3(x, hv[0]), row3(x, hv[1]), row3(x, hv[2]), row3(x, hv[3]),
                                mesh_.hinge_rest_angle[h], mesh_.hinge_weight[h], materials_.hinge_bend[h],
                                project_spd || !bend);
  if (!bend) {  // damping only: keep the gradient direction, drop the elastic part
    b.energy = 0.0;
    b.gradient.setZero();
    b.hessian.setZero();
  }
  out.energy = b.energy;
  out.force = -b.gradient;
  out.damping.setZero();
  if (damp_hinge) {
    out.damping = hinge_damping_[h] * b.gauss_newton;
    Vec12 v_local;
    for (int i = 0; i < 4; ++i) v_local.segment<3>(3 * i) = row3(v, hv[i]);
    out.force -= out.damping * v_local;
  }
  out.stiffness = b.hessian;
  return out;
}

MembraneLinearization ForceModel::membrane_linearization(int f, const Positions& x) const {
  MembraneLinearization out;
  const auto face = mesh_.faces.row(f);
  const Mat2& dm_inverse = mesh_.rest_dm_inverse[f];
  const double area = mesh_.rest_area[f];
  Vec3 w_u, w_v;
  deformation_columns(row3(x, face[0]), row3(x, face[1]), row3(x, face[2]), dm_inverse, w_u, w_v);
  const double a_u[3] = {-(dm_inverse(0, 0) + dm_inverse(1, 0)), dm_inverse(0, 0), dm_inverse(1, 0)};
  const double a_v[3] = {-(dm_inverse(0, 1) + dm_inverse(1, 1)), dm_inverse(0, 1), dm_inverse(1, 1)};
  const double len_u = w_u.norm(), len_v = w_v.norm();
  const double shear = w_u.dot(w_v);
  const double k_shear = materials_.face_shear[f];
  const StretchCurve c = curve(f);
  const StretchResponse psi_u = stretch_response(len_u - 1.0, materials_.face_stretch_warp[f], c);
  const StretchResponse psi_v = stretch_response(len_v - 1.0, materials_.face_stretch_weft[f], c);
  const Vec3 u_hat = len_u > 0.0 ? Vec3(w_u / len_u) : Vec3::Zero();
  const Vec3 v_hat = len_v > 0.0 ? Vec3(w_v / len_v) : Vec3::Zero();
  const Vec3 grad_wu = area * (psi_u.slope * u_hat + k_shear * shear * w_v);
  const Vec3 grad_wv = area * (psi_v.slope * v_hat + k_shear * shear * w_u);
  for (int i = 0; i < 3; ++i) {
    out.a_u[i] = a_u[i];
    out.a_v[i] = a_v[i];
    out.gradient[i] = a_u[i] * grad_wu + a_v[i] * grad_wv;
    out.shear_gradient[i] = w_v * a_u[i] + w_u * a_v[i];
  }
  if (len_u > 0.0) out.stretch_u = area * stretch_block(u_hat, len_u, psi_u, true);
  if (len_v > 0.0) out.stretch_v = area * stretch_block(v_hat, len_v, psi_v, true);
  out.shear = area * k_shear;
  const double beta = materials_.face_damping[f];
  if (beta > 0.0) {
    out.damp_u = (beta * area * psi_u.curvature) * (u_hat * u_hat.transpose());
    out.damp_v = (beta * area * psi_v.curvature) * (v_hat * v_hat.transpose());
    out.shear_damping = beta * out.shear;
  }
  return out;
}

HingeLinearization ForceModel::hinge_linearization(int h, const Positions& x) const {
  HingeLinearization out;
  if (materials_.hinge_bend[h] == 0.0) return out;
  const Hinge& hv = mesh_.hinges[h];
  V3<double> xd[4], gd[4];
  for (int i = 0; i < 4; ++i) xd[i] = {x(hv[i], 0), x(hv[i], 1), x(hv[i], 2)};
  const double theta = hinge_angle(row3(x, hv[0]), row3(x, hv[1]), row3(x, hv[2]), row3(x, hv[3]));
  dihedral_gradient(xd, gd);
  for (int i = 0; i < 4; ++i) out.g.segment<3>(3 * i) = Vec3(gd[i].x, gd[i].y, gd[i].z);
  out.active = true;
  out.bend = materials_.hinge_bend[h] * mesh_.hinge_weight[h];
  out.bend_force = out.bend * wrap_angle(theta - mesh_.hinge_rest_angle[h]);
  out.damping = hinge_damping_[h] > 0.0 ? hinge_damping_[h] * out.bend : 0.0;
  return out;
}

VertexForce ForceModel::vertex(int i, const Positions& v, const Vec3& wind, unsigned terms) const {
  const double drag = (terms & kDrag) ? environment_.air_drag : 0.0;
  const double c = drag * mesh_.vertex_rest_area[i];
  VertexForce out;
  out.force.setZero();
  if (terms & kGravity) out.force += materials_.vertex_mass[i] * environment_.gravity;
  if (c > 0.0) out.force -= c * (row3(v, i) - wind);
  out.damping = c;
  return out;
}

void ForceModel::compute(const Positions& x, const Positions& v, double time, unsigned terms, bool project_spd,
                         int threads, ElementBuffers& out) const {
  const int face_count = static_cast<int>(mesh_.faces.rows());
  const int hinge_count = static_cast<int>(mesh_.hinges.size());
  const int vertex_count = mesh_.vertex_count;
  out.membrane_force.resize(face_count);
  out.membrane_stiffness.resize(face_count);
  out.membrane_damping.resize(face_count);
  out.hinge_force.resize(hinge_count);
  out.hinge_stiffness.resize(hinge_count);
  out.hinge_damping.resize(hinge_count);
  out.vertex_force.resize(vertex_count);
  out.vertex_damping.resize(vertex_count);
  // Per-element energies, summed in a fixed order afterwards (bitwise independent of threads).
  std::vector<double> energy(static_cast<size_t>(face_count) + hinge_count);
  const Vec3 wind = environment_.wind_at(time);

#pragma omp parallel num_threads(threads)
  {
#pragma omp for schedule(static)
    for (int f = 0; f < face_count; ++f) {
      MembraneBlocks m = membrane(f, x, v, terms, project_spd);
      energy[f] = m.energy;
      out.membrane_force[f] = m.force;
      out.membrane_stiffness[f] = m.stiffness;
      out.membrane_damping[f] = m.damping;
    }
#pragma omp for schedule(static)
    for (int h = 0; h < hinge_count; ++h) {
      HingeBlocks b = hinge(h, x, v, terms, project_spd);
      energy[face_count + h] = b.energy;
      out.hinge_force[h] = b.force;
      out.hinge_stiffness[h] = b.stiffness;
      out.hinge_damping[h] = b.damping;
    }
#pragma omp for schedule(static)
    for (int i = 0; i < vertex_count; ++i) {
      const VertexForce p = vertex(i, v, wind, terms);
      out.vertex_force[i] = p.force;
      out.vertex_damping[i] = p.damping;
    }
  }
  out.elastic_energy = ordered_sum(energy, threads);
}

double ForceModel::elastic_energy(const Positions& x, unsigned terms, int threads) const {
  // Faces then hinges as one range of terms, summed in fixed chunks (ordered_sum.h): the same
  // bits for any thread count.
  const int face_count = static_cast<int>(mesh_.faces.rows());
  const std::int64_t hinge_count = (terms & kBend) ? static_cast<std::int64_t>(mesh_.hinges.size()) : 0;
  auto term = [&](std::int64_t k) -> double {
    if (k < face_count) {
      const int f = static_cast<int>(k);
      const auto face = mesh_.faces.row(f);
      const double kw = (terms & kStretch) ? materials_.face_stretch_warp[f] : 0.0;
      const double kf = (terms & kStretch) ? materials_.face_stretch_weft[f] : 0.0;
      const double ks = (terms & kShear) ? materials_.face_shear[f] : 0.0;
      Vec3 w_u, w_v;  // energy only: no gradient or Hessian
      deformation_columns(row3(x, face[0]), row3(x, face[1]), row3(x, face[2]), mesh_.rest_dm_inverse[f], w_u, w_v);
      return membrane_energy_density(w_u.norm(), w_v.norm(), w_u.dot(w_v), kw, kf, ks, curve(f)) * mesh_.rest_area[f];
    }
    const auto h = static_cast<size_t>(k - face_count);
    const Hinge& hv = mesh_.hinges[h];
    const double theta = hinge_angle(row3(x, hv[0]), row3(x, hv[1]), row3(x, hv[2]), row3(x, hv[3]));
    const double delta = wrap_angle(theta - mesh_.hinge_rest_angle[h]);
    return 0.5 * materials_.hinge_bend[h] * mesh_.hinge_weight[h] * delta * delta;
  };
  return ordered_sums<1>(face_count + hinge_count, threads, [&](std::int64_t begin, std::int64_t end) {
    double sum = 0.0;
    for (std::int64_t k = begin; k < end; ++k) sum += term(k);
    return std::array<double, 1>{sum};
  })[0];
}

double ForceModel::gravity_energy(const Positions& x, int threads) const {
  return ordered_sums<1>(mesh_.vertex_count, threads, [&](std::int64_t begin, std::int64_t end) {
    double energy = 0.0;
    for (auto i = static_cast<int>(begin); i < end; ++i)
      energy -= materials_.vertex_mass[i] * environment_.gravity.dot(row3(x, i));
    return std::array<double, 1>{energy};
  })[0];
}

}  // namespace weft
