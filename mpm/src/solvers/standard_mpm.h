#pragma once
// Standard MPM, update-stress-last with a PIC/FLIP blend (seed 000 eqs. 1-8).
//
// P2G: mass, momentum m v, and the internal force f_i = -sum V sigma grad w_i, written
// with the Kirchhoff stress as -sum V0 tau grad w_i (V sigma = J V0 sigma = V0 tau, so the
// volume update V = J V0 of eq. 7 is carried by tau). The grid keeps the velocity before
// the force for the FLIP increment. G2P: x += dt v_PIC (eq. 4), L = sum v_i grad w_i^T
// (eq. 5), F <- (I + dt L) F (eq. 6), v = a (v + sum w (v_i - v_i,old)) + (1 - a) v_PIC.
// No affine field: C stays what it was and plays no part.
#include "core/constitutive.h"
#include "solvers/transfer.h"

namespace mpm {

struct StandardMpm {
  static constexpr bool kElasticCfl = true;
  /// No affine field: C is not used.
  static constexpr bool kAffine = false;

  template <bool kCentroid>
  struct P2G {
    ParticleView P;
    GridGeometry geo;
    const MaterialParams* materials;
    float dt;
    template <class Nodes>
    MPM_HD void operator()(uint32_t p, Nodes& nodes) const {
      if (!geo.stencilInside(P.x[p])) return;
      const QuadraticStencil st(geo, P.x[p]);
      const float m = P.mass[p];
      const Vec3f mv = m * P.v[p], xp = P.x[p];
      // dt f_i = -dt V0 tau grad w_i
      const Mat3f impulse = (-dt * P.volume0[p]) * kirchhoffStress(materials[P.object[p]], P.F[p]);
      forEachStencilGradient(st, geo.invDx, [&](int a, int b, int c, float wt, Vec3f grad) {
        if constexpr (kCentroid)
          nodes.add(a, b, c, wt * m, wt * mv, (wt * m) * xp);
        else
          nodes.add(a, b, c, wt * m, wt * mv);
        nodes.addStressImpulse(a, b, c, impulse * grad);
      });
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
    ParticleView P;
    GridGeometry geo;
    float dt;
    float flip;  ///< FLIP share of the velocity update
    const PartView* parts;
    int nParts;
    template <class Nodes>
    MPM_HD StepCheck operator()(uint32_t p, const Nodes& nodes) const {
      if (!geo.stencilInside(P.x[p])) return strayParticle(p, P);
      const QuadraticStencil st(geo, P.x[p]);
      Vec3f vPic{0.f, 0.f, 0.f}, dv{0.f, 0.f, 0.f};
      Mat3f L{};
      forEachStencilGradient(st, geo.invDx, [&](int a, int b, int c, float wt, Vec3f grad) {
        const Vec3f vNew = nodes.velocity(a, b, c);
        vPic += wt * vNew;
        dv += wt * (vNew - nodes.oldVelocity(a, b, c));
        L = L + outer(vNew, grad);
      });
      P.x[p] += dt * vPic;
      P.v[p] = flip * (P.v[p] + dv) + (1.f - flip) * vPic;
      P.F[p] = (Mat3f::identity() + dt * L) * P.F[p];
      return finishParticle(p, P, geo, parts, nParts);
    }
  };

  template <class System>
  static void substep(System& s, const SubstepParams& p) {
    const ParticleView P = s.particles();
    explicitSubstep<P2G, GridUpdate>(s, p, G2P{P, s.geometry(), p.dt, p.solver.flipBlend, s.parts(), s.partCount()},
                                     P, s.geometry(), s.materials(), p.dt);
  }
};

}  // namespace mpm
