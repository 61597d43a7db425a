#pragma once
// The Kirchhoff stress of many particles at once, for the CPU's P2G: kLanes particles per
// SIMD vector (SoA inside a batch: one vector per matrix entry). The law and its polar
// decomposition are those of core/constitutive.h (kirchhoffFixedCorotated with
// fastPolarRotation), lane by lane; the device and the other laws keep the per-particle
// functions. Host only (GCC / Clang vector extensions); elsewhere every particle takes the
// per-particle path.
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

/// tau[q] = kirchhoffStress(materials[object[ids[q]]], F[ids[q]]) for q < n: fixed
/// corotated particles kLanes at a time, the rest one by one.
inline void kirchhoffStressBatch(const MaterialParams* materials, const uint32_t* object, const Mat3f* F,
                                 const uint32_t* ids, int n, Mat3f* tau) {
#ifdef MPM_STRESS_BATCH
  using simd::kLanes;
  for (int q0 = 0; q0 < n; q0 += kLanes) {
    const int lanes = n - q0 < kLanes ? n - q0 : kLanes;
    simd::Floats f[9], mu = simd::splat(0.f), lambda = simd::splat(0.f), t[9];
    simd::Mask other = simd::Mask{} + 1;  // lanes the batch leaves to kirchhoffStress
    for (int l = 0; l < kLanes; ++l) {
      // unused lanes compute the identity's zero stress
      const Mat3f& Fl = l < lanes ? F[ids[q0 + l]] : Mat3f::identity();
      for (int e = 0; e < 9; ++e) f[e][l] = Fl.m[e / 3][e % 3];
      if (l >= lanes) continue;
      const MaterialParams& mat = materials[object[ids[q0 + l]]];
      if (mat.model != kFixedCorotated) continue;
      other[l] = 0;
      mu[l] = mat.mu;
      lambda[l] = mat.lambda;
    }
    simd::Mask scalar;
    fixedCorotatedLanes(f, mu, lambda, t, scalar);
    for (int l = 0; l < lanes; ++l) {
      const uint32_t p = ids[q0 + l];
      Mat3f& out = tau[q0 + l];
      if (other[l] || scalar[l]) {
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
