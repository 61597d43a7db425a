// The CPU path colours grid blocks instead of using float atomics, so every node sums its
// contributions in the same order whatever the thread count: 1 and 2 threads must give
// bit-identical trajectories, with every solver.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <vector>

#include "mpm/scene.h"
#include "scenes/standard_scenes.h"
#include "solver_cases.h"

namespace mpm {
namespace {

std::vector<Vec3f> runBenchScene(SolverType solver, int threads, int frames) {
  SceneSettings s = scenes::CressimBench::settings(Backend::Cpu, threads);
  s.solver = solver;
  // PB-MPM runs `iterations` (10) P2G/G2P cycles per substep and is made for large steps:
  // one substep per frame gives it the 200 cycles the others make in 200 substeps (10x
  // the test's time otherwise, 17 s).
  if (solver == SolverType::PbMpm) s.substeps.fixedSubsteps = 1;
  Scene scene(s);
  ParticleObjectDesc box = scenes::CressimBench::box(1.f);  // 8k particles
  box.angularVelocity = {0.5f, 1.f, 0.f};                   // exercise all directions
  const ParticleObjectId id = scene.addParticleObject(box);
  for (int f = 0; f < frames; ++f) scene.step(scenes::CressimBench::kFrameDt);
  std::vector<Vec3f> x;
  scene.readPositions(id, x);
  return x;
}

class Determinism : public ::testing::TestWithParam<SolverType> {};

TEST_P(Determinism, OneAndTwoThreadsBitIdenticalOver20Frames) {
  const std::vector<Vec3f> a = runBenchScene(GetParam(), 1, 20), b = runBenchScene(GetParam(), 2, 20);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a.size(), 8000u);
  EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3f)));
  // and the block actually moved (falling under gravity (0, -1, 0))
  double meanY = 0;
  for (const Vec3f& p : a) meanY += p.y;
  meanY /= a.size();
  std::printf("%s: mean height after 20 frames %.4f m\n", test::solverName(GetParam()).c_str(), meanY);
  EXPECT_LT(meanY, -0.05);
}

INSTANTIATE_TEST_SUITE_P(AllSolvers, Determinism, test::allSolvers(), test::solverParamName());

}  // namespace
}  // namespace mpm
