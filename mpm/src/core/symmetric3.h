#pragma once
// Symmetric 3x3 matrices stored as their six entries xx, yy, zz, xy, xz, yz (inertia
// tensors, a sided stencil's second moments).
#include "mpm/math.h"

namespace mpm {

/// Inverse of a symmetric 3x3 matrix given as xx, yy, zz, xy, xz, yz.
MPM_HD Mat3f inverseSymmetric(const float s[6]) {
  Mat3f a;
  a.m[0][0] = s[0]; a.m[1][1] = s[1]; a.m[2][2] = s[2];
  a.m[0][1] = a.m[1][0] = s[3]; a.m[0][2] = a.m[2][0] = s[4]; a.m[1][2] = a.m[2][1] = s[5];
  const float det = determinant(a);
  Mat3f inv;
  if (fabsf(det) < 1e-30f) return inv;  // zero: no rotational response
  inv.m[0][0] = (a.m[1][1] * a.m[2][2] - a.m[1][2] * a.m[2][1]) / det;
  inv.m[0][1] = (a.m[0][2] * a.m[2][1] - a.m[0][1] * a.m[2][2]) / det;
  inv.m[0][2] = (a.m[0][1] * a.m[1][2] - a.m[0][2] * a.m[1][1]) / det;
  inv.m[1][0] = inv.m[0][1];
  inv.m[1][1] = (a.m[0][0] * a.m[2][2] - a.m[0][2] * a.m[2][0]) / det;
  inv.m[1][2] = (a.m[0][2] * a.m[1][0] - a.m[0][0] * a.m[1][2]) / det;
  inv.m[2][0] = inv.m[0][2];
  inv.m[2][1] = inv.m[1][2];
  inv.m[2][2] = (a.m[0][0] * a.m[1][1] - a.m[0][1] * a.m[1][0]) / det;
  return inv;
}

/// s v for a symmetric 3x3 matrix s given as xx, yy, zz, xy, xz, yz.
MPM_HD Vec3f symmetricTimes(const float s[6], Vec3f v) {
  return {s[0] * v.x + s[3] * v.y + s[4] * v.z, s[3] * v.x + s[1] * v.y + s[5] * v.z,
          s[4] * v.x + s[5] * v.y + s[2] * v.z};
}

}  // namespace mpm
