#pragma once
// A slicer's blades: what they record on the particles they pass (the cut plane the
// transfers then respect, transfer/cut.h) and the material's resistance to being cut.
#include "contact/rigid_body.h"
#include "transfer/cut.h"

namespace mpm {

/// Records on a particle at `x` the blade part `blade` (kPartBlade) when the particle lies
/// within its stencil's reach (stencilReach) of the blade's plane, within its cutting
/// extent: between the edge (faceLower.y) and the spine's reach (faceUpper.y less the
/// spine's radius, `radius`), along the whole edge. Elsewhere the particle keeps what it had.
MPM_HD void recordCut(CutPlane& cut, Vec3f x, const PartView& blade, float dx) {
  const Vec3f q = transpose(blade.rotation) * (x - blade.position);
  if (q.x < blade.faceLower.x || q.x > blade.faceUpper.x || q.y < blade.faceLower.y ||
      q.y > blade.faceUpper.y - blade.radius)
    return;
  const float z = q.z - 0.5f * (blade.faceLower.z + blade.faceUpper.z);
  const Vec3f n = blade.rotation.column(2);
  if (fabsf(z) > stencilReach(n, dx)) return;
  cut.normal = (z >= 0.f ? 1.f : -1.f) * n;
  cut.offset = fabsf(z);
}

/// Distance from p to the segment [a, b].
MPM_HD float segmentDistance(Vec3f p, Vec3f a, Vec3f b) {
  const Vec3f ab = b - a;
  const float len2 = dot(ab, ab);
  float t = len2 > 0.f ? dot(p - a, ab) / len2 : 0.f;
  t = t < 0.f ? 0.f : (t > 1.f ? 1.f : t);
  return norm(p - (a + t * ab));
}

/// Records a curved blade (kPartCurvedBlade) on a particle at `x` within its stencil's reach,
/// where a blade is beside it and its nearest point is not within the spine's radius: the
/// tangent plane at that point, seen from the particle, moved toward the particle as far as
/// it takes to put every node of its stencil that lies across the blade across the plane
/// too. On the blade's concave side a tangent plane alone leaves nodes between the curve
/// and the plane on the particle's side (up to t^2 / 2R at a distance t along a blade of
/// radius R: 1.7 mm at 1.5 cm for R = 6.5 cm); checked against the blade, the stencil's own
/// nodes make the record exact while the blade is there (the blade being its facets).
MPM_HD void recordCurvedCut(CutPlane& cut, Vec3f x, const PartView& blade, const GridGeometry& geo) {
  const Mat3f toBlade = transpose(blade.rotation);
  const Vec3f p = toBlade * (x - blade.position);
  float sided;
  Vec3f n;
  if (!blade.curvedBladeAt(p, sided, n) || fabsf(sided) > stencilReach(blade.rotation * n, geo.dx)) return;
  if (blade.radius > 0.f && segmentDistance(p - fabsf(sided) * n, blade.faceLower, blade.faceUpper) < blade.radius)
    return;
  const Vec3f normal = blade.rotation * n;
  float offset = fabsf(sided);
  const QuadraticStencil st(geo, x);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) {
        const Vec3f d{((float)i - st.fx.x) * geo.dx, ((float)j - st.fx.y) * geo.dx, ((float)k - st.fx.z) * geo.dx};
        float nodeSided;
        Vec3f nodeNormal;
        // a node across the blade (other sign) must be across the plane: n . d + offset <= 0
        if (blade.curvedBladeAt(p + toBlade * d, nodeSided, nodeNormal) && nodeSided * sided < 0.f)
          offset = fminf(offset, -dot(normal, d));
      }
  cut.normal = normal;
  cut.offset = offset;
}

/// Momentum a blade receives over a substep, and its moment about the blade's centre.
struct BladeImpulse {
  Vec3f linear, angular;
  float presence = 0.f;  ///< a needle's tip: the share of material within its reach (needleTipResistance)
};

/// Radius of the region about a blade's cutting boundary in which material counts as
/// engaged, in cells. Each particle on the uncut side of the boundary there adds twice its
/// volume times a weight to the engaged length; the weight (1 - rho^2 / r^2)^2 integrates
/// to pi r^2 / 3 over the disc, so the sum is the length of boundary inside material and
/// is smooth as the blade moves. Only the uncut half of the disc is counted: behind the
/// boundary the blade has pushed the material out of its band, and counting both halves
/// measured 12-14 % short of G_c d.
constexpr float kCuttingReach = 1.f;
/// Below this speed of the boundary [m/s] the resistance grows in proportion (a blade at
/// rest feels none; Coulomb-like, regularised).
constexpr float kCuttingSpeedScale = 1e-3f;

