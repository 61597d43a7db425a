// Instantiates every method's substep for the CPU backend: the one place the CPU execution
// backend and the solvers meet.
#include "backend/cpu/cpu_exec.h"
#include "solvers/solver_list.h"

namespace mpm {

// the sort's fast paths (ParticleGridSystem::saveStateAndSort): a trait that stops
// detecting its member would fall back silently to the GPU's way
static_assert(GathersByField<CpuExec>::value, "CpuExec gathers a field per thread");
static_assert(KeepsBinning<CpuExec>::value, "CpuExec keeps the sort's binning for the first substep");

std::unique_ptr<SimBackend> makeCpuBackend(const SceneSettings& settings, const GridGeometry& geo) {
  return makeSolverBackend<CpuExec>(settings, geo, settings.cpuThreads);
}

}  // namespace mpm
