// Common value types for the weft solver. Positions are N x 3 row-major so that a
// numpy (N, 3) float64 array maps onto them without a copy.
#pragma once

#include <Eigen/Dense>
#include <array>
#include <cstdint>
#include <cstring>
#include <vector>

namespace weft {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Mat2 = Eigen::Matrix2d;
using Mat3 = Eigen::Matrix3d;
using Positions = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using Faces = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;
using VectorX = Eigen::VectorXd;

// Flattened 3N vectors view (x0,y0,z0,x1,...) of a Positions block.
inline Eigen::Map<VectorX> flat(Positions& p) { return {p.data(), p.size()}; }
inline Eigen::Map<const VectorX> flat(const Positions& p) { return {p.data(), p.size()}; }

inline Vec3 row3(const Positions& p, int i) { return p.row(i).transpose(); }
// The same rows with the same bits (a body that did not move between two calls).
inline bool same_bits(const Positions& a, const Positions& b) {
  return a.rows() == b.rows() && std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<size_t>(a.size())) == 0;
}

}  // namespace weft
