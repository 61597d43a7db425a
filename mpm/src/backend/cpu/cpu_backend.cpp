// Instantiates every solver's substep for the CPU backend.
#include "backend/cpu/cpu_exec.h"
#include "solvers/solver_list.h"

namespace mpm {

std::unique_ptr<SimBackend> makeCpuBackend(const SceneSettings& settings, const GridGeometry& geo) {
  return makeSolverBackend<CpuExec>(settings, geo, settings.cpuThreads);
}

}  // namespace mpm
