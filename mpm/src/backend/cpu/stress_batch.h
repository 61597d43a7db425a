#pragma once
// The material's response of many particles at once, for the CPU's P2G: kLanes particles
// per SIMD vector (SoA inside a batch: one vector per matrix entry). The Kirchhoff stress
// of the laws of core/constitutive.h (kirchhoffFixedCorotated with fastPolarRotation's
// polar decomposition, kirchhoffNeoHookeanDecoupled) for MLS-MPM, and PB-MPM's constraint
// projection (core/pb_projection.h), lane by lane the same arithmetic; the device keeps
// the per-particle functions. Host only (GCC / Clang vector extensions); elsewhere every
// particle takes the per-particle path.
//
// Why: the stress is the largest part of an MLS-MPM substep (the Newton polar iteration
// of fixed corotated is 40 % of P2G at 125k particles), and PB-MPM's polar rotation was
// 30 % of its iterations on the embedding scene; per particle they run on scalar
// instructions, one lane of the machine's vectors.
#include <cstdint>

#include "backend/cpu/lanes_layout.h"
#include "core/constitutive.h"
#include "core/pb_projection.h"

namespace mpm {

#ifdef MPM_CPU_LANES

/// det of the kLanes matrices f[9] (row-major entries, one lane per particle).
inline simd::Floats determinantLanes(const simd::Floats f[9]) {
  return f[0] * (f[4] * f[8] - f[5] * f[7]) - f[1] * (f[3] * f[8] - f[5] * f[6]) + f[2] * (f[3] * f[7] - f[4] * f[6]);
}

/// fastPolarRotation of the kLanes matrices f[9] with determinants detF: Newton's
/// iteration, every lane stopping at the iteration at which it converges on its own.
/// `scalar` marks the lanes that its Jacobi path must take (flat, inverted, not finite or
/// not converged), whose R is not to be used.
inline void polarRotationLanes(const simd::Floats f[9], const simd::Floats& detF, simd::Floats R[9],
                               simd::Mask& scalar) {
  using simd::Floats;
  using simd::Mask;
  Floats nF2 = f[0] * f[0];
  for (int e = 1; e < 9; ++e) nF2 += f[e] * f[e];
  // det F against |F|^3, as fastPolarRotation; written as not(>) so NaN lanes fail it
  Mask active = detF > 1e-4f * nF2 * simd::sqrtLanes(nF2);
  scalar = ~active;
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
}

/// Fixed corotated stress (kirchhoffFixedCorotated) of the kLanes matrices f[9], with the
/// rotation of polarRotationLanes; `scalar` marks the lanes whose tau is left to the caller.
inline void fixedCorotatedLanes(const simd::Floats f[9], const simd::Floats& mu, const simd::Floats& lambda,
                                simd::Floats tau[9], simd::Mask& scalar) {
  using simd::Floats;
  const Floats detF = determinantLanes(f);
  Floats R[9];
  polarRotationLanes(f, detF, R, scalar);
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
  const Floats J = determinantLanes(f);
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

/// PB-MPM's projected velocity gradient (pbProjectedVelocityGradient) of the kLanes
/// particles with F f[9] and C c[9]; `scalar` marks the lanes left to the caller (the
/// polar rotation's Jacobi path, or J^(1/3) outside inverseCbrtLanes' range).
inline void pbProjectionLanes(const simd::Floats f[9], const simd::Floats c[9], float dt, float relaxation,
                              float rigidity, simd::Floats out[9], simd::Mask& scalar) {
  using simd::Floats;
  Floats fs[9];  // F* = (I + dt C) F
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const Floats a0 = dt * c[3 * i] + (i == 0 ? 1.f : 0.f), a1 = dt * c[3 * i + 1] + (i == 1 ? 1.f : 0.f),
                   a2 = dt * c[3 * i + 2] + (i == 2 ? 1.f : 0.f);
      fs[3 * i + j] = a0 * f[j] + a1 * f[3 + j] + a2 * f[6 + j];
    }
  const Floats J = determinantLanes(fs);
  Floats R[9];
  polarRotationLanes(fs, J, R, scalar);
  simd::Mask outside;
  const Floats invCbrtJ = inverseCbrtLanes(J, outside);
  const simd::Mask positive = J > 0.f;
  scalar |= outside & ~(J <= 0.f);  // J <= 0 takes R; tiny, huge or NaN J the scalar path
  Floats fc[9];
  for (int e = 0; e < 9; ++e) fc[e] = rigidity * R[e] + (1.f - rigidity) * (positive ? invCbrtJ * fs[e] : R[e]);
  // F^-1 = cof(F)^T / det F
  const Floats invDet = 1.f / determinantLanes(f);
  Floats inv[9];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const int r0 = (j + 1) % 3, r1 = (j + 2) % 3, c0 = (i + 1) % 3, c1 = (i + 2) % 3;
      inv[3 * i + j] = invDet * (f[3 * r0 + c0] * f[3 * r1 + c1] - f[3 * r0 + c1] * f[3 * r1 + c0]);
    }
  // C_c = C + omega ((F_c F^-1 - I) / dt - C)
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const Floats fcInv = fc[3 * i] * inv[j] + fc[3 * i + 1] * inv[3 + j] + fc[3 * i + 2] * inv[6 + j];
      const Floats rate = (1.f / dt) * (fcInv - (i == j ? 1.f : 0.f));
      out[3 * i + j] = c[3 * i + j] + relaxation * (rate - c[3 * i + j]);
    }
}
#endif  // the lanes (GCC / Clang vector extensions)

