#pragma once
// Cuts in the transfers (DESIGN 5 and 7; CPIC, Hu et al. 2018): a particle and a grid node
// on opposite sides of a cut exchange nothing, in P2G and in G2P, in every grid solver.
//
// The cut is carried by the material: a blade passing a particle records on it the blade's
// plane as the particle sees it (CutPlane: the normal toward its side, its distance from
// the plane), and the plane moves and turns with the material from then on (advectCut). So
// what the blade has passed stays separated after it has gone, material the blade has not
// reached stays joined, and the cut is part of the particle state (saved with it).
//
// A cut particle's transfers run over the stencil nodes on its side only, in the APIC form
// generalised to a partial stencil: the affine field is centred on the weighted centroid
// x-bar of those nodes and its inertia D = sum w (x_i - x-bar)(x_i - x-bar)^T is their own.
// Then the momentum a particle deposits is exactly W m v (W the weight on its side), the
// stress force and the affine part sum to zero over the nodes it reaches (no particle
// pushes on itself), and G2P returns the velocity field's gradient exactly for an affine
// field. The share 1 - W the particle could not deposit keeps its own velocity in G2P,
// so the momentum of the grid and of the particles together is conserved.
#include "solvers/transfer.h"

// The transfers of a cut particle are called out of line: inlined into the solvers' kernels,
// the sided stencil's arrays slowed MLS-MPM's P2G of a scene without any cut by a third
// (125k particles, 1 thread: 144 against 109 ms a frame). On the GPU the gather is inlined
// (MPM_HD_OUTLINE_HOST): its call took the stencil, the node accessor and the results by
// address, which kept them in local memory for the whole G2P kernel, cut particle or not
// (MLS-MPM's G2P at 1M particles on an H200: 105 -> 86 us). The scatter stays out of line
// there too: inlined, P2G took 95 registers instead of 78 and ran slower (367 -> 457 us).
#if defined(__CUDACC__)
#define MPM_HD_OUTLINE __host__ __device__ __noinline__
#define MPM_HD_OUTLINE_HOST __host__ __device__
#else
#define MPM_HD_OUTLINE __attribute__((noinline))
#define MPM_HD_OUTLINE_HOST __attribute__((noinline))
#endif

namespace mpm {

/// Whether particle `cut` has been cut (has a plane).
MPM_HD bool isCut(const CutPlane& cut) { return cut.normal.x != 0.f || cut.normal.y != 0.f || cut.normal.z != 0.f; }

/// Whether a node at offset `d` from the particle (x_i - x_p) lies on the particle's side
/// of its cut plane. A node on the plane is on neither side: it would join them.
MPM_HD bool sameSide(const CutPlane& cut, Vec3f d) { return dot(cut.normal, d) + cut.offset > 0.f; }

/// How far from a blade's surface, along its unit normal n, a particle's stencil can have a
/// node across it: the stencil reaches 1.5 dx along each axis, so 1.5 dx (|n_x| + |n_y| +
/// |n_z|), up to 2.6 dx for a blade at 45 degrees to every axis. (With 1.5 dx alone, a
/// curved blade passed 0.3-2 mm/s of a 0.11 m/s push across through the particles between.)
MPM_HD float stencilReach(Vec3f n, float dx) { return 1.5f * dx * (fabsf(n.x) + fabsf(n.y) + fabsf(n.z)); }
/// The farthest that is, for any orientation [m].
MPM_HD float maxStencilReach(float dx) { return 1.5f * 1.7320508f * dx; }

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
/// The boundary's speed is the blade's own, not relative to the particle: a particle's
/// velocity is noisy at this scale (the reaction kicks the few particles ahead of the edge,
/// and with standard MPM's FLIP they keep the kick): measured relative to it, the switch
/// above held standard MPM's force at 32-55 % of G_c d. So material that moves along with
/// the blade is still charged as if it were cut.
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
  // side), the particle at `along` on it, which runs over [from, to]; outward `outLocal`
  auto boundary = [&](float ahead, float along, float from, float to, Vec3f outLocal) {
    const float rho2 = ahead * ahead + z * z;
    if (ahead <= 0.f || rho2 >= r2 || along < from || along > to) return;
    const Vec3f out = blade.rotation * outLocal;
    const float un = dot(u, out);
    if (un <= 0.f) return;
    const float w = (1.f - rho2 / r2) * (1.f - rho2 / r2);
    f -= (toughness * share * w * fminf(un / kCuttingSpeedScale, 1.f)) * out;
  };
  boundary(lo - q.y, q.x, blade.faceLower.x, blade.faceUpper.x, Vec3f{0.f, -1.f, 0.f});
  boundary(q.x - blade.faceUpper.x, q.y, lo, top, Vec3f{1.f, 0.f, 0.f});
  boundary(blade.faceLower.x - q.x, q.y, lo, top, Vec3f{-1.f, 0.f, 0.f});
  return f;
}

