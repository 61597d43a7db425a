#pragma once
/// Small fixed-size vector and matrix types usable from host code and CUDA kernels.
/// Eigen serves host-side linear algebra; these serve the per-particle kernels, where
/// Eigen is heavy and only partly supported under nvcc.
#include <cmath>

#if defined(__CUDACC__)
#define MPM_HD __host__ __device__ __forceinline__
#else
#define MPM_HD inline
#endif

namespace mpm {

/// 3-vector of floats (SI units wherever it carries a physical quantity).
struct Vec3f {
  float x = 0, y = 0, z = 0;
  MPM_HD Vec3f() = default;
  MPM_HD Vec3f(float x_, float y_, float z_) : x(x_), y(y_), z(z_) {}
  // x, y, z are contiguous (standard layout, no padding): indexing them as an array is
  // what lets loops over axes unroll into plain loads instead of branches
  MPM_HD float& operator[](int i) { return (&x)[i]; }
  MPM_HD float operator[](int i) const { return (&x)[i]; }
};

MPM_HD Vec3f operator+(Vec3f a, Vec3f b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
MPM_HD Vec3f operator-(Vec3f a, Vec3f b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
MPM_HD Vec3f operator-(Vec3f a) { return {-a.x, -a.y, -a.z}; }
MPM_HD Vec3f operator*(float s, Vec3f a) { return {s * a.x, s * a.y, s * a.z}; }
MPM_HD Vec3f operator*(Vec3f a, float s) { return {s * a.x, s * a.y, s * a.z}; }
MPM_HD Vec3f& operator+=(Vec3f& a, Vec3f b) { a.x += b.x; a.y += b.y; a.z += b.z; return a; }
MPM_HD Vec3f& operator-=(Vec3f& a, Vec3f b) { a.x -= b.x; a.y -= b.y; a.z -= b.z; return a; }
MPM_HD float dot(Vec3f a, Vec3f b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
MPM_HD Vec3f cross(Vec3f a, Vec3f b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
MPM_HD float norm(Vec3f a) { return sqrtf(dot(a, a)); }
/// Component-wise product.
MPM_HD Vec3f hadamard(Vec3f a, Vec3f b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
/// False for NaN and +-inf (works without `<cmath>` on device, and without fast-math).
MPM_HD bool isFinite(float v) { return v - v == 0.f; }

/// 3x3 matrix of floats, row-major: m[r][c].
struct Mat3f {
  float m[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  MPM_HD static Mat3f identity() {
    Mat3f r;
    r.m[0][0] = r.m[1][1] = r.m[2][2] = 1.f;
    return r;
  }
  MPM_HD static Mat3f diagonal(float a, float b, float c) {
    Mat3f r;
    r.m[0][0] = a; r.m[1][1] = b; r.m[2][2] = c;
    return r;
  }
  /// Matrix whose columns are a, b, c.
  MPM_HD static Mat3f fromColumns(Vec3f a, Vec3f b, Vec3f c) {
    Mat3f r;
    for (int i = 0; i < 3; ++i) { r.m[i][0] = a[i]; r.m[i][1] = b[i]; r.m[i][2] = c[i]; }
    return r;
  }
  MPM_HD Vec3f column(int c) const { return {m[0][c], m[1][c], m[2][c]}; }
  MPM_HD float* operator[](int r) { return m[r]; }
  MPM_HD const float* operator[](int r) const { return m[r]; }
};

MPM_HD Mat3f operator+(const Mat3f& a, const Mat3f& b) {
  Mat3f r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[i][j] + b.m[i][j];
  return r;
}
MPM_HD Mat3f operator-(const Mat3f& a, const Mat3f& b) {
  Mat3f r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[i][j] - b.m[i][j];
  return r;
}
MPM_HD Mat3f operator*(float s, const Mat3f& a) {
  Mat3f r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = s * a.m[i][j];
  return r;
}
MPM_HD Mat3f operator*(const Mat3f& a, const Mat3f& b) {
  Mat3f r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      r.m[i][j] = a.m[i][0] * b.m[0][j] + a.m[i][1] * b.m[1][j] + a.m[i][2] * b.m[2][j];
  return r;
}
MPM_HD Vec3f operator*(const Mat3f& a, Vec3f v) {
  return {a.m[0][0] * v.x + a.m[0][1] * v.y + a.m[0][2] * v.z,
          a.m[1][0] * v.x + a.m[1][1] * v.y + a.m[1][2] * v.z,
          a.m[2][0] * v.x + a.m[2][1] * v.y + a.m[2][2] * v.z};
}
MPM_HD Mat3f transpose(const Mat3f& a) {
  Mat3f r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[j][i];
  return r;
}
MPM_HD float trace(const Mat3f& a) { return a.m[0][0] + a.m[1][1] + a.m[2][2]; }
MPM_HD float determinant(const Mat3f& a) {
  return a.m[0][0] * (a.m[1][1] * a.m[2][2] - a.m[1][2] * a.m[2][1]) -
         a.m[0][1] * (a.m[1][0] * a.m[2][2] - a.m[1][2] * a.m[2][0]) +
         a.m[0][2] * (a.m[1][0] * a.m[2][1] - a.m[1][1] * a.m[2][0]);
}
/// Inverse by the adjugate; the caller makes sure det a != 0.
MPM_HD Mat3f inverse(const Mat3f& a) {
  const float inv = 1.f / determinant(a);
  Mat3f r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      // cofactor of a[j][i], from the cyclic neighbours of row j and column i
      const int r0 = (j + 1) % 3, r1 = (j + 2) % 3, c0 = (i + 1) % 3, c1 = (i + 2) % 3;
      r.m[i][j] = inv * (a.m[r0][c0] * a.m[r1][c1] - a.m[r0][c1] * a.m[r1][c0]);
    }
  return r;
}
/// Outer product a b^T.
MPM_HD Mat3f outer(Vec3f a, Vec3f b) {
  Mat3f r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = a[i] * b[j];
  return r;
}

}  // namespace mpm
