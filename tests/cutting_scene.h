#pragma once
// The cutting tests' scene: an 8 x 4 x 6 cm block of soft tissue centred at the origin in a
// 20 cm box without gravity, dx = 1 cm, and a curved blade (a strip of a cylinder).
#include <cmath>

#include "mpm/scene.h"

namespace mpm::test {

constexpr float kCutDx = 0.01f;
/// The block's half-extents; blades cut it across z.
const Vec3f kBlockHalf{0.04f, 0.02f, 0.03f};

inline SceneSettings cuttingSettings(SolverType solver) {
  SceneSettings s;
  s.domain.lower = {-0.1f, -0.1f, -0.1f};
  s.domain.upper = {0.1f, 0.1f, 0.1f};
  s.dx = kCutDx;
  s.gravity = {0.f, 0.f, 0.f};
  s.solver = solver;
  s.backend = Backend::Cpu;
  return s;
}

/// The block: E 20 kPa, nu 0.3, 1000 kg/m^3.
inline ParticleObjectDesc cutBlock() {
  ParticleObjectDesc d;
  d.center = {0.f, 0.f, 0.f};
  d.halfExtents = kBlockHalf;
  d.material.youngsModulus = 2e4f;
  d.material.poissonRatio = 0.3f;
  d.material.density = 1000.f;
  return d;
}

// A curved blade: part of a cylinder of radius kArcRadius about the vertical axis through
// (0, ., kArcCentreZ), from angle -50 to +50 degrees (x = R sin a, z = zc + R cos a), in
// `facets` facets, its edge at y = 0 and its top 10 cm above (no spine). Through the block
// it bows 1.4 cm: z = 5 mm at x = 0, -8.8 mm at the block's sides.
constexpr float kArcRadius = 0.065f, kArcCentreZ = -0.06f;
inline MeshSlicerDesc arcBlade(float edgeY, Vec3f velocity = {0.f, 0.f, 0.f}, int facets = 24) {
  MeshSlicerDesc d;
  for (int i = 0; i <= facets; ++i) {
    const float a = (-50.f + 100.f * (float)i / (float)facets) * 3.14159265f / 180.f;
    for (float y : {0.f, 0.1f}) d.blade.vertices.push_back({kArcRadius * std::sin(a), y, kArcCentreZ + kArcRadius * std::cos(a)});
  }
  for (uint32_t i = 0; i < (uint32_t)facets; ++i) {
    const uint32_t a = 2 * i, b = 2 * i + 1, c = 2 * i + 2, e = 2 * i + 3;
    for (uint32_t v : {a, c, b, b, c, e}) d.blade.indices.push_back(v);
  }
  d.spineRadius = 0.f;
  d.pose.position = {0.f, edgeY, 0.f};
  d.linearVelocity = velocity;
  return d;
}

}  // namespace mpm::test
