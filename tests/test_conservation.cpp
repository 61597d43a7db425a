// Conservation with gravity and walls off, for every solver: the transfers of all three
// conserve linear momentum exactly; MLS-MPM's APIC conserves angular momentum (Jiang et al.
// 2015), standard MPM and PB-MPM do not (per-solver bounds below).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "mpm/scene.h"
#include "solver_cases.h"

namespace mpm {
namespace {

SceneSettings freeSpace(SolverType solver) {
  SceneSettings s;
  s.solver = solver;
  s.domain.lower = {-1.f, -1.f, -1.f};
  s.domain.upper = {1.f, 1.f, 1.f};
  s.domain.walls = false;
  s.dx = 0.05f;
  s.gravity = {0.f, 0.f, 0.f};
  return s;
}

double magnitude(const double v[3]) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

class Conservation : public ::testing::TestWithParam<SolverType> {};

TEST_P(Conservation, LinearMomentumOver1000Substeps) {
  SceneSettings s = freeSpace(GetParam());
  s.substeps.fixedSubsteps = 10;
  Scene scene(s);
  ParticleObjectDesc d;
  d.halfExtents = {0.15f, 0.1f, 0.12f};
  d.velocity = {0.3f, -0.2f, 0.1f};
  d.angularVelocity = {1.f, 2.f, -1.5f};
  d.material.youngsModulus = 2e4f;
  d.material.poissonRatio = 0.3f;
  const ParticleObjectId id = scene.addParticleObject(d);
  const ObjectSummary before = scene.summary(id);
  for (int f = 0; f < 100; ++f) scene.step(0.002f);  // 1000 substeps of 2e-4 s
  const ObjectSummary after = scene.summary(id);
  const double p0 = magnitude(before.momentum);
  ASSERT_GT(p0, 0.0);
  double worst = 0;
  for (int a = 0; a < 3; ++a) worst = std::fmax(worst, std::abs(after.momentum[a] - before.momentum[a]) / p0);
  std::printf("%s: largest momentum change %.3g of |p0|\n", test::solverName(GetParam()).c_str(), worst);
  for (int a = 0; a < 3; ++a)
    EXPECT_LT(std::abs(after.momentum[a] - before.momentum[a]) / p0, 1e-4) << "axis " << a;
  EXPECT_NEAR(after.mass, before.mass, 1e-9 * before.mass);
}

TEST_P(Conservation, AngularMomentumOfSpinningBlockOverOneSecond) {
  SceneSettings s = freeSpace(GetParam());
  Scene scene(s);
  ParticleObjectDesc d;
  d.halfExtents = {0.2f, 0.1f, 0.1f};
  d.angularVelocity = {0.f, 0.f, 4.f};
  d.material.youngsModulus = 5e4f;
  d.material.poissonRatio = 0.3f;
  const ParticleObjectId id = scene.addParticleObject(d);
  const ObjectSummary before = scene.summary(id);
  const double L0 = before.angularMomentum[2];
  ASSERT_GT(L0, 0.0);
  int substeps = 0;
  for (int f = 0; f < 50; ++f) substeps += scene.step(0.02f).substeps;
  const ObjectSummary after = scene.summary(id);
  std::printf("%s: %d substeps; L_z change %.3g of L0, |L_x| %.3g, |L_y| %.3g\n", test::solverName(GetParam()).c_str(),
              substeps, std::abs(after.angularMomentum[2] - L0) / L0, std::abs(after.angularMomentum[0]) / L0,
              std::abs(after.angularMomentum[1]) / L0);
  EXPECT_GT(substeps, 50) << "CFL substepping is active";
  // Only MLS-MPM conserves L (APIC; measured 1.5e-6). PB-MPM's transfers are APIC, but
  // each iteration's per-particle constraint projection replaces C, spin included, without
  // balancing torques (Jacobi PBD does not conserve angular momentum): measured 14.1% lost
  // over 1 s in 88 substeps, bound 20%. Standard MPM has no affine field: every P2G drops
  // the particles' spin about their own positions and its 5% PIC share feeds the loss back
  // each substep, so the spin decays: measured 95.7% lost, checked for what remains true
  // of a dissipative transfer: L_z never grows and is not lost entirely (bound 99%). The
  // off-axis components (no spurious torque) hold to 1% for every solver.
  const double lz = after.angularMomentum[2];
  if (GetParam() == SolverType::StandardMpm) {
    EXPECT_LE(lz, L0 * (1 + 1e-4)) << "a dissipative transfer must not add spin";
    EXPECT_GT(lz, 0.01 * L0);
  } else {
    EXPECT_LT(std::abs(lz - L0) / L0, GetParam() == SolverType::PbMpm ? 0.20 : 0.01);
  }
  EXPECT_LT(std::abs(after.angularMomentum[0]) / L0, 0.01);
  EXPECT_LT(std::abs(after.angularMomentum[1]) / L0, 0.01);
}

INSTANTIATE_TEST_SUITE_P(AllSolvers, Conservation, test::allSolvers(), test::solverParamName());

}  // namespace
}  // namespace mpm
