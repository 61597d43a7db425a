#pragma once
// The distances of the tools' parts, in their local frames: a quad blade's faces and a
// needle's wire.
#include "shapes/sdf_primitives.h"

namespace mpm {

/// A blade's faces (a slicer, mpm/slicers.h): the slab between the planes z = lo.z and
/// z = hi.z over the rectangle [lo.x, hi.x] x [lo.y, hi.y], seen from the side of its
/// mid-plane that p is on: |z - mid| - half-thickness, the normal toward p's side. Off the
/// rectangle there is no blade to push on (kNoSurface): its edge and sides cut material,
/// they do not push it ahead of them.
MPM_HD float sdfBladeFaces(Vec3f p, Vec3f lo, Vec3f hi, Vec3f& n) {
  const float z = p.z - 0.5f * (lo.z + hi.z);
  n = Vec3f{0.f, 0.f, z >= 0.f ? 1.f : -1.f};
  if (p.x < lo.x || p.x > hi.x || p.y < lo.y || p.y > hi.y) return kNoSurface;
  return fabsf(z) - 0.5f * (hi.z - lo.z);
}

/// Distance from p to the centre line of a circular arc of radius R about the origin in the
/// x-y plane, from angle a0 to a1 (a0 < a1 < a0 + 2 pi); `t` the unit tangent at the
/// nearest point (toward a1), `n` the unit direction from it to p; `beyond` whether the
/// nearest point is an end of the arc (p lies past it).
MPM_HD float arcLineDistance(Vec3f p, float R, float a0, float a1, Vec3f& n, Vec3f& t, bool& beyond) {
  float theta = atan2f(p.y, p.x);
  // the angle relative to a0 in [0, 2 pi)
  float rel = theta - a0;
  const float twoPi = 6.2831853f;
  rel -= twoPi * floorf(rel / twoPi);
  const float span = a1 - a0;
  float a = a0 + rel;
  beyond = false;
  if (rel > span) {  // past an end: the nearer one
    beyond = true;
    const Vec3f e0{R * cosf(a0), R * sinf(a0), 0.f}, e1{R * cosf(a1), R * sinf(a1), 0.f};
    a = dot(p - e0, p - e0) < dot(p - e1, p - e1) ? a0 : a1;
  }
  const float c = cosf(a), s = sinf(a);
  const Vec3f foot{R * c, R * s, 0.f};
  t = Vec3f{-s, c, 0.f};
  const Vec3f d = p - foot;
  const float len = norm(d);
  if (len > 1e-12f) {
    n = (1.f / len) * d;
  } else {  // on the centre line: any direction across it
    n = Vec3f{0.f, 0.f, 1.f};
  }
  return len;
}

}  // namespace mpm
