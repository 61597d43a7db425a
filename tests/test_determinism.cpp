// The CPU path colours grid blocks instead of using float atomics, so every node sums its
// contributions in the same order whatever the thread count: 1 and 2 threads must give
// bit-identical trajectories, with every solver. And a pinned hash of one trajectory per
// solver, so a change that alters the physics shows.
#include <gtest/gtest.h>

#include <cstdint>
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

/// FNV-1a of the bytes of `x`.
uint64_t fnv1a(const std::vector<Vec3f>& x) {
  uint64_t h = 1469598103934665603ull;
  const auto* b = reinterpret_cast<const unsigned char*>(x.data());
  for (size_t i = 0; i < x.size() * sizeof(Vec3f); ++i) h = (h ^ b[i]) * 1099511628211ull;
  return h;
}

// The positions after 20 frames of the bench scene (one thread), hashed and pinned. The
// bits depend on the instruction set the library is compiled for (with FMA the compiler
// contracts a * b + c), so the values hold for builds for the x86-64 baseline
// (MPM_NATIVE_ARCH=OFF, as the sanitizer tree of scripts/sanitize.sh is built: no FMA, the
// same bits at -O1 and -O3). A change that alters the physics changes them: say why in
// its commit and pin the new values it prints.
TEST_P(Determinism, PinnedTrajectoryHash) {
#ifndef MPM_BASELINE_ISA
  GTEST_SKIP() << "built for this machine's instruction set (MPM_NATIVE_ARCH=ON); the pinned hashes are for "
                  "x86-64 baseline builds (MPM_NATIVE_ARCH=OFF), which scripts/sanitize.sh makes";
#endif
  const uint64_t h = fnv1a(runBenchScene(GetParam(), 1, 20));
  std::printf("%s: trajectory hash 0x%016llx\n", test::solverName(GetParam()).c_str(), (unsigned long long)h);
  const uint64_t pinned = GetParam() == SolverType::MlsMpm        ? 0xdfb7d9c24099f0daull
                          : GetParam() == SolverType::StandardMpm ? 0x9cd6dbd94161b758ull
                                                                  : 0x40a06548d7c9850eull;
  EXPECT_EQ(h, pinned) << "the trajectory changed: if the physics was meant to change, pin the new hash";
}

INSTANTIATE_TEST_SUITE_P(AllSolvers, Determinism, test::allSolvers(), test::solverParamName());

}  // namespace
}  // namespace mpm
