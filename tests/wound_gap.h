#pragma once
// The suturing tests' wound: two tissue blocks side by side, a gap across x between them,
// glued to a plate at their bases.
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

}  // namespace mpm::test
