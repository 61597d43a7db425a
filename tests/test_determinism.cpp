// The CPU path colours grid blocks instead of using float atomics, so every node sums its
// contributions in the same order whatever the thread count: 1 and 2 threads must give
// bit-identical trajectories.
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "mpm/scene.h"
#include "scenes/standard_scenes.h"

namespace mpm {
namespace {

std::vector<Vec3f> runBenchScene(int threads, int frames) {
  Scene scene(scenes::CressimBench::settings(Backend::Cpu, threads));
  ParticleObjectDesc box = scenes::CressimBench::box(1.f);  // 8k particles
  box.angularVelocity = {0.5f, 1.f, 0.f};                   // exercise all directions
  const ParticleObjectId id = scene.addParticleObject(box);
  for (int f = 0; f < frames; ++f) scene.step(scenes::CressimBench::kFrameDt);
  std::vector<Vec3f> x;
  scene.readPositions(id, x);
  return x;
}

TEST(Determinism, OneAndTwoThreadsBitIdenticalOver200Substeps) {
  const std::vector<Vec3f> a = runBenchScene(1, 20), b = runBenchScene(2, 20);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a.size(), 8000u);
  EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3f)));
  // and the block actually moved (falling under gravity (0, -1, 0))
  double meanY = 0;
  for (const Vec3f& p : a) meanY += p.y;
  meanY /= a.size();
  EXPECT_LT(meanY, -0.05);
}

}  // namespace
}  // namespace mpm
