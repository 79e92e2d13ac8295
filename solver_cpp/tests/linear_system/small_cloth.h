// Test fixture shared by the linear-system tests: a small cloth sheet with its force model.
#pragma once

#include <array>
#include <memory>
#include <random>
#include <vector>

#include "weft/forces/forces.h"
#include "weft/mesh/mesh.h"

namespace weft_test {
using namespace weft;

// A small cloth: nx x ny grid in the xz plane, 1 cm spacing, with its force model.
struct SmallCloth {
  ClothMesh mesh;
  std::unique_ptr<ForceModel> model;
  Positions x, v;
  // stretch_scale multiplies the stretch and shear stiffness (a stiffer, harder system); bend is
  // every hinge's bending stiffness (N m).
  SmallCloth(int nx, int ny, double stretch_scale = 1.0, double bend = 1e-4) {
    const int n = nx * ny;
    Positions rest(n, 3);
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) rest.row(j * nx + i) << 0.01 * i, 0.0, 0.01 * j;
    std::vector<std::array<int, 3>> tris;
    for (int j = 0; j + 1 < ny; ++j)
      for (int i = 0; i + 1 < nx; ++i) {
        const int a = j * nx + i, b = a + 1, c = a + nx, d = c + 1;
        tris.push_back({a, c, b});
        tris.push_back({b, c, d});
      }
    Faces faces(tris.size(), 3);
    FaceUVs uv(tris.size(), 6);
    for (size_t f = 0; f < tris.size(); ++f)
      for (int c = 0; c < 3; ++c) {
        faces(f, c) = tris[f][c];
        uv(f, 2 * c) = rest(tris[f][c], 0);
        uv(f, 2 * c + 1) = rest(tris[f][c], 2);
      }
    mesh = build_cloth_mesh(n, faces, uv, Positions());
    ClothMaterials m;
    const size_t fc = tris.size();
    m.face_stretch_warp.assign(fc, 500.0 * stretch_scale);
    m.face_stretch_weft.assign(fc, 300.0 * stretch_scale);
    m.face_shear.assign(fc, 50.0 * stretch_scale);
    m.face_damping.assign(fc, 0.01);
    m.hinge_bend.assign(mesh.hinges.size(), bend);
    m.vertex_mass.assign(n, 2e-5);
    Environment env;
    env.air_drag = 0.3;
    model = std::make_unique<ForceModel>(mesh, m, env);
    std::mt19937 rng(23);
    std::normal_distribution<double> g(0.0, 1.0);
    x = rest;
    v = Positions::Zero(n, 3);
    for (int i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) {
        x(i, c) += 0.002 * g(rng);
        v(i, c) = 0.1 * g(rng);
      }
  }
};

}  // namespace weft_test
