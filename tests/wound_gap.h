#pragma once
// The suturing tests' tissue: their grid and blocks, and the wound, two tissue blocks side
// by side, a gap across x between them, glued to a plate at their bases.
#include <algorithm>
#include <vector>

#include "mpm/scene.h"
#include "mpm/shapes.h"

namespace mpm::test {

/// The plate the suturing tests' blocks are glued to at their bases (Bonded).
inline ShapeDesc basePlate() {
  ShapeDesc d;
  d.parts.push_back(Geometry::box({0.05f, 0.005f, 0.05f}));
  d.pose.position = {0.f, -0.005f, 0.f};
  d.contact.mode = ContactMode::Bonded;
  return d;
}

/// Width of the gap between two blocks' facing sides over their upper half (y > 1 cm) [m]:
/// the right block's leftmost particle there minus the left block's rightmost.
inline float woundGap(const Scene& scene, ParticleObjectId left, ParticleObjectId right) {
  std::vector<Vec3f> a, b;
  scene.readPositions(left, a);
  scene.readPositions(right, b);
  float inner = -1.f, outer = 1.f;
  for (const Vec3f& x : a)
    if (x.y > 0.01f) inner = std::max(inner, x.x);
  for (const Vec3f& x : b)
    if (x.y > 0.01f) outer = std::min(outer, x.x);
  return outer - inner;
}

/// The suturing tests' scene: a grid of 2.5 mm cells round a block (the demo's), gravity off.
inline SceneSettings threadTissueSettings() {
  SceneSettings settings;
  settings.domain.lower = {-0.04f, -0.02f, -0.02f};
  settings.domain.upper = {0.04f, 0.04f, 0.02f};
  settings.dx = 0.0025f;
  settings.gravity = {0.f, 0.f, 0.f};
  settings.backend = Backend::Cpu;
  return settings;
}

/// A tissue block of half extents `half` at `center` (E, nu, rho).
inline ParticleObjectDesc tissueBlock(Vec3f half, Vec3f center, float E, float nu, float rho) {
  ParticleObjectDesc block;
  block.center = center;
  block.halfExtents = half;
  block.material.youngsModulus = E;
  block.material.poissonRatio = nu;
  block.material.density = rho;
  return block;
}

}  // namespace mpm::test
