// The surgical tools' paths through the kernels, pinned: a block glued to a plate, cut by a
// quad blade coming down, a quarter needle turned into it and a kinematic thread drawn
// through it, with every grid solver. One and two threads give the same bits (the CPU path
// sums each node's contributions in one order), and the trajectory and the tools' impulses
// after 20 frames are hashed and pinned for x86-64 baseline builds (MPM_NATIVE_ARCH=OFF,
// as in test_determinism.cpp), so moving the tools' code cannot change their physics
// unseen.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <vector>

#include "mpm/scene.h"
#include "solver_cases.h"
#include "wound_gap.h"

namespace mpm {
namespace {

struct ToolRun {
  std::vector<Vec3f> x;        ///< the block's particles
  std::vector<Vec3f> impulse;  ///< blade, needle, thread, plate: linear then angular
};

ToolRun runToolScene(SolverType solver, int threads, int frames) {
  SceneSettings s;
  s.domain.lower = {-0.06f, -0.02f, -0.05f};
  s.domain.upper = {0.06f, 0.06f, 0.05f};
  s.dx = 0.005f;
  s.solver = solver;
  s.backend = Backend::Cpu;
  s.cpuThreads = threads;
  // PB-MPM's own substep (two a frame here) lets the blade's push reach 1.1 cells a
  // substep, which the divergence check refuses: eight a frame keep it under one
  if (solver == SolverType::PbMpm) s.substeps.fixedSubsteps = 8;
  Scene scene(s);
  ParticleObjectDesc block;
  block.center = {0.f, 0.01f, 0.f};
  block.halfExtents = {0.03f, 0.01f, 0.02f};  // 6 x 2 x 4 cm, 7.7k particles
  block.material.youngsModulus = 3e4f;
  block.material.poissonRatio = 0.4f;
  block.material.density = 1000.f;
  block.material.fractureToughness = 25.f;
  const ParticleObjectId id = scene.addParticleObject(block);
  const ShapeId plate = scene.addShape(test::basePlate());

  QuadSlicerDesc blade;  // across z at z = 12 mm, its edge coming down from 2.5 cm
  blade.halfLength = 0.04f;
  blade.width = 0.03f;
  blade.pose.position = {0.f, 0.025f, 0.012f};
  blade.linearVelocity = {0.f, -0.3f, 0.f};
  blade.spineRadius = 0.5f * s.dx;  // a blunt back that reaches the block in the last frames
  const SlicerId slicer = scene.addSlicer(blade);

  ArcDesc needle;  // a quarter needle whose tip, pointing down, enters the block's top
  needle.radius = 0.01f;
  needle.startAngle = 0.5f * 3.14159265f;
  needle.endAngle = 3.14159265f;
  needle.wireRadius = 0.25e-3f;
  needle.friction = 0.3f;
  needle.punctureForce = 0.03f;
  needle.pose.position = {0.f, 0.022f, -0.008f};
  needle.angularVelocity = {0.f, 0.f, 4.f};
  const CurveId arc = scene.addCurve(needle);

  LineSegmentsDesc thread;  // across the block at mid-height, drawn along z
  for (int i = 0; i <= 8; ++i) thread.points.push_back({-0.04f + 0.01f * i, 0.011f, -0.012f});
  thread.radius = 0.125e-3f;
  const CurveId line = scene.addCurve(thread);
  const std::vector<Vec3f> threadVelocity(thread.points.size(), Vec3f{0.f, 0.f, 0.02f});

  const float dt = 1.f / 120.f;
  ToolRun run;
  std::vector<Vec3f> points = thread.points;
  for (int f = 0; f < frames; ++f) {
    scene.setCurvePoints(line, points, threadVelocity);
    scene.step(dt);
    for (Vec3f& p : points) p += dt * threadVelocity[0];
  }
  scene.readPositions(id, run.x);
  for (ShapeImpulse i : {scene.slicerImpulse(slicer), scene.curveImpulse(arc), scene.curveImpulse(line),
                         scene.shapeImpulse(plate)}) {
    run.impulse.push_back(i.linear);
    run.impulse.push_back(i.angular);
  }
  return run;
}

uint64_t fnv1a(const std::vector<Vec3f>& x, uint64_t h = 1469598103934665603ull) {
  const auto* b = reinterpret_cast<const unsigned char*>(x.data());
  for (size_t i = 0; i < x.size() * sizeof(Vec3f); ++i) h = (h ^ b[i]) * 1099511628211ull;
  return h;
}

class ToolDeterminism : public ::testing::TestWithParam<SolverType> {};

// Each tool acts (its impulse is not zero), and 2 threads give the bits of 1.
TEST_P(ToolDeterminism, OneAndTwoThreadsBitIdenticalWithEveryTool) {
  const ToolRun a = runToolScene(GetParam(), 1, 20), b = runToolScene(GetParam(), 2, 20);
  ASSERT_EQ(a.x.size(), b.x.size());
  EXPECT_EQ(0, std::memcmp(a.x.data(), b.x.data(), a.x.size() * sizeof(Vec3f)));
  ASSERT_EQ(a.impulse.size(), b.impulse.size());
  EXPECT_EQ(0, std::memcmp(a.impulse.data(), b.impulse.data(), a.impulse.size() * sizeof(Vec3f)));
  const char* names[] = {"blade", "needle", "thread", "plate"};
  for (int t = 0; t < 4; ++t) {
    const Vec3f p = a.impulse[2 * t];
    std::printf("%s: %s impulse (%.3e, %.3e, %.3e) N s\n", test::solverName(GetParam()).c_str(), names[t], p.x, p.y, p.z);
    EXPECT_GT(norm(p), 0.f) << names[t] << " took no momentum from the tissue";
  }
}

TEST_P(ToolDeterminism, PinnedTrajectoryHash) {
#ifndef MPM_BASELINE_ISA
  GTEST_SKIP() << "built for this machine's instruction set (MPM_NATIVE_ARCH=ON); the pinned hashes are for "
                  "x86-64 baseline builds (MPM_NATIVE_ARCH=OFF), which scripts/sanitize.sh makes";
#endif
  const ToolRun r = runToolScene(GetParam(), 1, 20);
  const uint64_t h = fnv1a(r.impulse, fnv1a(r.x));
  std::printf("%s: tool trajectory hash 0x%016llx\n", test::solverName(GetParam()).c_str(), (unsigned long long)h);
  // PB-MPM's changed when material that touched a Bonded shape stayed glued to it
  // (push_out.h): the block's base on its glued plate (0x2604fbb6d22bb947 before). All
  // three changed when the needle's blunt tip came to hold the nodes within 1.5 dx of
  // its point (tools/tool_builder.h, kTipReach; 0xbac240bf07b4ddef, 0x7240387cd0d628e8,
  // 0xf774da1fa1dd5716 before)
  const uint64_t pinned = GetParam() == SolverType::MlsMpm        ? 0x0f082e43a68f62afull
                          : GetParam() == SolverType::StandardMpm ? 0x784d7433d88eb2daull
                                                                  : 0x883677b79a7c835eull;
  EXPECT_EQ(h, pinned) << "the trajectory changed: if the physics was meant to change, pin the new hash";
}

INSTANTIATE_TEST_SUITE_P(AllSolvers, ToolDeterminism, test::allSolvers(), test::solverParamName());

}  // namespace
}  // namespace mpm
