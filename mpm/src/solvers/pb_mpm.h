#pragma once
// Position-based MPM (Lewin 2024; the CRESSim-MPM paper, eqs. 13-16): each substep runs
// `iterations` P2G / grid / G2P cycles with the positions and F held at the start of the
// substep. In each P2G the particle's candidate deformation from its current velocity
// gradient C is projected onto the material constraint and turned back into a velocity
// gradient, which is spread as APIC momentum; G2P gathers v and C from the grid (a
// Jacobi-style constraint solve). After the last cycle x += dt v and F <- (I + dt C) F with
// the gathered C, the motion the particles actually make, so F keeps the deformation the
// constraint has not yet undone.
//
// The 3D form used here, per particle with F the deformation at the start of the substep:
//   F*  = (I + dt C) F                                    (eq. 13)
//   R   = polar rotation of F*                            (eq. 14)
//   F_c = beta R + (1 - beta) F* / det(F*)^(1/3)          (eq. 15; the cube root makes the
//         second term volume preserving in 3D, as F / sqrt(det F) does in 2D)
//   C_c = C + omega ((F_c F^-1 - I) / dt - C)             (eq. 16 when omega = 1)
// beta = SolverParams::rigidity, omega = SolverParams::relaxation. Gravity enters in the
// first cycle only; walls and rigid contact act in every cycle (the momentum each cycle
// gives a shape is summed, so the exchange stays exact). The material's E and nu play no
// part: stiffness comes from the iterations (more iterations, stiffer), as in PBD.
#include "core/pb_projection.h"
#include "solvers/substep_stages.h"
#include "transfer/cut.h"
#include "transfer/particle_check.h"

namespace mpm {

struct PbMpm {
  /// Unconditionally stable in the elastic response: only particle speed limits the step.
  static constexpr bool kElasticCfl = false;
  /// Particles carry the APIC affine field C.
  static constexpr bool kAffine = true;

  /// The constraint projection (eqs. 13-16), then APIC P2G of the projected C.
  template <bool kCentroid>
  struct P2G {
    static constexpr bool kCentroidSums = kCentroid;
    static constexpr bool kStressImpulse = false;
    ParticleView P;
    GridGeometry geo;
    float dt;
    float relaxation;
    float rigidity;
    bool cuts;          ///< some particle may be cut (ParticleGridSystem::cuts)
    const Vec3f* push;  ///< resistance to cutting, first cycle only, or null (ParticleGridSystem::cuttingPush)
    /// The projection enters only through C_c = pbProjectedVelocityGradient(F, C, ...):
    /// the CPU computes it for many particles at once (backend/cpu/stress_batch.h) and
    /// hands it to scatterProjected; the device calls operator().
    static constexpr bool kBatchedProjection = true;
    /// Likewise its stencil, QuadraticStencil(geo, P.x[p]) (backend/cpu/stencil_batch.h).
    using BatchedStencil = QuadraticStencil;
    template <class Nodes>
    MPM_HD void operator()(uint32_t p, Nodes& nodes) const {
      scatterProjected(p, QuadraticStencil(geo, P.x[p]),
                       pbProjectedVelocityGradient(P.F[p], P.C[p], dt, relaxation, rigidity), nodes);
    }
    template <class Nodes>
    MPM_HD void scatterProjected(uint32_t p, const QuadraticStencil& st, const Mat3f& Cc, Nodes& nodes) const {
      if (!st.inside(geo)) return;  // a stray: reported by G2P, never written
      const float m = P.mass[p];
      const Vec3f mv = push ? m * P.v[p] + push[p] : m * P.v[p];
      if (cuts && isCut(P.cut[p]))
        scatterCutParticle<kCentroid>(st, geo.dx, P.cut[p], m, mv, m * Cc, Mat3f{}, false, Vec3f{}, P.x[p], P.touch[p],
                                      nodes);
      else
        apicScatter<kCentroid>(st, geo.dx, m, mv, m * Cc, P.x[p], P.touch[p], nodes);
    }
  };

  struct G2P {
    static constexpr bool kOldVelocity = false;
    ParticleView P;
    GridGeometry geo;
    float dt;
    bool integrate;  ///< the last cycle: also move the particle and advance F
    const PartView* parts = nullptr;  ///< the parts in reach this substep (withParts)
    int nParts = 0;
    bool cuts = false;  ///< some particle may be cut (withParts)
    /// As MLS-MPM's G2P: the CPU hands each particle its stencil, QuadraticStencil(geo,
    /// P.x[p]), and its APIC sums, computed for many particles at once.
    using BatchedStencil = QuadraticStencil;
    static constexpr bool kBatchedSums = true;
    /// The rest of gatherSummed in lanes too, as MLS-MPM's (integrating on the last cycle).
    MPM_HD bool integrates() const { return integrate; }
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
      if (integrate) {
        P.x[p] += dt * v;
        advanceDeformation(C, dt, P.F[p]);
        if (cut) advectCut(P.cut[p], C, dt);
        return finishParticle(p, P, geo, parts, nParts, nodes.nearParts());
      }
      StepCheck c;
      c.maxSpeed2 = dot(v, v);
      if (!isFinite(c.maxSpeed2 + trace(C))) c.firstBadParticle = p;
      return c;
    }
  };

  template <class System>
  static void substep(System& s, const SubstepParams& p) {
    s.binParticles();  // positions stay put until the last cycle
    s.placeShapes();
    s.recordCuts(p.dt);
    const ParticleView P = s.particles();
    const int n = p.solver.iterations;
    // Cycle `it` is P2G, grid update, contact, G2P. The material centroids (sum w m x_p,
    // sum w m touch_p) are the same in every cycle, the positions and touch flags held:
    // scattered in the first only, kept after. Gravity and the resistance to cutting act
    // once a substep, in the first.
    scatterParticles<P2G>(s, true, GridUpdate{s.grid(), p.dt, p.gravity, p.walls}, P, s.geometry(), p.dt,
                          p.solver.relaxation, p.solver.rigidity, s.cuts(), s.cuttingPush());
    for (int it = 0;; ++it) {
      s.exchangeContact(p.dt, it == 0, n);
      if (it == n - 1) break;
      // this cycle's G2P and the next one's P2G, over the same stencils (positions held)
      s.gatherThenScatter(withParts(s, G2P{P, s.geometry(), p.dt, false}),
                          P2G<false>{P, s.geometry(), p.dt, p.solver.relaxation, p.solver.rigidity, s.cuts(), nullptr},
                          GridUpdate{s.grid(), p.dt, Vec3f{0.f, 0.f, 0.f}, p.walls}, true);
    }
    s.gather(withParts(s, G2P{P, s.geometry(), p.dt, true}));
    s.moveShapes(p.dt);
  }
};

}  // namespace mpm
