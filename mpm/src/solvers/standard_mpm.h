#pragma once
// Standard MPM, update-stress-last with a PIC/FLIP blend (the CRESSim-MPM paper, eqs. 1-8).
//
// P2G: mass, momentum m v, and the internal force f_i = -sum V sigma grad w_i, written
// with the Kirchhoff stress as -sum V0 tau grad w_i (V sigma = J V0 sigma = V0 tau, so the
// volume update V = J V0 of eq. 7 is carried by tau). The grid keeps the velocity before
// the force for the FLIP increment. G2P: x += dt v_PIC (eq. 4), L = sum v_i grad w_i^T
// (eq. 5), F <- (I + dt L) F (eq. 6), v = a (v + sum w (v_i - v_i,old)) + (1 - a) v_PIC.
// No affine field: C stays what it was and plays no part.
#include "core/constitutive.h"
#include "solvers/substep_stages.h"
#include "transfer/cut.h"
#include "transfer/particle_check.h"

namespace mpm {

struct StandardMpm {
  static constexpr bool kElasticCfl = true;
  /// No affine field: C is not used.
  static constexpr bool kAffine = false;

  template <bool kCentroid>
  struct P2G {
    static constexpr bool kCentroidSums = kCentroid;
    static constexpr bool kStressImpulse = true;
    ParticleView P;
    GridGeometry geo;
    const MaterialParams* materials;
    float dt;
    bool cuts;          ///< some particle may be cut (ParticleGridSystem::cuts)
    const Vec3f* push;  ///< resistance to cutting this substep, or null (ParticleGridSystem::cuttingPush)
    /// The material enters only through tau = kirchhoffStress(materials[P.object[p]],
    /// P.F[p]) (CPU: computed for many particles at once, backend/cpu/stress_batch.h).
    static constexpr bool kBatchedStress = true;
    template <class Nodes>
    MPM_HD void operator()(uint32_t p, Nodes& nodes) const {
      scatterStressed(p, kirchhoffStress(materials[P.object[p]], P.F[p]), nodes);
    }
    template <class Nodes>
    MPM_HD void scatterStressed(uint32_t p, const Mat3f& tau, Nodes& nodes) const {
      const Vec3f xp = P.x[p];
      const QuadraticStencil st(geo, xp);
      if (!st.inside(geo)) return;  // a stray: reported by G2P, never written
      const float m = P.mass[p];
      const Vec3f mv = m * P.v[p];
      // the resistance to cutting enters as a force, with the stress: the FLIP increment sees it
      const Vec3f pushed = push ? push[p] : Vec3f{0.f, 0.f, 0.f};
      if (cuts && isCut(P.cut[p])) {  // the nodes on its side of the cut, with their own gradients
        scatterCutParticle<kCentroid>(st, geo.dx, P.cut[p], m, mv, Mat3f{},
                                      (-dt * P.volume0[p]) * tau, true,
                                      pushed, xp, P.touch[p], nodes);
        return;
      }
      const Float4 push4 = Float4::make(0.f, pushed.x, pushed.y, pushed.z);
      // dt f_i = -dt V0 tau grad w_i, with grad w_i = (dw0 w1 w2, w0 dw1 w2, w0 w1 dw2):
      // per node w2 (dw0 w1 T0 + w0 dw1 T1) + dw2 (w0 w1 T2), T the impulse's columns
      const Mat3f impulse = (-dt * P.volume0[p]) * tau;
      const Float4 t0 = Float4::make(0.f, impulse.m[0][0], impulse.m[1][0], impulse.m[2][0]);
      const Float4 t1 = Float4::make(0.f, impulse.m[0][1], impulse.m[1][1], impulse.m[2][1]);
      const Float4 t2 = Float4::make(0.f, impulse.m[0][2], impulse.m[1][2], impulse.m[2][2]);
      const Float4 q0 = Float4::make(m, mv.x, mv.y, mv.z);
      const Float4 x4 = Float4::make(P.touch[p], xp.x, xp.y, xp.z);
      float dw[3][3];
      st.gradients(geo.invDx, dw);
      const float(&w)[3][3] = st.w;
      const int* base = st.base;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
          const float wij = w[0][i] * w[1][j];
          // the push's share w_ij w_k J rides on e, which each node takes times w_k
          const Float4 e = (dw[0][i] * w[1][j]) * t0 + (w[0][i] * dw[1][j]) * t1 + wij * push4;
          const Float4 f = wij * t2;
          for (int k = 0; k < 3; ++k) {
            const float wt = wij * w[2][k];
            nodes.add(base[0] + i, base[1] + j, base[2] + k, wt * q0);
            if constexpr (kCentroid) nodes.addCentroid(base[0] + i, base[1] + j, base[2] + k, (wt * m) * x4);
            nodes.addStressImpulse(base[0] + i, base[1] + j, base[2] + k, w[2][k] * e + dw[2][k] * f);
          }
        }
    }
  };

