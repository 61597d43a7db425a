#pragma once
// The suturing tests' wound: two tissue blocks side by side, a gap across x between them.
#include <algorithm>
#include <vector>

#include "mpm/scene.h"

namespace mpm::test {

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
