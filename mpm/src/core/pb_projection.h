#pragma once
// PB-MPM's constraint projection of one particle (Lewin 2024; the CRESSim-MPM paper,
// eqs. 13-16), the per-particle form that the device and the CPU's scalar path run; the
// CPU's P2G takes it for many particles at once in backend/cpu/stress_batch.h
// (pbProjectionBatch), lane by lane the same arithmetic.
#include "core/polar.h"

namespace mpm {

/// The velocity gradient C_c whose motion moves F toward the material constraint: with
/// F* = (I + dt C) F, R its polar rotation and J = det F*,
/// F_c = beta R + (1 - beta) F* / J^(1/3) (R where J <= 0) and
/// C_c = C + omega ((F_c F^-1 - I) / dt - C). beta: rigidity, omega: relaxation.
MPM_HD Mat3f pbProjectedVelocityGradient(const Mat3f& F, const Mat3f& C, float dt, float relaxation,
                                         float rigidity) {
  const Mat3f I = Mat3f::identity();
  const Mat3f Fstar = (I + dt * C) * F;
  const Mat3f R = fastPolarRotation(Fstar);
  const float J = determinant(Fstar);
  const Mat3f isochoric = J > 0.f ? (1.f / cbrtf(J)) * Fstar : R;
  const Mat3f Fc = rigidity * R + (1.f - rigidity) * isochoric;
  return C + relaxation * ((1.f / dt) * (Fc * inverse(F) - I) - C);
}

}  // namespace mpm
