#pragma once
// Cuts in the transfers (CPIC, Hu et al. 2018): a particle and a grid node
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
#include "core/particle_state.h"
#include "core/symmetric3.h"
#include "transfer/apic.h"

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
