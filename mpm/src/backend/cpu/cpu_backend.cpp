// Instantiates every solver's substep for the CPU backend.
#include "backend/cpu/cpu_exec.h"
#include "solvers/solver_list.h"

namespace mpm {

std::unique_ptr<SimBackend> makeCpuBackend(SolverType solver, const GridGeometry& geo, int threads) {
  return makeParticleGridSystem<CpuExec>(solver, geo, threads);
}

}  // namespace mpm
