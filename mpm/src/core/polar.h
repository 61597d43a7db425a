#pragma once
// Rotation of the polar decomposition F = R S with det R = +1, for host and device.
// Eigen-decomposition of F^T F by cyclic Jacobi, then U from F V / sigma with the last
// column completed by a cross product: that keeps det U = +1 when F is inverted or
// flattened, which is exactly what fixed-corotated elasticity needs.
#include "mpm/math.h"

namespace mpm {

/// Symmetric 3x3 eigen-decomposition A = V diag(e) V^T by cyclic Jacobi rotations.
MPM_HD void symmetricEigen(const Mat3f& A, Mat3f& V, float e[3]) {
  float a[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) a[i][j] = A.m[i][j];
  V = Mat3f::identity();
  for (int sweep = 0; sweep < 8; ++sweep) {
    const float off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
    const float diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
    if (off <= 1e-14f * diag || off == 0.f) break;
    for (int pq = 0; pq < 3; ++pq) {
      const int p = pq == 2 ? 1 : 0;
      const int q = pq == 0 ? 1 : 2;
      const float apq = a[p][q];
      if (apq == 0.f) continue;
      // rotation angle that zeroes a[p][q] (Golub & Van Loan 8.5.2)
      const float theta = (a[q][q] - a[p][p]) / (2.f * apq);
      const float t = (theta >= 0.f ? 1.f : -1.f) / (fabsf(theta) + sqrtf(theta * theta + 1.f));
      const float c = 1.f / sqrtf(t * t + 1.f);
      const float s = t * c;
      for (int k = 0; k < 3; ++k) {  // a <- a J
        const float akp = a[k][p], akq = a[k][q];
        a[k][p] = c * akp - s * akq;
        a[k][q] = s * akp + c * akq;
      }
      for (int k = 0; k < 3; ++k) {  // a <- J^T a
        const float apk = a[p][k], aqk = a[q][k];
        a[p][k] = c * apk - s * aqk;
        a[q][k] = s * apk + c * aqk;
      }
      for (int k = 0; k < 3; ++k) {  // V <- V J
        const float vkp = V.m[k][p], vkq = V.m[k][q];
        V.m[k][p] = c * vkp - s * vkq;
        V.m[k][q] = s * vkp + c * vkq;
      }
    }
  }
  e[0] = a[0][0]; e[1] = a[1][1]; e[2] = a[2][2];
}

MPM_HD Vec3f normalizedOr(Vec3f v, Vec3f fallback) {
  const float n = norm(v);
  return n > 1e-20f ? (1.f / n) * v : fallback;
}

/// Any unit vector orthogonal to unit vector a.
MPM_HD Vec3f anyOrthogonal(Vec3f a) {
  const Vec3f t = fabsf(a.x) < 0.6f ? Vec3f{1.f, 0.f, 0.f} : Vec3f{0.f, 1.f, 0.f};
  return normalizedOr(cross(a, t), Vec3f{0.f, 0.f, 1.f});
}

/// R of F = R S, det R = +1. Singular values come out as sigma (the last one negative
/// when det F < 0), sorted by magnitude, largest first.
MPM_HD Mat3f polarRotation(const Mat3f& F, float sigma[3] = nullptr) {
  Mat3f V;
  float e[3];
  symmetricEigen(transpose(F) * F, V, e);
  // sort eigenpairs descending so the column rebuilt by a cross product is the weakest
  int order[3] = {0, 1, 2};
  if (e[order[0]] < e[order[1]]) { int t = order[0]; order[0] = order[1]; order[1] = t; }
  if (e[order[1]] < e[order[2]]) { int t = order[1]; order[1] = order[2]; order[2] = t; }
  if (e[order[0]] < e[order[1]]) { int t = order[0]; order[0] = order[1]; order[1] = t; }
  Vec3f v0 = V.column(order[0]), v1 = V.column(order[1]);
  Vec3f v2 = cross(v0, v1);  // makes det V = +1
  Vec3f u0 = normalizedOr(F * v0, Vec3f{1.f, 0.f, 0.f});
  Vec3f u1 = F * v1;
  u1 = u1 - dot(u1, u0) * u0;
  u1 = norm(u1) > 1e-20f ? normalizedOr(u1, u1) : anyOrthogonal(u0);
  const Vec3f u2 = cross(u0, u1);
  if (sigma) {
    sigma[0] = dot(u0, F * v0);
    sigma[1] = dot(u1, F * v1);
    sigma[2] = dot(u2, F * v2);
  }
  // R = U V^T
  return Mat3f::fromColumns(u0, u1, u2) * transpose(Mat3f::fromColumns(v0, v1, v2));
}

/// R of F = R S, det R = +1, as polarRotation gives it, but faster where F is not inverted:
/// for det F clearly positive, Newton's iteration R <- (g R + R^-T / g) / 2 (Higham 1986),
/// with the Frobenius-norm scaling g = (|R^-1| / |R|)^(1/2), converges quadratically to the
/// rotation of the polar decomposition (3-5 iterations for the strains of soft tissue).
/// Inverted, nearly flat or unconverged F take polarRotation's Jacobi path.
MPM_HD Mat3f fastPolarRotation(const Mat3f& F) {
  const float nF2 = F.m[0][0] * F.m[0][0] + F.m[0][1] * F.m[0][1] + F.m[0][2] * F.m[0][2] +
                    F.m[1][0] * F.m[1][0] + F.m[1][1] * F.m[1][1] + F.m[1][2] * F.m[1][2] +
                    F.m[2][0] * F.m[2][0] + F.m[2][1] * F.m[2][1] + F.m[2][2] * F.m[2][2];
  // det F against |F|^3 (scale-free): below 1e-4 the element is flat, inverted or not finite
  if (!(determinant(F) > 1e-4f * nF2 * sqrtf(nF2))) return polarRotation(F);
  Mat3f R = F;
  float r2 = nF2;  // |R|_F^2
  for (int it = 0; it < 12; ++it) {
    // cofactor matrix: R^-T = cof / det R
    Mat3f cof;
    cof.m[0][0] = R.m[1][1] * R.m[2][2] - R.m[1][2] * R.m[2][1];
    cof.m[0][1] = R.m[1][2] * R.m[2][0] - R.m[1][0] * R.m[2][2];
    cof.m[0][2] = R.m[1][0] * R.m[2][1] - R.m[1][1] * R.m[2][0];
    cof.m[1][0] = R.m[0][2] * R.m[2][1] - R.m[0][1] * R.m[2][2];
    cof.m[1][1] = R.m[0][0] * R.m[2][2] - R.m[0][2] * R.m[2][0];
    cof.m[1][2] = R.m[0][1] * R.m[2][0] - R.m[0][0] * R.m[2][1];
    cof.m[2][0] = R.m[0][1] * R.m[1][2] - R.m[0][2] * R.m[1][1];
    cof.m[2][1] = R.m[0][2] * R.m[1][0] - R.m[0][0] * R.m[1][2];
    cof.m[2][2] = R.m[0][0] * R.m[1][1] - R.m[0][1] * R.m[1][0];
    const float det = R.m[0][0] * cof.m[0][0] + R.m[0][1] * cof.m[0][1] + R.m[0][2] * cof.m[0][2];
    float c2 = 0.f;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) c2 += cof.m[i][j] * cof.m[i][j];
    // g^4 = |R^-T|^2 / |R|^2 = c2 / (det^2 r2)
    const float g = sqrtf(sqrtf(c2 / (det * det * r2)));
    const float a = 0.5f * g, b = 0.5f / (g * det);
    float d2 = 0.f, n2 = 0.f;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        const float next = a * R.m[i][j] + b * cof.m[i][j];
        const float d = next - R.m[i][j];
        d2 += d * d;
        n2 += next * next;
        R.m[i][j] = next;
      }
    r2 = n2;
    // quadratic convergence: a step below 1e-5 leaves an error below float precision
    if (d2 < 1e-10f) return R;
  }
  return polarRotation(F);
}

}  // namespace mpm
