#pragma once
// Elastic constitutive laws as host/device functions of F. Both return the Kirchhoff
// stress tau = P F^T, which is what MLS-MPM's fused P2G needs (times the rest volume).
#include "core/polar.h"
#include "mpm/math.h"

namespace mpm {

/// Material constants as the kernels use them (derived once from Material).
struct MaterialParams {
  int model = 0;       ///< static_cast<int>(MaterialModel)
  float mu = 0;        ///< shear modulus [Pa]
  float lambda = 0;    ///< first Lamé parameter [Pa]
  float bulk = 0;      ///< K = lambda + 2 mu / 3 [Pa]
  float density = 0;   ///< [kg/m^3]
  float toughness = 0; ///< fracture toughness G_c [J/m^2]
};

enum : int { kFixedCorotated = 0, kNeoHookeanDecoupled = 1 };

/// Fixed corotated (Stomakhin et al. 2012): tau = 2 mu (F - R) F^T + lambda (J - 1) J I.
/// R is the rotation of the polar decomposition with det R = +1, so the law stays
/// defined for inverted elements.
MPM_HD Mat3f kirchhoffFixedCorotated(const Mat3f& F, float mu, float lambda) {
  const Mat3f R = fastPolarRotation(F);
  const float J = determinant(F);
  Mat3f tau = (2.f * mu) * ((F - R) * transpose(F));
  const float vol = lambda * (J - 1.f) * J;
  tau.m[0][0] += vol; tau.m[1][1] += vol; tau.m[2][2] += vol;
  return tau;
}

/// Decoupled Neo-Hookean, W = mu/2 (I1bar - 3) + K/2 (J - 1)^2 (CalculiX / Abaqus
/// NEO HOOKE with C10 = mu/2, D1 = 2/K): tau = mu dev(J^-2/3 B) + K J (J - 1) I.
MPM_HD Mat3f kirchhoffNeoHookeanDecoupled(const Mat3f& F, float mu, float bulk) {
  const float J = determinant(F);
  const Mat3f B = F * transpose(F);
  // cbrt of a negative J keeps the sign; an inverted particle is pushed back by K J (J-1).
  const float Jm23 = 1.f / cbrtf(J * J);
  const float trB3 = trace(B) * (1.f / 3.f);
  Mat3f tau = (mu * Jm23) * B;
  const float diag = -mu * Jm23 * trB3 + bulk * J * (J - 1.f);
  tau.m[0][0] += diag; tau.m[1][1] += diag; tau.m[2][2] += diag;
  return tau;
}

MPM_HD Mat3f kirchhoffStress(const MaterialParams& mat, const Mat3f& F) {
  switch (mat.model) {
    case kNeoHookeanDecoupled:
      return kirchhoffNeoHookeanDecoupled(F, mat.mu, mat.bulk);
    case kFixedCorotated:
    default:
      return kirchhoffFixedCorotated(F, mat.mu, mat.lambda);
  }
}

/// Strain energy per unit rest volume [J/m^3] of the law whose stress kirchhoffStress
/// returns: fixed corotated mu |F - R|^2 + lambda/2 (J - 1)^2, decoupled Neo-Hookean
/// mu/2 (J^-2/3 tr B - 3) + K/2 (J - 1)^2.
MPM_HD float strainEnergyDensity(const MaterialParams& mat, const Mat3f& F) {
  const float J = determinant(F);
  if (mat.model == kNeoHookeanDecoupled) {
    const float trB = trace(F * transpose(F));
    return 0.5f * mat.mu * (trB / cbrtf(J * J) - 3.f) + 0.5f * mat.bulk * (J - 1.f) * (J - 1.f);
  }
  const Mat3f D = F - polarRotation(F);
  return mat.mu * trace(D * transpose(D)) + 0.5f * mat.lambda * (J - 1.f) * (J - 1.f);
}

/// Speed of the fastest elastic (P) wave, sqrt((lambda + 2 mu) / rho) [m/s], small strain.
inline float pWaveSpeed(const MaterialParams& mat) {
  return std::sqrt((mat.lambda + 2.f * mat.mu) / mat.density);
}

}  // namespace mpm
