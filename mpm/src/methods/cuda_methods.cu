// Instantiates every method's substep for the CUDA backend: the one place the CUDA
// execution backend and the solvers meet.
#include "backend/cuda/cuda_exec.cuh"
#include "solvers/solver_list.h"

namespace mpm {

std::unique_ptr<SimBackend> makeCudaBackend(const SceneSettings& settings, const GridGeometry& geo) {
  if (!cudaDeviceAvailable()) throw BackendUnavailable("no usable CUDA device in this process");
  return makeSolverBackend<CudaExec>(settings, geo);
}

}  // namespace mpm
