#pragma once
// The solvers, by SolverType: the one place a new solver is registered. Included by each
// backend's methods file (methods/), which instantiates every solver for its execution backend.
#include <memory>

#include "system/particle_grid_system.h"
#include "solvers/mls_mpm.h"
#include "solvers/mtled.h"
#include "solvers/pb_mpm.h"
#include "solvers/standard_mpm.h"

namespace mpm {

/// The backend that runs `settings.solver`: a particle-grid system for the MPM solvers, a
/// system of its own for a solver without the MPM grid.
template <class Exec, class... ExecArgs>
std::unique_ptr<SimBackend> makeSolverBackend(const SceneSettings& settings, const GridGeometry& geo,
                                              ExecArgs&&... execArgs) {
  switch (settings.solver) {
    case SolverType::MlsMpm:
      return std::make_unique<ParticleGridSystem<Exec, MlsMpm>>(geo, std::forward<ExecArgs>(execArgs)...);
    case SolverType::StandardMpm:
      return std::make_unique<ParticleGridSystem<Exec, StandardMpm>>(geo, std::forward<ExecArgs>(execArgs)...);
    case SolverType::PbMpm:
      return std::make_unique<ParticleGridSystem<Exec, PbMpm>>(geo, std::forward<ExecArgs>(execArgs)...);
    case SolverType::Mtled:
      return std::make_unique<MtledSystem<Exec>>(settings.mtled, std::forward<ExecArgs>(execArgs)...);
  }
  throw InvalidArgument("SceneSettings.solver", std::to_string(static_cast<int>(settings.solver)),
                        "is not a solver");
}

/// What the Scene needs to know of a solver.
struct SolverTraits {
  bool elasticCfl;  ///< the elastic wave speed limits the substep through the grid's CFL bound
  bool affine;      ///< particles carry an APIC affine field C (its spin counts in L)
  /// the particles are nodes of a meshless discretisation: placed on the object's bounds,
  /// with background integration cells (SimBackend::appendIntegrationCells)
  bool meshless;
};

template <class Method>
constexpr SolverTraits traitsOf() {
  return {Method::kElasticCfl, Method::kAffine, false};
}

inline SolverTraits solverTraits(SolverType solver) {
  switch (solver) {
    case SolverType::MlsMpm: return traitsOf<MlsMpm>();
    case SolverType::StandardMpm: return traitsOf<StandardMpm>();
    case SolverType::PbMpm: return traitsOf<PbMpm>();
    // its own critical step (SimBackend::stableTimeStep) replaces the grid's CFL bound
    case SolverType::Mtled: return {false, false, true};
  }
  return traitsOf<MlsMpm>();
}

}  // namespace mpm
