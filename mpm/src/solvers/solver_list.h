#pragma once
// The particle-grid solvers, by SolverType: the one place a new solver is registered.
// Included by each backend's translation unit, which instantiates every solver for its
// execution backend.
#include <memory>

#include "backend/particle_grid_system.h"
#include "solvers/mls_mpm.h"
#include "solvers/pb_mpm.h"
#include "solvers/standard_mpm.h"

namespace mpm {

template <class Exec, class... ExecArgs>
std::unique_ptr<SimBackend> makeParticleGridSystem(SolverType solver, const GridGeometry& geo,
                                                   ExecArgs&&... execArgs) {
  switch (solver) {
    case SolverType::MlsMpm:
      return std::make_unique<ParticleGridSystem<Exec, MlsMpm>>(geo, std::forward<ExecArgs>(execArgs)...);
    case SolverType::StandardMpm:
      return std::make_unique<ParticleGridSystem<Exec, StandardMpm>>(geo, std::forward<ExecArgs>(execArgs)...);
    case SolverType::PbMpm:
      return std::make_unique<ParticleGridSystem<Exec, PbMpm>>(geo, std::forward<ExecArgs>(execArgs)...);
  }
  throw InvalidArgument("SceneSettings.solver", std::to_string(static_cast<int>(solver)), "is not a solver");
}

/// What the Scene needs to know of a solver.
struct SolverTraits {
  bool elasticCfl;  ///< the elastic wave speed limits the substep (explicit in time)
  bool affine;      ///< particles carry an APIC affine field C (its spin counts in L)
};

template <class Method>
constexpr SolverTraits traitsOf() {
  return {Method::kElasticCfl, Method::kAffine};
}

inline SolverTraits solverTraits(SolverType solver) {
  switch (solver) {
    case SolverType::MlsMpm: return traitsOf<MlsMpm>();
    case SolverType::StandardMpm: return traitsOf<StandardMpm>();
    case SolverType::PbMpm: return traitsOf<PbMpm>();
  }
  return traitsOf<MlsMpm>();
}

}  // namespace mpm
