#pragma once
// A bound on a part's distance at a point, for skipping parts without taking it.
#include "tools/needle.h"

namespace mpm {

/// Whether part `q`'s distance at x (PartView::distance) is surely greater than `phi`,
/// without taking it: a part with a Euclidean distance lies inside its push-out box, so its
/// distance at x is at least x's distance to that box; the slack covers the rounding of
/// both (of the part's box, placed in floats, and of its distance). A needle's arc: its
/// circle's tube (arcLowerDistance).
MPM_HD bool surelyFartherThan(const PartView& q, Vec3f x, float phi) {
  if (q.type == kPartArc) return arcLowerDistance(q, x) > phi;
  if (!q.lipschitzDistance()) return false;
  const float d2 = squaredGap(x, x, q.pushLower, q.pushUpper);  // NaN bounds: 0, never skipped
  if (!(d2 > 0.f)) return false;  // x in the box: the part may be nearer than anything
  const float box = sqrtf(d2);
  const float slack = 1e-5f * (fabsf(x.x) + fabsf(x.y) + fabsf(x.z) + fabsf(phi) + box);
  return box - slack > phi;
}

}  // namespace mpm
