// Built instead of cuda_device.cu and methods/cuda_methods.cu when nvcc is absent: CUDA is then never available.
#include "system/sim_backend.h"

namespace mpm {

bool cudaDeviceAvailable() { return false; }
std::string cudaDeviceName() { return ""; }

std::unique_ptr<SimBackend> makeCudaBackend(const SceneSettings&, const GridGeometry&) {
  throw BackendUnavailable("the library was built without the CUDA backend (nvcc not found)");
}

}  // namespace mpm
