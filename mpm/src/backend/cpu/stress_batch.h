#pragma once
// The Kirchhoff stress of many particles at once, for the CPU's P2G: kLanes particles per
// SIMD vector (SoA inside a batch: one vector per matrix entry). The laws are those of
// core/constitutive.h (kirchhoffFixedCorotated with fastPolarRotation's polar
// decomposition, kirchhoffNeoHookeanDecoupled), lane by lane; the device keeps the
// per-particle functions. Host only (GCC / Clang vector extensions); elsewhere every
// particle takes the per-particle path.
//
// Why: the stress is the largest part of an MLS-MPM substep (the Newton polar iteration
// of fixed corotated is 40 % of P2G at 125k particles); per particle it runs on scalar
// instructions, one lane of the machine's vectors.
#include <cstdint>

#include "core/constitutive.h"

namespace mpm {

#if defined(__GNUC__) && !defined(__CUDACC__)
#define MPM_STRESS_BATCH 1
namespace simd {
// the machine's vector width (the x86-64 baseline's 4 too: wider vectors would be passed
// between functions differently from what an AVX caller expects, -Wpsabi)
#if defined(__AVX512F__)
constexpr int kLanes = 16;
#elif defined(__AVX__)
constexpr int kLanes = 8;
#else
constexpr int kLanes = 4;
#endif
typedef float Floats __attribute__((vector_size(4 * kLanes)));
typedef int Mask __attribute__((vector_size(4 * kLanes)));

inline Floats splat(float s) { return Floats{} + s; }
inline Floats sqrtLanes(Floats x) {
  Floats r;
  for (int l = 0; l < kLanes; ++l) r[l] = __builtin_sqrtf(x[l]);  // one vsqrtps (-fno-math-errno)
  return r;
}
inline bool any(Mask m) {
  int a = 0;
  for (int l = 0; l < kLanes; ++l) a |= m[l];
  return a != 0;
}
}  // namespace simd

/// Fixed corotated stress (kirchhoffFixedCorotated) of the kLanes matrices f[9] (row-major
/// entries, one lane per particle). The rotation comes from fastPolarRotation's Newton
/// iteration, every lane stopping at the iteration at which it converges on its own;
/// `scalar` marks the lanes that its Jacobi path must take (flat, inverted, not finite or
/// not converged), whose tau is left to the caller.
inline void fixedCorotatedLanes(const simd::Floats f[9], const simd::Floats& mu, const simd::Floats& lambda,
                                simd::Floats tau[9], simd::Mask& scalar) {
  using simd::Floats;
  using simd::Mask;
  Floats nF2 = f[0] * f[0];
  for (int e = 1; e < 9; ++e) nF2 += f[e] * f[e];
  const Floats detF = f[0] * (f[4] * f[8] - f[5] * f[7]) - f[1] * (f[3] * f[8] - f[5] * f[6]) +
                      f[2] * (f[3] * f[7] - f[4] * f[6]);
  // det F against |F|^3, as fastPolarRotation; written as not(>) so NaN lanes fail it
  Mask active = detF > 1e-4f * nF2 * simd::sqrtLanes(nF2);
  scalar = ~active;
  Floats R[9];
  for (int e = 0; e < 9; ++e) R[e] = f[e];
  Floats r2 = nF2;
  for (int it = 0; it < 12 && simd::any(active); ++it) {
    Floats cof[9];
    cof[0] = R[4] * R[8] - R[5] * R[7];
    cof[1] = R[5] * R[6] - R[3] * R[8];
    cof[2] = R[3] * R[7] - R[4] * R[6];
    cof[3] = R[2] * R[7] - R[1] * R[8];
    cof[4] = R[0] * R[8] - R[2] * R[6];
    cof[5] = R[1] * R[6] - R[0] * R[7];
    cof[6] = R[1] * R[5] - R[2] * R[4];
    cof[7] = R[2] * R[3] - R[0] * R[5];
    cof[8] = R[0] * R[4] - R[1] * R[3];
    const Floats det = R[0] * cof[0] + R[1] * cof[1] + R[2] * cof[2];
    Floats c2 = cof[0] * cof[0];
    for (int e = 1; e < 9; ++e) c2 += cof[e] * cof[e];
    const Floats g = simd::sqrtLanes(simd::sqrtLanes(c2 / (det * det * r2)));
    const Floats a = 0.5f * g, b = 0.5f / (g * det);
    Floats d2 = simd::splat(0.f), n2 = simd::splat(0.f);
    for (int e = 0; e < 9; ++e) {
      const Floats next = a * R[e] + b * cof[e];
      const Floats d = next - R[e];
      d2 += d * d;
      n2 += next * next;
      R[e] = active ? next : R[e];
    }
    r2 = active ? n2 : r2;
    active &= ~(d2 < 1e-10f);  // converged lanes keep this R
  }
  scalar |= active;  // not converged in 12 iterations
  // tau = 2 mu (F - R) F^T + lambda (J - 1) J I
  const Floats twoMu = 2.f * mu, vol = lambda * (detF - 1.f) * detF;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      Floats s = (f[3 * i] - R[3 * i]) * f[3 * j];
      s += (f[3 * i + 1] - R[3 * i + 1]) * f[3 * j + 1];
      s += (f[3 * i + 2] - R[3 * i + 2]) * f[3 * j + 2];
      tau[3 * i + j] = twoMu * s + (i == j ? vol : simd::splat(0.f));
    }
}
#endif

