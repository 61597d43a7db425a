#pragma once
// MLS-MPM (Hu et al. 2018; the CRESSim-MPM paper, eqs. 9-12, Algorithm 1). P2G fuses the
// APIC momentum and the stress force in one affine matrix, A = m C - dt V0 M^-1 tau
// (tau = P F^T, the Kirchhoff stress); G2P rebuilds v and C from the grid and advances
// F <- (I + dt C) F.
#include "core/constitutive.h"
#include "solvers/substep_stages.h"
#include "transfer/cut.h"
#include "transfer/particle_check.h"

namespace mpm {

struct MlsMpm {
  /// Wave speed limits the substep (explicit in time).
  static constexpr bool kElasticCfl = true;
  /// Particles carry the APIC affine field C.
  static constexpr bool kAffine = true;

  template <bool kCentroid>
  struct P2G {
    static constexpr bool kCentroidSums = kCentroid;
    static constexpr bool kStressImpulse = false;
    ParticleView P;
    GridGeometry geo;
    const MaterialParams* materials;
    float dt;
    bool cuts;          ///< some particle may be cut (ParticleGridSystem::cuts)
    const Vec3f* push;  ///< resistance to cutting this substep, or null (ParticleGridSystem::cuttingPush)
    /// The material enters only through tau = kirchhoffStress(materials[P.object[p]],
    /// P.F[p]): the CPU computes it for many particles at once (backend/cpu/stress_batch.h)
    /// and hands it to scatterStressed; the device calls operator().
    static constexpr bool kBatchedStress = true;
    /// Likewise its stencil, QuadraticStencil(geo, P.x[p]) (backend/cpu/stencil_batch.h).
    using BatchedStencil = QuadraticStencil;
    template <class Nodes>
    MPM_HD void operator()(uint32_t p, Nodes& nodes) const {
      scatterStressed(p, QuadraticStencil(geo, P.x[p]), kirchhoffStress(materials[P.object[p]], P.F[p]), nodes);
    }
    template <class Nodes>
    MPM_HD void scatterStressed(uint32_t p, const QuadraticStencil& st, const Mat3f& tau, Nodes& nodes) const {
      if (!st.inside(geo)) return;  // a stray: reported by G2P, never written
      const float m = P.mass[p];
      const Vec3f mv = push ? m * P.v[p] + push[p] : m * P.v[p];
      if (cuts && isCut(P.cut[p])) {  // the nodes on its side of the cut, M^-1 their own
        scatterCutParticle<kCentroid>(st, geo.dx, P.cut[p], m, mv, m * P.C[p], (-dt * P.volume0[p]) * tau, false,
                                      Vec3f{}, P.x[p], P.touch[p], nodes);
        return;
      }
      const Mat3f affine = m * P.C[p] - (dt * P.volume0[p] * apicInverseInertia(geo)) * tau;
      apicScatter<kCentroid>(st, geo.dx, m, mv, affine, P.x[p], P.touch[p], nodes);
    }
  };

  struct G2P {
    static constexpr bool kOldVelocity = false;
    ParticleView P;
    GridGeometry geo;
    float dt;
    const PartView* parts = nullptr;  ///< the parts in reach this substep (withParts)
    int nParts = 0;
    bool cuts = false;  ///< some particle may be cut (withParts)
    /// The CPU computes the stencils QuadraticStencil(geo, P.x[p]) of many particles at
    /// once and with them the gather's sums, apicSums(stencil, nodes), and hands each to
    /// gatherSummed (backend/cpu/stencil_batch.h, gather_batch.h).
    using BatchedStencil = QuadraticStencil;
    static constexpr bool kBatchedSums = true;
    /// ... and the rest of gatherSummed for many particles at once too (backend/cpu/
    /// update_batch.h), which asks whether this G2P moves the particles and advances F.
    MPM_HD bool integrates() const { return true; }
    template <class Nodes>
    MPM_HD StepCheck operator()(uint32_t p, const Nodes& nodes) const {
      return gatherSummed(p, QuadraticStencil(geo, P.x[p]), nullptr, nodes);
    }
    /// `sums`: apicSums(st, nodes) if already computed (not read for a cut particle or a
    /// stray), else null.
    template <class Nodes>
    MPM_HD StepCheck gatherSummed(uint32_t p, const QuadraticStencil& st, const ApicSums* sums,
                                  const Nodes& nodes) const {
      if (!st.inside(geo)) return strayParticle(p, P);
      Vec3f v;
      Mat3f C;
      const bool cut = apicGatherParticle(p, P, geo, cuts, st, sums, nodes, v, C);
      P.v[p] = v;
      P.C[p] = C;
      P.x[p] += dt * v;
      advanceDeformation(C, dt, P.F[p]);
      if (cut) advectCut(P.cut[p], C, dt);
      return finishParticle(p, P, geo, parts, nParts, nodes.nearParts());
    }
  };

  template <class System>
  static void substep(System& s, const SubstepParams& p) {
    const ParticleView P = s.particles();
    explicitSubstep<P2G, GridUpdate>(s, p, G2P{P, s.geometry(), p.dt}, P, s.geometry(),
                                     s.materials(), p.dt, s.cuts(), s.cuttingPush());
  }
};

}  // namespace mpm
