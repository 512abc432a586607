// Small fixed-size vector and rotation types for the synthesizer (double precision for motion and
// rigging, float for the per-vertex work). Rotations are 3x3 row-major matrices acting on column
// vectors: rotated = R * v. Angles are radians unless a name says otherwise.
#pragma once
#include <array>
#include <cmath>

namespace dp::synth {

struct Vec3 {
  double x = 0, y = 0, z = 0;
  Vec3() = default;
  constexpr Vec3(double x_, double y_, double z_) : x(x_), y(y_), z(z_) {}
  Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  Vec3 operator*(double s) const { return {x * s, y * s, z * s}; }
  Vec3& operator+=(const Vec3& o) { x += o.x; y += o.y; z += o.z; return *this; }
  double dot(const Vec3& o) const { return x * o.x + y * o.y + z * o.z; }
  Vec3 cross(const Vec3& o) const { return {y * o.z - z * o.y, z * o.x - x * o.z, x * o.y - y * o.x}; }
  double norm() const { return std::sqrt(dot(*this)); }
  Vec3 normalized() const { double n = norm(); return n > 0 ? *this * (1.0 / n) : *this; }
};

struct Vec3f {
  float x = 0, y = 0, z = 0;
};

struct Mat3 {
  std::array<double, 9> m{1, 0, 0, 0, 1, 0, 0, 0, 1};
  static Mat3 identity() { return {}; }
  double operator()(int r, int c) const { return m[r * 3 + c]; }
  double& operator()(int r, int c) { return m[r * 3 + c]; }
  Vec3 operator*(const Vec3& v) const {
    return {m[0] * v.x + m[1] * v.y + m[2] * v.z, m[3] * v.x + m[4] * v.y + m[5] * v.z,
            m[6] * v.x + m[7] * v.y + m[8] * v.z};
  }
  Mat3 operator*(const Mat3& o) const {
    Mat3 r;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        r(i, j) = (*this)(i, 0) * o(0, j) + (*this)(i, 1) * o(1, j) + (*this)(i, 2) * o(2, j);
    return r;
  }
  Mat3 transposed() const {
    Mat3 r;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r(i, j) = (*this)(j, i);
    return r;
  }
};

inline Mat3 rot_x(double a) {
  Mat3 r;
  double c = std::cos(a), s = std::sin(a);
  r.m = {1, 0, 0, 0, c, -s, 0, s, c};
  return r;
}
inline Mat3 rot_y(double a) {
  Mat3 r;
  double c = std::cos(a), s = std::sin(a);
  r.m = {c, 0, s, 0, 1, 0, -s, 0, c};
  return r;
}
inline Mat3 rot_z(double a) {
  Mat3 r;
  double c = std::cos(a), s = std::sin(a);
  r.m = {c, -s, 0, s, c, 0, 0, 0, 1};
  return r;
}
// Rotation about a unit axis by angle a (Rodrigues).
inline Mat3 rot_axis(const Vec3& axis, double a) {
  double c = std::cos(a), s = std::sin(a), t = 1 - c;
  double x = axis.x, y = axis.y, z = axis.z;
  Mat3 r;
  r.m = {t * x * x + c,     t * x * y - s * z, t * x * z + s * y,
         t * x * y + s * z, t * y * y + c,     t * y * z - s * x,
         t * x * z - s * y, t * y * z + s * x, t * z * z + c};
  return r;
}
// The smallest rotation taking direction `from` onto direction `to` (both non-zero).
inline Mat3 rotation_between(const Vec3& from, const Vec3& to) {
  Vec3 a = from.normalized(), b = to.normalized();
  Vec3 axis = a.cross(b);
  double s = axis.norm(), c = a.dot(b);
  if (s < 1e-12) {
    if (c > 0) return Mat3::identity();
    Vec3 any = std::fabs(a.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
    return rot_axis(a.cross(any).normalized(), M_PI);
  }
  return rot_axis(axis * (1.0 / s), std::atan2(s, c));
}

constexpr double kDegToRad = M_PI / 180.0;

}  // namespace dp::synth