/// The resistance of the material to a needle's tip inside it (kPartTipInside of body
/// `body`): the tip opens a track of the wire's diameter d against the fracture toughness,
/// G_c d while it advances. Particles in the half ball of radius kCuttingReach dx ahead of
/// the tip share it, each by its volume times (1 - rho^2 / r^2)^2 over that weight's
/// integral on the half ball, 16 pi r^3 / 105; so the force is G_c d where the half ball is
/// full of material, and less as the tip leaves it. Returns the force on the needle [N]
/// (the particle takes the opposite); `presence` gets the particle's share whatever the
/// tip's motion (the scene tells from it whether the tip is still in material). Withdrawing
/// (moving back along its tangent) the tip opens nothing: no force.
MPM_HD Vec3f needleTipResistance(const PartView& tip, const BodyView& body, Vec3f x, float volume, float toughness,
                                 float dx, float& presence) {
  presence = 0.f;
  const Vec3f t = tip.rotation * tip.tangent;
  const Vec3f d = x - tip.position;
  const float r = kCuttingReach * dx, rho2 = dot(d, d);
  if (dot(d, t) <= 0.f || rho2 >= r * r) return Vec3f{0.f, 0.f, 0.f};
  const float q = 1.f - rho2 / (r * r);
  presence = volume * q * q / (16.f * 3.14159265f * r * r * r / 105.f);
  const float u = dot(body.velocityAt(tip.position), t);  // the tip's own speed, as a blade's
  if (u <= 0.f) return Vec3f{0.f, 0.f, 0.f};
  return (-toughness * 2.f * tip.radius * presence * fminf(u / kCuttingSpeedScale, 1.f)) * t;
}

/// A cut plane carried over a substep by the particle's motion, x <- x + dt v with velocity
/// gradient C: points near the particle move by (I + dt C), so the plane's normal turns by
/// (I + dt C)^-T (to first order, I - dt C^T) and the offset follows the particle's foot on it.
MPM_HD void advectCut(CutPlane& cut, const Mat3f& C, float dt) {
  if (!isCut(cut)) return;
  const Vec3f n = cut.normal;
  Vec3f m = n - dt * (transpose(C) * n);
  const float len = norm(m);
  if (!(len > 1e-12f)) return;
  m = (1.f / len) * m;
  cut.offset *= dot(m, n + dt * (C * n));
  cut.normal = m;
}

/// A cut particle's stencil restricted to the nodes on its side: their weights, the
/// weighted centroid x-bar (offset from the particle) and the inverse of their inertia.
struct SidedStencil {
  float w[27];    ///< B-spline weight of each node on the particle's side, 0 across
  Vec3f d[27];    ///< x_i - x-bar
  float W = 0.f;  ///< sum of w: the share of the particle the nodes on its side take
  Mat3f Dinv;     ///< (sum w (x_i - x-bar)(x_i - x-bar)^T + regularisation)^-1 [1/m^2]

  MPM_HD SidedStencil(const QuadraticStencil& st, float dx, const CutPlane& cut) {
    Vec3f centroid{0.f, 0.f, 0.f};
    for (int n = 0; n < 27; ++n) {
      const int i = n / 9, j = (n / 3) % 3, k = n % 3;
      const Vec3f off{((float)i - st.fx.x) * dx, ((float)j - st.fx.y) * dx, ((float)k - st.fx.z) * dx};
      d[n] = off;
      w[n] = sameSide(cut, off) ? st.w[0][i] * st.w[1][j] * st.w[2][k] : 0.f;
      W += w[n];
      centroid += w[n] * off;
    }
    if (W > 0.f) centroid = (1.f / W) * centroid;
    float D[6] = {0.f, 0.f, 0.f, 0.f, 0.f, 0.f};
    for (int n = 0; n < 27; ++n) {
      d[n] -= centroid;
      const Vec3f r = d[n];
      D[0] += w[n] * r.x * r.x; D[1] += w[n] * r.y * r.y; D[2] += w[n] * r.z * r.z;
      D[3] += w[n] * r.x * r.y; D[4] += w[n] * r.x * r.z; D[5] += w[n] * r.y * r.z;
    }
    // The nodes on one side may all lie in one layer along the cut's normal (a particle
    // right at the cut): D is singular there and that direction has no gradient to give.
    // A small multiple of the full stencil's inertia (dx^2 / 4) keeps it invertible and
    // leaves that column of the gradient near zero.
    const float reg = 0.02f * 0.25f * dx * dx;
    D[0] += reg; D[1] += reg; D[2] += reg;
    Dinv = inverseSymmetric(D);
  }

  /// APIC/MLS scatter of node momentum w (mv + A (x_i - x-bar)) and mass w m; with
  /// kCentroid also w m x_p and w m touch (as apicScatter).
  template <bool kCentroid, class Nodes>
  MPM_HD void scatter(const QuadraticStencil& st, float m, Vec3f mv, const Mat3f& A, Vec3f xp, float touch,
                      Nodes& nodes) const {
    const Float4 x4 = Float4::make(touch, xp.x, xp.y, xp.z);
    for (int n = 0; n < 27; ++n) {
      if (w[n] == 0.f) continue;
      const int i = st.base[0] + n / 9, j = st.base[1] + (n / 3) % 3, k = st.base[2] + n % 3;
      const Vec3f q = mv + A * d[n];
      nodes.add(i, j, k, w[n] * Float4::make(m, q.x, q.y, q.z));
      if constexpr (kCentroid) nodes.addCentroid(i, j, k, (w[n] * m) * x4);
    }
  }