  /// Eq. 3 (v = (mv + dt f) / m, then gravity and walls), keeping the old velocity.
  struct GridUpdate {
    GridView grid;
    float dt;
    Vec3f gravity;
    WallParams walls;
    MPM_HD void operator()(size_t n) const {
      GridNode& node = grid.nodes[n];
      const Vec3f vOld = holdsMaterial(node) ? (1.f / node.mass) * node.mv : Vec3f{0.f, 0.f, 0.f};
      node.mv += node.dmv;
      node.dmv = vOld;
      gridUpdateNode((uint32_t)n, grid, dt, gravity, walls);
    }
  };

  struct G2P {
    static constexpr bool kOldVelocity = true;
    ParticleView P;
    GridGeometry geo;
    float dt;
    float flip;  ///< FLIP share of the velocity update
    const PartView* parts = nullptr;  ///< the parts in reach this substep (withParts)
    int nParts = 0;
    bool cuts = false;  ///< some particle may be cut (withParts)
    template <class Nodes>
    MPM_HD StepCheck operator()(uint32_t p, const Nodes& nodes) const {
      const QuadraticStencil st(geo, P.x[p]);
      if (!st.inside(geo)) return strayParticle(p, P);
      if (cuts && isCut(P.cut[p])) {
        Vec3f vPic, vOld;
        Mat3f L;
        gatherCutParticle(st, geo.dx, P.cut[p], nodes, P.v[p], vPic, L, &vOld);
        return advance(p, vPic, vPic - vOld, L, true, nodes.nearParts());
      }
      float dw[3][3];
      st.gradients(geo.invDx, dw);
      const float(&w)[3][3] = st.w;
      const int* base = st.base;
      // separable sums: vPic = sum w v, vOld = sum w v_old, L = sum v grad w^T by columns
      Float4 vp = Float4::zero(), vo = Float4::zero(), l0 = Float4::zero(), l1 = Float4::zero(),
             l2 = Float4::zero();
      for (int i = 0; i < 3; ++i) {
        Float4 S = Float4::zero(), D = Float4::zero(), T = Float4::zero(), O = Float4::zero();
        for (int j = 0; j < 3; ++j) {
          Float4 s = Float4::zero(), t = Float4::zero(), o = Float4::zero();
          for (int k = 0; k < 3; ++k) {
            const Float4 vn = nodes.velocity4(base[0] + i, base[1] + j, base[2] + k);
            s += w[2][k] * vn;
            t += dw[2][k] * vn;
            o += w[2][k] * nodes.oldVelocity4(base[0] + i, base[1] + j, base[2] + k);
          }
          S += w[1][j] * s;
          D += dw[1][j] * s;
          T += w[1][j] * t;
          O += w[1][j] * o;
        }
        vp += w[0][i] * S;
        l0 += dw[0][i] * S;
        l1 += w[0][i] * D;
        l2 += w[0][i] * T;
        vo += w[0][i] * O;
      }
      return advance(p, vp.xyz(), (vp - vo).xyz(), Mat3f::fromColumns(l0.xyz(), l1.xyz(), l2.xyz()), false,
                     nodes.nearParts());
    }
    /// x += dt v_PIC, the PIC/FLIP velocity (dv: the grid's velocity increment seen by the
    /// particle), F <- (I + dt L) F; a cut particle's plane moves with it. `near`: the
    /// nodes' list of the parts near the particle (finishParticle).
    MPM_HD StepCheck advance(uint32_t p, Vec3f vPic, Vec3f dv, const Mat3f& L, bool cut, const NearParts& near) const {
      P.x[p] += dt * vPic;
      P.v[p] = flip * (P.v[p] + dv) + (1.f - flip) * vPic;
      P.F[p] = (Mat3f::identity() + dt * L) * P.F[p];
      if (cut) advectCut(P.cut[p], L, dt);
      return finishParticle(p, P, geo, parts, nParts, near);
    }
  };

  template <class System>
  static void substep(System& s, const SubstepParams& p) {
    const ParticleView P = s.particles();
    explicitSubstep<P2G, GridUpdate>(s, p, G2P{P, s.geometry(), p.dt, p.solver.flipBlend},
                                     P, s.geometry(), s.materials(), p.dt, s.cuts(), s.cuttingPush());
  }
};

}  // namespace mpm
