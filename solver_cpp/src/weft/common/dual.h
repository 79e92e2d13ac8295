// Forward-mode dual numbers with N derivative directions. Used to differentiate a
// closed-form gradient once more (exact Hessians of the bending angle) without hand-deriving
// a 12x12 expression. Only the operations the force kernels need are provided.
#pragma once

#include <Eigen/Core>
#include <cmath>

namespace weft {

template <int N>
struct Dual {
  double v = 0.0;
  Eigen::Matrix<double, N, 1> d = Eigen::Matrix<double, N, 1>::Zero();

  Dual() = default;
  Dual(double value) : v(value) {}  // NOLINT: constants promote implicitly
  static Dual variable(double value, int index) {
    Dual r(value);
    r.d[index] = 1.0;
    return r;
  }
};

template <int N> Dual<N> operator+(const Dual<N>& a, const Dual<N>& b) { Dual<N> r; r.v = a.v + b.v; r.d = a.d + b.d; return r; }
template <int N> Dual<N> operator-(const Dual<N>& a, const Dual<N>& b) { Dual<N> r; r.v = a.v - b.v; r.d = a.d - b.d; return r; }
template <int N> Dual<N> operator-(const Dual<N>& a) { Dual<N> r; r.v = -a.v; r.d = -a.d; return r; }
template <int N> Dual<N> operator*(const Dual<N>& a, const Dual<N>& b) { Dual<N> r; r.v = a.v * b.v; r.d = a.d * b.v + b.d * a.v; return r; }
template <int N> Dual<N> operator/(const Dual<N>& a, const Dual<N>& b) {
  Dual<N> r;
  r.v = a.v / b.v;
  r.d = (a.d - r.v * b.d) / b.v;
  return r;
}
template <int N> Dual<N> sqrt(const Dual<N>& a) { Dual<N> r; r.v = std::sqrt(a.v); r.d = a.d / (2.0 * r.v); return r; }

inline double value_of(double x) { return x; }
template <int N> double value_of(const Dual<N>& x) { return x.v; }

// Minimal 3-vector over any scalar (double or Dual), enough for cross/dot products.
template <class T>
struct V3 {
  T x, y, z;
  V3 operator+(const V3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  V3 operator-(const V3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  V3 operator*(const T& s) const { return {x * s, y * s, z * s}; }
};
template <class T> T dot(const V3<T>& a, const V3<T>& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
template <class T> V3<T> cross(const V3<T>& a, const V3<T>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}

}  // namespace weft
