// Backend selection: CUDA without a device is a clear error, Auto falls back to the CPU,
// and where a GPU exists its trajectories match the CPU reference.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "mpm/scene.h"
#include "scenes/standard_scenes.h"

namespace mpm {
namespace {

TEST(Backend, CudaWithoutDeviceIsAClearError) {
  if (cudaDeviceAvailable()) GTEST_SKIP() << "a CUDA device is present";
  SceneSettings s = scenes::CressimBench::settings(Backend::Cuda);
  try {
    Scene scene(s);
    FAIL() << "expected BackendUnavailable";
  } catch (const BackendUnavailable& e) {
    EXPECT_NE(std::string(e.what()).find("Cuda"), std::string::npos) << e.what();
  }
}

TEST(Backend, AutoPicksCpuWithoutDevice) {
  if (cudaDeviceAvailable()) GTEST_SKIP() << "a CUDA device is present";
  Scene scene(scenes::CressimBench::settings(Backend::Auto));
  EXPECT_EQ(scene.backend(), Backend::Cpu);
  const ParticleObjectId id = scene.addParticleObject(scenes::CressimBench::box(0.5f));
  scene.step(scenes::CressimBench::kFrameDt);
  EXPECT_EQ(scene.particleCount(id), 1000u);
}

TEST(Backend, CudaMatchesCpuOnBenchScene) {
  if (!cudaDeviceAvailable()) GTEST_SKIP() << "no CUDA device: GPU comparison skipped";
  std::vector<Vec3f> out[2];
  const Backend backends[2] = {Backend::Cpu, Backend::Cuda};
  for (int b = 0; b < 2; ++b) {
    Scene scene(scenes::CressimBench::settings(backends[b]));
    const ParticleObjectId id = scene.addParticleObject(scenes::CressimBench::box(1.f));
    for (int f = 0; f < 20; ++f) scene.step(scenes::CressimBench::kFrameDt);
    scene.readPositions(id, out[b]);
  }
  ASSERT_EQ(out[0].size(), out[1].size());
  // atomics change the summation order: agreement to float rounding, not bits
  double worst = 0;
  for (size_t i = 0; i < out[0].size(); ++i) worst = std::max(worst, (double)norm(out[0][i] - out[1][i]));
  EXPECT_LT(worst, 1e-4);
}

}  // namespace
}  // namespace mpm
