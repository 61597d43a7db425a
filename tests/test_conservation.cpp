// Conservation with gravity and walls off, for every solver: the transfers of all three
// conserve linear momentum exactly; MLS-MPM's APIC conserves angular momentum (Jiang et al.
// 2015), standard MPM and PB-MPM do not (per-solver bounds below).
#include <gtest/gtest.h>

#include <algorithm>
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

// ---- Seed 004 sections 4.6-4.8: the cylinder's energy balance and its spin ------------

namespace seed {

constexpr double kRadius = 0.05, kHeight = 0.1, kMu = 1007.0, kBulk = 50001.333;
constexpr double kPi = 3.14159265358979;

SceneSettings cylinderSettings(SolverType solver, float dx) {
  SceneSettings s;
  s.solver = solver;
  s.domain = {{-0.12f, -0.06f, -0.12f}, {0.12f, 0.16f, 0.12f}};
  s.domain.walls = false;
  s.dx = dx;
  s.gravity = {0.f, 0.f, 0.f};
  s.backend = Backend::Cpu;
  return s;
}

/// The seed's cylinder (axis y, bottom face at y = 0): decoupled Neo-Hookean mu, K.
ParticleObjectDesc cylinder(float spacing) {
  ParticleObjectDesc c;
  c.primitive = PrimitiveType::Cylinder;
  c.center = {0.f, (float)kHeight / 2, 0.f};
  c.radius = (float)kRadius;
  c.halfExtents = {0.f, (float)kHeight / 2, 0.f};
  c.particleSpacing = spacing;
  c.material = {MaterialModel::NeoHookeanDecoupled, (float)(9 * kBulk * kMu / (3 * kBulk + kMu)),
                (float)((3 * kBulk - 2 * kMu) / (2 * (3 * kBulk + kMu))), 1000.f};
  return c;
}

double smoothRamp(double s) {
  s = std::min(std::max(s, 0.0), 1.0);
  return (10 - 15 * s + 6 * s * s) * s * s * s;
}

class SeedCylinder : public ::testing::TestWithParam<SolverType> {};

// Section 4.7: the work the plates do compressing the cylinder is stored as strain energy.
// Slip ends, 20 % in 1 s (eq. 43 ramp), held 0.2 s. Each frame's work is the plate's
// impulse times its mean velocity (Scene's energy account); the stored energy is sum V0
// W(F) of the particles (MLS-MPM, standard MPM) or of MTLED's integration points. PB-MPM's
// forces do not derive from a W(F) it could report, so it has no energy to compare.
TEST_P(SeedCylinder, CompressionWorkIsStoredAsStrainEnergy) {
  const SolverType solver = GetParam();
  if (solver == SolverType::PbMpm) GTEST_SKIP() << "PB-MPM reports no stored elastic energy";
  const bool meshless = solver == SolverType::Mtled;
  const float dx = 0.01f;
  SceneSettings s = cylinderSettings(solver, dx);
  s.energyCheck.enabled = true;
  Scene scene(s);
  scene.addParticleObject(cylinder(meshless ? dx : 0.f));
  ShapeDesc plate;
  Geometry box;
  box.type = GeometryType::Box;
  box.halfExtents = {0.11f, 0.02f, 0.11f};
  plate.parts = {box};
  plate.contact.mode = ContactMode::Frictional;
  // MTLED's end nodes lie on the faces; the grid's nearest node layer to a face holds it
  plate.contact.band = meshless ? 0.1f * dx : 0.5f * dx;
  plate.pose.position = {0.f, -0.02f, 0.f};
  scene.addShape(plate);
  plate.pose.position = {0.f, (float)kHeight + 0.02f, 0.f};
  const ShapeId top = scene.addShape(plate);

  const double ramp = 1.0, hold = 0.2, frame = 0.01, travel = 0.2 * kHeight;
  EnergyBalance e;
  for (int f = 0; f * frame < ramp + hold - 1e-9; ++f) {
    const double t = f * frame;
    ShapeState st;
    st.pose.position = {0.f, (float)(kHeight + 0.02 - travel * smoothRamp(t / ramp)), 0.f};
    st.linearVelocity = {0.f, (float)(-travel * (smoothRamp((t + frame) / ramp) - smoothRamp(t / ramp)) / frame), 0.f};
    scene.setShapeState(top, st);
    e = scene.step((float)frame).energy;
  }
  const double stored = e.kinetic + e.strain;
  std::printf("%s: plate work %.5g J, strain %.5g J, kinetic %.3g J; (strain + kinetic) / work - 1 = %+.3f %%\n",
              test::solverName(solver).c_str(), e.work, e.strain, e.kinetic, 100 * (stored / e.work - 1));
  ASSERT_GT(e.work, 0.03);  // the closed form stores about 0.052 J at 20 %
  // measured: MLS-MPM -0.44 %, standard MPM -1.16 % (grid transfers dissipate a little),
  // MTLED +0.14 %; the seed's goal is 2 %
  EXPECT_LT(std::abs(stored / e.work - 1), 0.02);
}

// Section 4.8: the cylinder spun about its axis at 1 Hz for 20 s, no load: angular
// momentum about the axis kept. MTLED's central differences with torque-free point forces
// (P F^T is symmetric) and MLS-MPM's APIC transfers conserve it; standard MPM's and
// PB-MPM's transfers lose it (see the spinning block above). Grid solvers at dx = 1.25 cm
// (R = 4 cells, 3.2k particles; 1 cm costs 105 s per solver for the same answer).
TEST_P(SeedCylinder, AngularMomentumOfA1HzSpinOver20s) {
  const SolverType solver = GetParam();
  const bool meshless = solver == SolverType::Mtled;
  const float dx = meshless ? 0.01f : 0.0125f;
  Scene scene(cylinderSettings(solver, dx));
  ParticleObjectDesc c = cylinder(meshless ? dx : 0.f);
  c.angularVelocity = {0.f, (float)(2 * kPi), 0.f};
  const ParticleObjectId id = scene.addParticleObject(c);
  // MTLED replaces the lattice's node masses by its lumped ones (seed 004 section 2.5) when
  // it builds its model, on the first step or on this query: L0 is taken in those masses
  scene.maxSubstep();
  const double L0 = scene.summary(id).angularMomentum[1];
  ASSERT_GT(L0, 0.0);
  long substeps = 0;
  for (int f = 0; f < 200; ++f) substeps += scene.step(0.1f).substeps;
  const ObjectSummary after = scene.summary(id);
  const double loss = 1 - after.angularMomentum[1] / L0;
  std::printf("%s: %zu particles, %ld substeps; L0 %.5g kg m^2/s (uniform cylinder: %.5g); L_y lost %.3g of L0 over "
              "20 s; |L_x|, |L_z| %.3g, %.3g of L0\n",
              test::solverName(solver).c_str(), after.particles, substeps, L0,
              0.5 * 1000 * kPi * std::pow(kRadius, 4) * kHeight * 2 * kPi, loss,
              std::abs(after.angularMomentum[0]) / L0, std::abs(after.angularMomentum[2]) / L0);
  // measured: MTLED -3.3e-7 (1 cm), MLS-MPM 1.3e-5 (1.25 cm; 1.1e-4 at 1 cm), standard MPM
  // 1.0 (all of it: its transfers drop each particle's spin about itself every substep),
  // PB-MPM 0.87 (each iteration's projection replaces C without balancing torques)
  const double bound = solver == SolverType::StandardMpm ? 1.0 + 1e-3 : solver == SolverType::PbMpm ? 0.9 : 0.01;
  EXPECT_LT(loss, bound);
  EXPECT_GT(loss, -0.01) << "no transfer may add spin";
  EXPECT_LT(std::abs(after.angularMomentum[0]) / L0, 0.01);
  EXPECT_LT(std::abs(after.angularMomentum[2]) / L0, 0.01);
}

INSTANTIATE_TEST_SUITE_P(AllSolvers, SeedCylinder,
                         ::testing::Values(SolverType::MlsMpm, SolverType::StandardMpm, SolverType::PbMpm,
                                           SolverType::Mtled),
                         test::solverParamName());

}  // namespace seed

}  // namespace
}  // namespace mpm
