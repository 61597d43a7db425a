// Whether this process has a CUDA device, and its name.
#include <cuda_runtime.h>

#include <string>

#include "mpm/scene.h"

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

}  // namespace mpm
