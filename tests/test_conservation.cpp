// Conservation with gravity and walls off: MLS-MPM's transfers conserve linear momentum
// exactly and APIC conserves angular momentum (Jiang et al. 2015).
#include <gtest/gtest.h>

#include <cmath>

#include "mpm/scene.h"

namespace mpm {
namespace {

SceneSettings freeSpace() {
  SceneSettings s;
  s.domain.lower = {-1.f, -1.f, -1.f};
  s.domain.upper = {1.f, 1.f, 1.f};
  s.domain.walls = false;
  s.dx = 0.05f;
  s.gravity = {0.f, 0.f, 0.f};
  return s;
}

double magnitude(const double v[3]) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

TEST(Conservation, LinearMomentumOver1000Substeps) {
  SceneSettings s = freeSpace();
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
  for (int a = 0; a < 3; ++a)
    EXPECT_LT(std::abs(after.momentum[a] - before.momentum[a]) / p0, 1e-4) << "axis " << a;
  EXPECT_NEAR(after.mass, before.mass, 1e-9 * before.mass);
}

TEST(Conservation, AngularMomentumOfSpinningBlockOverOneSecond) {
  SceneSettings s = freeSpace();
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
  EXPECT_GT(substeps, 50) << "CFL substepping is active";
  EXPECT_LT(std::abs(after.angularMomentum[2] - L0) / L0, 0.01);
  EXPECT_LT(std::abs(after.angularMomentum[0]) / L0, 0.01);
  EXPECT_LT(std::abs(after.angularMomentum[1]) / L0, 0.01);
}

}  // namespace
}  // namespace mpm
