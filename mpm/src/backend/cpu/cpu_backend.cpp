// Instantiates the substep for the CPU backend.
#include "backend/cpu/cpu_exec.h"
#include "backend/particle_grid_system.h"

namespace mpm {

std::unique_ptr<SimBackend> makeCpuBackend(const GridGeometry& geo, int threads) {
  return std::make_unique<ParticleGridSystem<CpuExec>>(geo, threads);
}

}  // namespace mpm