  /// Standard MPM's stress impulse dt f_i = S grad w_i with the gradient of the sided
  /// stencil, grad w_i = w_i Dinv (x_i - x-bar) (S = -dt V0 tau), and w_i times an
  /// external impulse `J` on the particle.
  template <class Nodes>
  MPM_HD void scatterStressImpulse(const QuadraticStencil& st, const Mat3f& S, Vec3f J, Nodes& nodes) const {
    const Mat3f SD = S * Dinv;
    for (int n = 0; n < 27; ++n) {
      if (w[n] == 0.f) continue;
      const Vec3f f = w[n] * (SD * d[n] + J);
      nodes.addStressImpulse(st.base[0] + n / 9, st.base[1] + (n / 3) % 3, st.base[2] + n % 3,
                             Float4::make(0.f, f.x, f.y, f.z));
    }
  }

  /// G2P: v = sum w v_i + (1 - W) vOld (the share the particle did not deposit keeps its
  /// velocity) and the gradient C = (sum w v_i (x_i - x-bar)^T) Dinv. With `oldOut`, also
  /// standard MPM's velocity before the force, sum w v_i,old + (1 - W) vOld.
  template <class Nodes>
  MPM_HD void gather(const QuadraticStencil& st, const Nodes& nodes, Vec3f vOld, Vec3f& v, Mat3f& C,
                     Vec3f* oldOut = nullptr) const {
    Vec3f sum{0.f, 0.f, 0.f}, sumOld{0.f, 0.f, 0.f};
    Mat3f B;
    for (int n = 0; n < 27; ++n) {
      if (w[n] == 0.f) continue;
      const int i = st.base[0] + n / 9, j = st.base[1] + (n / 3) % 3, k = st.base[2] + n % 3;
      const Vec3f vi = nodes.velocity4(i, j, k).xyz();
      sum += w[n] * vi;
      if (oldOut) sumOld += w[n] * nodes.oldVelocity4(i, j, k).xyz();
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) B.m[r][c] += w[n] * vi[r] * d[n][c];
    }
    v = sum + (1.f - W) * vOld;
    C = B * Dinv;
    if (oldOut) *oldOut = sumOld + (1.f - W) * vOld;
  }
};

/// P2G of a cut particle through the nodes on its side (SidedStencil): momentum w (mv +
/// A (x_i - x-bar)) with A = mC + S Dinv, S = -dt V0 tau the stress part (MLS-MPM; zero for
/// PB-MPM), and with `stressImpulse` (standard MPM) S's force w Dinv (x_i - x-bar) S and an
/// external impulse J as the nodes' stress impulse instead.
template <bool kCentroid, class Nodes>
MPM_HD_OUTLINE void scatterCutParticle(const QuadraticStencil& st, float dx, const CutPlane& cut, float m, Vec3f mv,
                                       const Mat3f& mC, const Mat3f& S, bool stressImpulse, Vec3f J, Vec3f xp,
                                       float touch, Nodes& nodes) {
  const SidedStencil side(st, dx, cut);
  if (stressImpulse) {
    side.scatter<kCentroid>(st, m, mv, mC, xp, touch, nodes);
    side.scatterStressImpulse(st, S, J, nodes);
  } else {
    side.scatter<kCentroid>(st, m, mv, mC + S * side.Dinv, xp, touch, nodes);
  }
}

/// G2P of a cut particle (SidedStencil::gather).
template <class Nodes>
MPM_HD_OUTLINE_HOST void gatherCutParticle(const QuadraticStencil& st, float dx, const CutPlane& cut, const Nodes& nodes,
                                      Vec3f vOld, Vec3f& v, Mat3f& C, Vec3f* oldOut) {
  SidedStencil(st, dx, cut).gather(st, nodes, vOld, v, C, oldOut);
}

/// G2P's velocity and affine field of an APIC particle (MLS-MPM, PB-MPM) inside the grid:
/// through its cut if it is cut, else from its APIC sums, `sums` if the caller computed them
/// (backend/cpu/gather_batch.h), else from the nodes. Returns whether it is cut.
template <class Nodes>
MPM_HD bool apicGatherParticle(uint32_t p, const ParticleView& P, const GridGeometry& geo, bool cuts,
                               const QuadraticStencil& st, const ApicSums* sums, const Nodes& nodes, Vec3f& v,
                               Mat3f& C) {
  const bool cut = cuts && isCut(P.cut[p]);
  if (cut)
    gatherCutParticle(st, geo.dx, P.cut[p], nodes, P.v[p], v, C, nullptr);
  else
    apicFromSums(st, geo, sums ? *sums : apicSums(st, nodes), v, C);
  return cut;
}

}  // namespace mpm