/// Cc[q] = pbProjectedVelocityGradient(F[ids[q]], C[ids[q]], ...) for q < n, kLanes
/// particles at a time.
inline void pbProjectionBatch(const Mat3f* F, const Mat3f* C, const uint32_t* ids, int n, float dt,
                              float relaxation, float rigidity, Mat3f* Cc) {
#ifdef MPM_CPU_LANES
  using simd::kLanes;
  for (int q0 = 0; q0 < n; q0 += kLanes) {
    const int lanes = n - q0 < kLanes ? n - q0 : kLanes;
    simd::Floats f[9], c[9], out[9];
    simd::loadMat3Lanes(F, ids + q0, lanes, Mat3f::identity(), f);
    simd::loadMat3Lanes(C, ids + q0, lanes, Mat3f{}, c);
    simd::Mask scalar;
    pbProjectionLanes(f, c, dt, relaxation, rigidity, out, scalar);
    simd::storeMat3Prefix(out, lanes, &Cc[q0]);
    for (uint32_t left = simd::laneBits(scalar & simd::lanesBelow(lanes)); left; left &= left - 1) {
      const int l = __builtin_ctz(left);
      const uint32_t p = ids[q0 + l];
      Cc[q0 + l] = pbProjectedVelocityGradient(F[p], C[p], dt, relaxation, rigidity);
    }
  }
#else
  for (int q = 0; q < n; ++q) Cc[q] = pbProjectedVelocityGradient(F[ids[q]], C[ids[q]], dt, relaxation, rigidity);
#endif
}

/// tau[q] = kirchhoffStress(materials[object[ids[q]]], F[ids[q]]) for q < n: kLanes
/// particles at a time, each law's lanes computed only when the batch holds one of its
/// particles; the lanes a law leaves to the scalar path take kirchhoffStress.
inline void kirchhoffStressBatch(const MaterialParams* materials, const uint32_t* object, const Mat3f* F,
                                 const uint32_t* ids, int n, Mat3f* tau) {
#ifdef MPM_CPU_LANES
  using simd::kLanes;
  for (int q0 = 0; q0 < n; q0 += kLanes) {
    const int lanes = n - q0 < kLanes ? n - q0 : kLanes;
    simd::Floats f[9], mu = simd::splat(0.f), second = simd::splat(0.f);  // second: lambda or K
    simd::Mask model = simd::Mask{} - 1;  // -1: a lane left to kirchhoffStress (unused lanes too)
    bool corotated = false, neoHookean = false;
    simd::loadMat3Lanes(F, ids + q0, lanes, Mat3f::identity(), f);  // unused lanes: the identity's zero stress
    for (int l = 0; l < lanes; ++l) {
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
    simd::storeMat3Prefix(t, lanes, &tau[q0]);
    for (uint32_t left = simd::laneBits(((model < 0) | scalar) & simd::lanesBelow(lanes)); left; left &= left - 1) {
      const int l = __builtin_ctz(left);
      const uint32_t p = ids[q0 + l];
      tau[q0 + l] = kirchhoffStress(materials[object[p]], F[p]);
    }
  }
#else
  for (int q = 0; q < n; ++q) tau[q] = kirchhoffStress(materials[object[ids[q]]], F[ids[q]]);
#endif
}

}  // namespace mpm
