#include "scenes/standard_scenes.h"

namespace mpm::scenes {

SceneSettings CressimBench::settings(Backend backend, int threads) {
  SceneSettings s;
  s.domain.lower = {-5.5f, -5.5f, -5.5f};
  s.domain.upper = {5.5f, 5.5f, 5.5f};
  s.domain.wallMode = WallMode::Separate;
  s.dx = 0.2f;
  s.gravity = {0.f, -1.f, 0.f};
  s.substeps.fixedSubsteps = kSubstepsPerFrame;
  s.backend = backend;
  s.cpuThreads = threads;
  return s;
}

ParticleObjectDesc CressimBench::box(float halfSize) {
  ParticleObjectDesc d;
  d.primitive = PrimitiveType::Box;
  d.center = {0.f, 0.f, 0.f};
  d.halfExtents = {halfSize, halfSize, halfSize};
  d.particleSpacing = 0.1f;
  d.material.model = MaterialModel::FixedCorotated;
  d.material.youngsModulus = 5e5f;
  d.material.poissonRatio = 0.4f;
  d.material.density = 10.f / (0.1f * 0.1f * 0.1f);  // mass 10 per particle
  return d;
}

SceneSettings BlockDrop::settings() {
  SceneSettings s;
  s.domain.lower = {-1.f, 0.f, -1.f};
  s.domain.upper = {1.f, 2.f, 1.f};
  s.domain.wallMode = WallMode::Separate;
  s.dx = 1.f / 32.f;
  s.gravity = {0.f, -9.81f, 0.f};
  return s;
}

ParticleObjectDesc BlockDrop::block() {
  ParticleObjectDesc d;
  d.center = {0.f, 1.2f, 0.f};
  d.halfExtents = {0.25f, 0.15f, 0.2f};
  d.velocity = {0.3f, 0.f, 0.f};
  d.angularVelocity = {0.f, 0.f, 1.5f};
  d.material.model = MaterialModel::NeoHookeanDecoupled;
  d.material.youngsModulus = 4e4f;
  d.material.poissonRatio = 0.35f;
  d.material.density = 1000.f;
  return d;
}

}  // namespace mpm::scenes
