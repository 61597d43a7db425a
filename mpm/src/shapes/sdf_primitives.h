#pragma once
// Signed distances (negative inside) and outward unit normals of the primitive geometries,
// in their local frames, as host/device functions. Plane: solid below y = 0. Box, capsule
// and cylinder also take their extent as two ends (faces) in a frame placed anywhere, so a
// large one is evaluated with small numbers near the point asked about.
#include "mpm/math.h"

namespace mpm {

MPM_HD float sdfPlane(Vec3f p, Vec3f& n) {
  n = Vec3f{0.f, 1.f, 0.f};
  return p.y;
}

MPM_HD float sdfSphere(Vec3f p, float r, Vec3f& n) {
  const float d = norm(p);
  n = d > 1e-12f ? (1.f / d) * p : Vec3f{0.f, 1.f, 0.f};
  return d - r;
}

/// Distance of coordinate t outside the slab [lo, hi] (negative inside: minus the distance
/// to the nearer end) and the side of that end (+1: hi). A tie goes by the midpoint, so a
/// slab [-h, h] gives exactly |t| - h and the side of t's sign.
MPM_HD float slabDistance(float t, float lo, float hi, float& side) {
  const float below = lo - t, above = t - hi;
  side = above > below || (above == below && t >= 0.5f * (lo + hi)) ? 1.f : -1.f;
  return side > 0.f ? above : below;
}

/// Box between its faces `lo` and `hi` (per axis, lo < hi), in a frame anywhere: a large
/// box keeps small numbers when its frame's origin is near the point asked about.
MPM_HD float sdfBoxFaces(Vec3f p, Vec3f lo, Vec3f hi, Vec3f& n) {
  Vec3f q, out, side;
  float inside = -3.4e38f;
  int face = 0;
  for (int a = 0; a < 3; ++a) {
    q[a] = slabDistance(p[a], lo[a], hi[a], side[a]);
    out[a] = q[a] > 0.f ? q[a] : 0.f;
    if (q[a] > inside) { inside = q[a]; face = a; }
  }
  const float outside = norm(out);
  if (outside > 0.f) {
    // nearest point is on a face, edge or corner: normal along the clamped offset
    for (int a = 0; a < 3; ++a) n[a] = side[a] * out[a] / outside;
    return outside;
  }
  n = Vec3f{0.f, 0.f, 0.f};
  n[face] = side[face];  // nearest face from the inside
  return inside;
}

/// No surface to push on here: a distance beyond every contact band and touch (a blade's
/// edge and sides, a needle's tip inside the material).
constexpr float kNoSurface = 1e30f;

/// Box of half-extents h about the origin.
MPM_HD float sdfBox(Vec3f p, Vec3f h, Vec3f& n) { return sdfBoxFaces(p, -h, h, n); }

/// Capsule: the points within r of the segment [lo, hi] on `axis`.
MPM_HD float sdfCapsule(Vec3f p, float r, float lo, float hi, int axis, Vec3f& n) {
  Vec3f c{0.f, 0.f, 0.f};
  const float t = p[axis];
  c[axis] = t < lo ? lo : (t > hi ? hi : t);
  const Vec3f d = p - c;
  const float len = norm(d);
  if (len > 1e-12f) {
    n = (1.f / len) * d;
  } else {  // on the axis: any radial direction
    n = Vec3f{0.f, 0.f, 0.f};
    n[(axis + 1) % 3] = 1.f;
  }
  return len - r;
}

/// Capsule about the segment [-hh, hh] on `axis`.
MPM_HD float sdfCapsule(Vec3f p, float r, float hh, int axis, Vec3f& n) { return sdfCapsule(p, r, -hh, hh, axis, n); }

/// Cylinder of radius r along `axis` between its caps at lo and hi on the axis.
MPM_HD float sdfCylinder(Vec3f p, float r, float lo, float hi, int axis, Vec3f& n) {
  Vec3f radial = p;
  radial[axis] = 0.f;
  const float rho = norm(radial);
  Vec3f er{0.f, 0.f, 0.f};
  if (rho > 1e-12f)
    er = (1.f / rho) * radial;
  else
    er[(axis + 1) % 3] = 1.f;  // on the axis: any radial direction
  Vec3f ea{0.f, 0.f, 0.f};
  const float dr = rho - r, da = slabDistance(p[axis], lo, hi, ea[axis]);
  if (dr > 0.f && da > 0.f) {  // beyond the rim: distance to the circle edge
    const float len = sqrtf(dr * dr + da * da);
    n = (dr / len) * er + (da / len) * ea;
    return len;
  }
  if (dr > da) {
    n = er;
    return dr;
  }
  n = ea;
  return da;
}

/// Cylinder of radius r and half height hh along `axis`, centred on the origin.
MPM_HD float sdfCylinder(Vec3f p, float r, float hh, int axis, Vec3f& n) { return sdfCylinder(p, r, -hh, hh, axis, n); }

/// Trilinear sample of a signed distance grid (values k-fastest), with its gradient.
/// Points outside the grid are clamped to it and the distance to the grid added, so the
/// value stays an upper bound of the true distance and the gradient points back in.
MPM_HD float sdfGridSample(const float* values, const int dims[3], Vec3f lower, float h, Vec3f p,
                           Vec3f& grad) {
  Vec3f g, clampOffset{0.f, 0.f, 0.f};
  int i0[3];
  float f[3];
  for (int a = 0; a < 3; ++a) {
    const float upper = lower[a] + h * (float)(dims[a] - 1);
    float x = p[a];
    if (x < lower[a]) { clampOffset[a] = x - lower[a]; x = lower[a]; }
    if (x > upper) { clampOffset[a] = x - upper; x = upper; }
    g[a] = (x - lower[a]) / h;
    int i = (int)floorf(g[a]);
    i = i < 0 ? 0 : (i > dims[a] - 2 ? dims[a] - 2 : i);
    i0[a] = i;
    f[a] = g[a] - (float)i;
  }
  float c[2][2][2];
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      for (int k = 0; k < 2; ++k)
        c[i][j][k] = values[((size_t)(i0[0] + i) * dims[1] + (i0[1] + j)) * dims[2] + (i0[2] + k)];
  const float fx = f[0], fy = f[1], fz = f[2];
  float c00 = c[0][0][0] * (1 - fz) + c[0][0][1] * fz, c01 = c[0][1][0] * (1 - fz) + c[0][1][1] * fz;
  float c10 = c[1][0][0] * (1 - fz) + c[1][0][1] * fz, c11 = c[1][1][0] * (1 - fz) + c[1][1][1] * fz;
  const float c0 = c00 * (1 - fy) + c01 * fy, c1 = c10 * (1 - fy) + c11 * fy;
  const float value = c0 * (1 - fx) + c1 * fx;
  grad.x = (c1 - c0) / h;
  grad.y = ((c01 - c00) * (1 - fx) + (c11 - c10) * fx) / h;
  const float dz00 = c[0][0][1] - c[0][0][0], dz01 = c[0][1][1] - c[0][1][0];
  const float dz10 = c[1][0][1] - c[1][0][0], dz11 = c[1][1][1] - c[1][1][0];
  grad.z = ((dz00 * (1 - fy) + dz01 * fy) * (1 - fx) + (dz10 * (1 - fy) + dz11 * fy) * fx) / h;
  const float off = norm(clampOffset);
  if (off > 0.f) {
    grad = (1.f / off) * clampOffset;
    return value + off;
  }
  return value;
}

}  // namespace mpm
