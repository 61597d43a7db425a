// Instantiates every solver's substep for the CUDA backend.
#include "backend/cuda/cuda_exec.cuh"
#include "solvers/solver_list.h"

namespace mpm {

bool cudaDeviceAvailable() {
  int count = 0;
  // no driver or no device both come back as an error code, never a crash
  if (cudaGetDeviceCount(&count) != cudaSuccess) {
    cudaGetLastError();  // clear the sticky error state
    return false;
  }
  return count > 0;
}

std::string cudaDeviceName() {
  if (!cudaDeviceAvailable()) return "";
  int device = 0;
  cudaDeviceProp prop{};
  if (cudaGetDevice(&device) != cudaSuccess || cudaGetDeviceProperties(&prop, device) != cudaSuccess) {
    cudaGetLastError();
    return "";
  }
  return prop.name;
}

std::unique_ptr<SimBackend> makeCudaBackend(const SceneSettings& settings, const GridGeometry& geo) {
  if (!cudaDeviceAvailable()) throw BackendUnavailable("no usable CUDA device in this process");
  return makeSolverBackend<CudaExec>(settings, geo);
}

}  // namespace mpm
