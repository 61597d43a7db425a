#pragma once
// What one substep is given and what it reports, shared by the Scene, the backends and
// the solvers' kernels.
#include <cstdint>

#include "grid/grid_update.h"
#include "mpm/math.h"

namespace mpm {

/// The chosen solver's parameters (SceneSettings.standardMpm / .pbMpm, validated).
struct SolverParams {
  float flipBlend = 0.95f;  ///< standard MPM: FLIP share of the particle velocity update
  int iterations = 10;      ///< PB-MPM: P2G-G2P iterations per substep
  float relaxation = 1.f;   ///< PB-MPM: share of the constraint's correction of C taken
  float rigidity = 1.f;     ///< PB-MPM: beta of eq. 15, rotation against volume-preserving part
};

/// Constant inputs of one substep.
struct SubstepParams {
  float dt = 0;
  Vec3f gravity;
  WallParams walls;
  SolverParams solver;
};

/// Result of the per-particle checks that run inside G2P.
struct StepCheck {
  float maxSpeed2 = 0;                      ///< largest |v|^2 after the substep [m^2/s^2]
  /// lowest index of a particle not finite, escaped or with J out of bounds (volumeRatioSound)
  uint32_t firstBadParticle = 0xffffffffu;
  float peakSpeed2 = 0;  ///< largest |v|^2 of any substep of the advance (takeCheck) [m^2/s^2]
};

}  // namespace mpm
