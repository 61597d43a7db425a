// Backend selection: CUDA without a device is a clear error, Auto falls back to the CPU,
// and where a GPU exists its trajectories match the CPU reference.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "mpm/scene.h"
#include "scenes/standard_scenes.h"
#include "solver_cases.h"

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

TEST(Backend, AutoPicksCudaWithDevice) {
  if (!cudaDeviceAvailable()) GTEST_SKIP() << "no CUDA device: nothing to pick";
  Scene scene(scenes::CressimBench::settings(Backend::Auto));
  EXPECT_EQ(scene.backend(), Backend::Cuda);
}

// Each solver on both backends: the bench box falling for 20 frames (0.4 s) while a
// kinematic sphere, starting 5 cm above it at 1 m/s, presses into its top, so the
// transfers, the constitutive update, the contact pass and the shape's impulse sums all run
// on the GPU. Atomics change the summation order: agreement to float rounding, not bits.
class BackendMatch : public ::testing::TestWithParam<SolverType> {};

TEST_P(BackendMatch, CudaMatchesCpu) {
  if (!cudaDeviceAvailable()) GTEST_SKIP() << "no CUDA device: GPU comparison skipped";
  std::vector<Vec3f> x[2];
  double impulse[2] = {0, 0};  // the sphere's, summed over the frames [N s]
  const Backend backends[2] = {Backend::Cpu, Backend::Cuda};
  for (int b = 0; b < 2; ++b) {
    SceneSettings s = scenes::CressimBench::settings(backends[b]);
    s.solver = GetParam();
    Scene scene(s);
    const ParticleObjectId id = scene.addParticleObject(scenes::CressimBench::box(1.f));
    ShapeDesc press;
    press.parts = {Geometry::sphere(0.5f)};
    press.pose.position = {0.f, 1.55f, 0.f};
    press.linearVelocity = {0.f, -1.f, 0.f};
    const ShapeId sphere = scene.addShape(press);  // kinematic: moves on at 1 m/s
    for (int f = 0; f < 20; ++f) {
      scene.step(scenes::CressimBench::kFrameDt);
      impulse[b] += scene.shapeImpulse(sphere).linear.y;
    }
    scene.readPositions(id, x[b]);
  }
  ASSERT_EQ(x[0].size(), x[1].size());
  double worst = 0;
  for (size_t i = 0; i < x[0].size(); ++i) worst = std::max(worst, (double)norm(x[0][i] - x[1][i]));
  std::printf("%s: worst position difference %.3g m; impulse on the sphere CPU %.7g, GPU %.7g N s\n",
              test::solverName(GetParam()).c_str(), worst, impulse[0], impulse[1]);
  EXPECT_LT(worst, 1e-4) << "m, over a box 2 m wide";
  EXPECT_GT(impulse[0], 0.0) << "the sphere presses on the box";
  EXPECT_NEAR(impulse[1], impulse[0], 1e-3 * std::fabs(impulse[0]));
}

INSTANTIATE_TEST_SUITE_P(AllSolvers, BackendMatch,
                         test::everySolver(),
                         test::solverParamName());

}  // namespace
}  // namespace mpm