/// The resistance to cutting that a particle of current volume `volume` at x opposes to
/// blade part `blade` of body `body`: -G_c l t for each cutting boundary it lies just ahead
/// of (the edge, outward -y, and the two ends of the blade, outward +-x, up to the spine's
/// reach), l its share of the engaged length and t the boundary's outward direction, while
/// the boundary moves outward. The force on the blade [N]; the particle takes the opposite
/// (opening the cut pushes the material ahead of the edge).
///
/// The boundary's speed is the blade's own, not relative to the particle, so material that
/// moves along with the blade is still charged as if it were cut. Relative to the
/// particle's velocity (the push handed to the grid in P2G) a blade carried in its own cut
/// with the tissue felt nothing, as it should, but demo_cutting's scalpel (5.8 cm/s, dx
/// 5 mm) felt 1.85 N against G_c d = 2.40 N: the few particles ahead of its end, pushed by
/// their share, surge to the blade's speed and are charged only while slower, so the
/// charge rectifies their motion (its own speed: 2.44 N).
MPM_HD Vec3f cuttingResistance(const PartView& blade, const BodyView& body, Vec3f x, float volume, float toughness,
                               float dx) {
  const Vec3f q = transpose(blade.rotation) * (x - blade.position);
  const float z = q.z - 0.5f * (blade.faceLower.z + blade.faceUpper.z);
  const float r = kCuttingReach * dx, r2 = r * r;
  const float share = 2.f * volume / (3.14159265f * r2 / 3.f);
  const Vec3f u = body.velocityAt(x);  // the blade's motion
  const float lo = blade.faceLower.y, top = blade.faceUpper.y - blade.radius;
  Vec3f f{0.f, 0.f, 0.f};
  // a boundary at distance `ahead` behind the particle (> 0: the particle is on its uncut
  // side), the particle at `along` on it, which runs over [from, to]; outward `outLocal`.
  // Its ends fade over a particle's spacing s (a ramp from -s/2 to s/2 about each end), so
  // the columns of particles along it count its length in material whatever their offset
  // from its ends: cut off at the ends, a 3 cm edge over columns 1 cm apart counted 2 or 4
  // of them as its ends' rounding fell (the README's scalpel in its slab, dx 2 cm: -30 %).
  const float s = cbrtf(volume);
  auto boundary = [&](float ahead, float along, float from, float to, Vec3f outLocal) {
    const float rho2 = ahead * ahead + z * z;
    if (ahead <= 0.f || rho2 >= r2) return;
    const float cover = fminf(fmaxf((along - from) / s + 0.5f, 0.f), 1.f) * fminf(fmaxf((to - along) / s + 0.5f, 0.f), 1.f);
    if (!(cover > 0.f)) return;
    const Vec3f out = blade.rotation * outLocal;
    const float un = dot(u, out);
    if (un <= 0.f) return;
    const float w = (1.f - rho2 / r2) * (1.f - rho2 / r2);
    f -= (toughness * share * w * cover * fminf(un / kCuttingSpeedScale, 1.f)) * out;
  };
  boundary(lo - q.y, q.x, blade.faceLower.x, blade.faceUpper.x, Vec3f{0.f, -1.f, 0.f});
  boundary(q.x - blade.faceUpper.x, q.y, lo, top, Vec3f{1.f, 0.f, 0.f});
  boundary(blade.faceLower.x - q.x, q.y, lo, top, Vec3f{-1.f, 0.f, 0.f});
  return f;
}

/// The resistance to cutting that a particle of current volume `volume` at x opposes to a
/// curved blade `blade` (kPartCurvedBlade) of body `body`, as cuttingResistance does a quad
/// blade's: the particle lies ahead of the blade's outline (no face beside it, within
/// kCuttingReach dx of the outline, not within the spine's radius of its axis) while the
/// outline moves toward it. Its direction is the particle's from the outline, `out` (the
/// sampled distance's gradient, the blade grid's second channel): off the blade's plane it
/// leans out of it, so each particle adds (1 - rho^2 / r^2)^2 cos(phi) along the outline's
/// outward normal, whose integral over the half disc ahead is r^2 / 3 (not pi r^2 / 6): the
/// share is volume / (r^2 / 3) and the force G_c per unit length of outline in material.
/// The leaning parts cancel between the two sides of the blade. The force on the blade [N].
MPM_HD Vec3f curvedCuttingResistance(const PartView& blade, const BodyView& body, Vec3f x, float volume,
                                     float toughness, float dx) {
  const Vec3f none{0.f, 0.f, 0.f};
  const Vec3f p = transpose(blade.rotation) * (x - blade.position);
  float sided;
  Vec3f n;
  if (blade.curvedBladeAt(p, sided, n)) return none;  // beside a face: behind the outline
  const float r = kCuttingReach * dx, r2 = r * r;
  Vec3f g;
  const size_t channel = (size_t)blade.sdfDims[0] * blade.sdfDims[1] * blade.sdfDims[2];
  const float rho = sdfGridSample(blade.sdfValues + channel, blade.sdfDims, blade.sdfLower, blade.sdfCell, p, g);
  const float len = norm(g);
  if (!(rho < r) || !(len > 1e-12f)) return none;
  const Vec3f outLocal = (1.f / len) * g;
  if (blade.radius > 0.f && segmentDistance(p - rho * outLocal, blade.faceLower, blade.faceUpper) < blade.radius)
    return none;  // the spine's back edge opens nothing
  const Vec3f out = blade.rotation * outLocal;
  const float un = dot(body.velocityAt(x), out);  // the blade's own motion, as cuttingResistance
  if (un <= 0.f) return none;
  const float q = 1.f - rho * rho / r2;
  const float share = volume / (r2 / 3.f);
  return (-toughness * share * q * q * fminf(un / kCuttingSpeedScale, 1.f)) * out;
}

}  // namespace mpm