/// 1 / cbrt(x) in every lane, for kirchhoffNeoHookeanDecoupled's J^-2/3 = 1 / cbrt(J^2)
/// (cbrtf has no vector form here: per particle it was a tenth of the embedding scene's
/// substep). A first guess from the exponent bits, then Newton's iteration for x y^3 = 1,
/// y <- y (4 - x y^3) / 3, whose relative error e goes to about 2 e^2: from the guess's
/// few per cent to float rounding in three steps (measured: 1.7e-7 at the most, 1.9e-5
/// after two). `outside` marks the lanes where x is not a
/// positive normal float far enough from the limits for y^3 x to stay finite (zero,
/// negative, huge, NaN): those lanes' results are not to be used.
inline simd::Floats inverseCbrtLanes(const simd::Floats& x, simd::Mask& outside) {
  using simd::Floats;
  using simd::Mask;
  outside = ~((x > 1e-30f) & (x < 1e30f));  // not(inside) also marks NaN
  const Floats safe = outside ? simd::splat(1.f) : x;
  Mask bits;
  __builtin_memcpy(&bits, &safe, sizeof bits);
  bits = 0x54a2fa8c - bits / 3;  // bits of x^-1/3 to a few per cent
  Floats y;
  __builtin_memcpy(&y, &bits, sizeof y);
  for (int it = 0; it < 3; ++it) y = y * (4.f - safe * (y * y * y)) * (1.f / 3.f);
  return y;
}

/// Decoupled Neo-Hookean stress (kirchhoffNeoHookeanDecoupled) of the kLanes matrices f[9]:
/// tau = mu dev(J^-2/3 B) + K J (J - 1) I. `scalar` marks the lanes whose J^2 is outside
/// inverseCbrtLanes' range (flat or not finite), whose tau is left to the caller.
inline void neoHookeanDecoupledLanes(const simd::Floats f[9], const simd::Floats& mu, const simd::Floats& bulk,
                                     simd::Floats tau[9], simd::Mask& scalar) {
  using simd::Floats;
  const Floats J = f[0] * (f[4] * f[8] - f[5] * f[7]) - f[1] * (f[3] * f[8] - f[5] * f[6]) +
                   f[2] * (f[3] * f[7] - f[4] * f[6]);
  const Floats muJm23 = mu * inverseCbrtLanes(J * J, scalar);
  for (int i = 0; i < 3; ++i)
    for (int j = i; j < 3; ++j) {
      const Floats b = f[3 * i] * f[3 * j] + f[3 * i + 1] * f[3 * j + 1] + f[3 * i + 2] * f[3 * j + 2];
      tau[3 * i + j] = tau[3 * j + i] = muJm23 * b;  // B = F F^T is symmetric
    }
  const Floats diag = -(tau[0] + tau[4] + tau[8]) * (1.f / 3.f) + bulk * J * (J - 1.f);
  tau[0] += diag;
  tau[4] += diag;
  tau[8] += diag;
}

/// tau[q] = kirchhoffStress(materials[object[ids[q]]], F[ids[q]]) for q < n: kLanes
/// particles at a time, each law's lanes computed only when the batch holds one of its
/// particles; the lanes a law leaves to the scalar path take kirchhoffStress.
inline void kirchhoffStressBatch(const MaterialParams* materials, const uint32_t* object, const Mat3f* F,
                                 const uint32_t* ids, int n, Mat3f* tau) {
#ifdef MPM_STRESS_BATCH
  using simd::kLanes;
  for (int q0 = 0; q0 < n; q0 += kLanes) {
    const int lanes = n - q0 < kLanes ? n - q0 : kLanes;
    simd::Floats f[9], mu = simd::splat(0.f), second = simd::splat(0.f);  // second: lambda or K
    simd::Mask model = simd::Mask{} - 1;  // -1: a lane left to kirchhoffStress (unused lanes too)
    bool corotated = false, neoHookean = false;
    for (int l = 0; l < kLanes; ++l) {
      // unused lanes compute the identity's zero stress
      const Mat3f& Fl = l < lanes ? F[ids[q0 + l]] : Mat3f::identity();
      for (int e = 0; e < 9; ++e) f[e][l] = Fl.m[e / 3][e % 3];
      if (l >= lanes) continue;
      const MaterialParams& mat = materials[object[ids[q0 + l]]];
      if (mat.model == kFixedCorotated) {
        corotated = true;
        second[l] = mat.lambda;
      } else if (mat.model == kNeoHookeanDecoupled) {
        neoHookean = true;
        second[l] = mat.bulk;
      } else {
        continue;
      }
      model[l] = mat.model;
      mu[l] = mat.mu;
    }
    simd::Floats t[9] = {}, tNeo[9];
    simd::Mask scalar = simd::Mask{}, scalarNeo = simd::Mask{};
    if (corotated) fixedCorotatedLanes(f, mu, second, t, scalar);
    if (neoHookean) {
      neoHookeanDecoupledLanes(f, mu, second, tNeo, scalarNeo);
      const simd::Mask isNeo = model == (int)kNeoHookeanDecoupled;
      for (int e = 0; e < 9; ++e) t[e] = isNeo ? tNeo[e] : t[e];
      scalar = isNeo ? scalarNeo : scalar;
    }
    for (int l = 0; l < lanes; ++l) {
      const uint32_t p = ids[q0 + l];
      Mat3f& out = tau[q0 + l];
      if (model[l] < 0 || scalar[l]) {
        out = kirchhoffStress(materials[object[p]], F[p]);
        continue;
      }
      for (int e = 0; e < 9; ++e) out.m[e / 3][e % 3] = t[e][l];
    }
  }
#else
  for (int q = 0; q < n; ++q) tau[q] = kirchhoffStress(materials[object[ids[q]]], F[ids[q]]);
#endif
}

}  // namespace mpm
