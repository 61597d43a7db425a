#pragma once
// How many substeps an advance takes: the CFL bound on the fastest elastic wave plus the
// fastest particle or shape, the solver's own stable step, and the limit past which an
// advance is refused.
#include "system/sim_backend.h"
#include "core/substep.h"
#include "scene/particle_seeding.h"
#include "scene/shape_exchange.h"

namespace mpm {

/// The bounds on the substep over the scene as it is now (SceneSettings.substeps applied).
struct SubstepBounds {
  const SceneSettings& settings;
  const ObjectTable& objects;
  const ShapeTable& shapes;
  const SlicerTable& slicers;
  const CurveTable& curves;
  float maxParticleSpeed;  ///< fastest particle after the last advance, or as seeded [m/s]
  SimBackend& backend;     ///< not const: stableTimeStep() may finish a deferred setup

  /// Most substeps one advance takes (SubstepPolicy::kMaxSubsteps).
  static constexpr float kMaxSubsteps = SubstepPolicy::kMaxSubsteps;

  /// Fastest a shape, slicer or curve may be given [m/s], refused where it is given: a
  /// speed that alone needs more than kMaxSubsteps substeps per simulated second, each
  /// moving it cflFor(solver) * dx.
  static float maxShapeSpeed(const SceneSettings& s) { return kMaxSubsteps * s.substeps.cflFor(s.solver) * s.dx; }

  /// Longest substep: the CFL bound on the fastest elastic wave plus the fastest particle
  /// or shape, and the solver's own stable step.
  float maxSubstep() const;

  /// Substep count for an advance of dt, unless the user fixed the count. Throws
  /// InvalidArgument, before anything changes, when that passes kMaxSubsteps.
  int substepCount(float dt) const;

 private:
  /// The fastest shape, slicer or curve point and the field that gives its speed.
  struct FastestShape {
    float speed = 0.f;
    const char* kind = nullptr;   ///< "shape", "slicer", "curve"; null: none moves
    size_t index = 0;
    const char* field = nullptr;  ///< e.g. "ShapeState.linearVelocity"
    int point = -1;               ///< a thread's point, or -1
  };
  FastestShape fastestShape() const;
  /// Names what bounds the substep: the fastest shape when its speed dominates, the
  /// stiffest material when its wave speed does or the solver's own step binds, else the
  /// fastest particle.
  [[noreturn]] void refuseSubsteps(float dt, float dtMax) const;
};

/// The constant inputs of each substep of length `dt` [s] under `settings`.
SubstepParams substepParams(const SceneSettings& settings, float dt);

}  // namespace mpm
