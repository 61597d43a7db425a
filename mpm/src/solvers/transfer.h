#pragma once
// What every particle-grid solver shares: the quadratic B-spline stencil (weights and
// their gradients), the APIC scatter and gather (seed 000 eqs. 10-11), the node accessor
// through the block table, and the per-particle end-of-substep checks. The solvers in
// this folder are compositions of these pieces; none of them repeats one.
#include "core/particle_state.h"
#include "core/substep.h"
#include "grid/block_grid.h"
#include "shapes/shape_kernels.h"

namespace mpm {

/// A particle's 3x3x3 quadratic B-spline stencil: lowest node, offset from it (in cells)
/// and the weights along each axis.
struct QuadraticStencil {
  int base[3];
  Vec3f fx;
  float w[3][3];
  MPM_HD QuadraticStencil(const GridGeometry& geo, Vec3f x) {
    geo.stencilBase(x, base, fx);
    for (int a = 0; a < 3; ++a) quadraticWeights(fx[a], w[a]);
  }
  /// d w / d x along axis a for the three nodes [1/m] (standard MPM's force and L).
  MPM_HD void gradients(float invDx, float dw[3][3]) const {
    for (int a = 0; a < 3; ++a) {
      dw[a][0] = -(1.5f - fx[a]) * invDx;
      dw[a][1] = -2.f * (fx[a] - 1.f) * invDx;
      dw[a][2] = (fx[a] - 0.5f) * invDx;
    }
  }
};

/// Calls f(i, j, k, w, grad w) for the 27 nodes of a stencil: node (base + (i, j, k)), its
/// weight and its weight gradient [1/m] (the standard-MPM transfers need both).
template <class F>
MPM_HD void forEachStencilGradient(const QuadraticStencil& st, float invDx, F f) {
  float dw[3][3];
  st.gradients(invDx, dw);
  const float(&w)[3][3] = st.w;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k)
        f(st.base[0] + i, st.base[1] + j, st.base[2] + k, w[0][i] * w[1][j] * w[2][k],
          Vec3f{dw[0][i] * w[1][j] * w[2][k], w[0][i] * dw[1][j] * w[2][k], w[0][i] * w[1][j] * dw[2][k]});
}

/// 1 / M_p of the quadratic B-spline APIC/MLS transfers, 4 / dx^2 [1/m^2].
MPM_HD float apicInverseInertia(const GridGeometry& geo) { return 4.f * geo.invDx * geo.invDx; }

/// APIC scatter of one particle: node momentum w (mv + A (x_i - x_p)) and mass w m.
/// `affine` is A: m C for APIC and PB-MPM, m C - dt V0 M^-1 tau for MLS-MPM. `Nodes` is
/// where the nodes live (the global grid with the backend's accumulate, or a CPU block
/// tile). kCentroid: also accumulate w m x_p (only shape contact needs it).
template <bool kCentroid, class Nodes>
MPM_HD void apicScatter(const QuadraticStencil& st, float dx, float m, Vec3f mv, const Mat3f& affine, Vec3f xp,
                        Nodes& nodes) {
  const int* base = st.base;
  const float(&w)[3][3] = st.w;
  // momentum at node offset d: mv + A d, built incrementally along each axis
  const Vec3f d0{-st.fx.x * dx, -st.fx.y * dx, -st.fx.z * dx};
  const Vec3f a0 = mv + affine * d0;
  const Vec3f ax = dx * affine.column(0), ay = dx * affine.column(1), az = dx * affine.column(2);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const Vec3f aij = a0 + (float)i * ax + (float)j * ay;
      const float wij = w[0][i] * w[1][j];
      for (int k = 0; k < 3; ++k) {
        const float wt = wij * w[2][k];
        if constexpr (kCentroid)
          nodes.add(base[0] + i, base[1] + j, base[2] + k, wt * m, wt * (aij + (float)k * az), (wt * m) * xp);
        else
          nodes.add(base[0] + i, base[1] + j, base[2] + k, wt * m, wt * (aij + (float)k * az));
      }
    }
}

/// APIC gather from the updated grid: v = sum w v_i and C = M^-1 sum w v_i (x_i - x_p)^T.
template <class Nodes>
MPM_HD void apicGather(const QuadraticStencil& st, const GridGeometry& geo, const Nodes& nodes, Vec3f& v,
                       Mat3f& C) {
  const int* base = st.base;
  const float(&w)[3][3] = st.w;
  const float dx = geo.dx;
  // B = sum w v (x_i - x_p)^T, accumulated as sum (w v) i^T dx minus (sum w v) fx^T dx
  v = Vec3f{0.f, 0.f, 0.f};
  Vec3f bi{0.f, 0.f, 0.f}, bj{0.f, 0.f, 0.f}, bk{0.f, 0.f, 0.f};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const float wij = w[0][i] * w[1][j];
      for (int k = 0; k < 3; ++k) {
        const Vec3f wv = (wij * w[2][k]) * nodes.velocity(base[0] + i, base[1] + j, base[2] + k);
        v += wv;
        bi += (float)i * wv;
        bj += (float)j * wv;
        bk += (float)k * wv;
      }
    }
  const Vec3f fx = st.fx;
  C = apicInverseInertia(geo) *
      Mat3f::fromColumns(dx * (bi - fx.x * v), dx * (bj - fx.y * v), dx * (bk - fx.z * v));
}

/// The end of every solver's G2P: push the particle out of the shapes it ended inside,
/// then check it (state finite, stencil on the grid) and report its speed.
MPM_HD StepCheck finishParticle(uint32_t p, const ParticleView& P, const GridGeometry& geo, const PartView* parts,
                                int nParts) {
  StepCheck c;
  const Vec3f x = P.x[p], v = P.v[p];
  const float sum = x.x + x.y + x.z + v.x + v.y + v.z + trace(P.F[p]);
  if (!isFinite(sum) || !geo.stencilInside(x)) c.firstBadParticle = p;
  if (nParts) pushOutOfParts(P.x[p], parts, nParts);
  c.maxSpeed2 = dot(v, v);
  return c;
}

/// A particle whose stencil already left the grid keeps its state (G2P would read nodes
/// that do not exist) and is reported.
MPM_HD StepCheck strayParticle(uint32_t p, const ParticleView& P) {
  StepCheck c;
  c.firstBadParticle = p;
  c.maxSpeed2 = dot(P.v[p], P.v[p]);
  return c;
}

/// P2G through the kernel template K<kCentroid>: with the material centroid w m x_p only
/// when the scene has shapes (contact needs it; a scene without shapes does not pay).
template <template <bool> class K, class System, class... Args>
void scatterParticles(System& s, const Args&... args) {
  if (s.hasShapes())
    s.scatter(K<true>{args...});
  else
    s.scatter(K<false>{args...});
}

/// The substep of an explicit solver (MLS-MPM, standard MPM): bin, clear, P2G, grid
/// update, rigid contact and bodies, G2P. P2G<kCentroid> is built from `p2gArgs`; the
/// grid kernel (fields grid, dt, gravity, walls) only after binning, which sets the grid.
template <template <bool> class P2G, class GridKernel, class System, class G2PKernel, class... P2GArgs>
void explicitSubstep(System& s, const SubstepParams& p, const G2PKernel& g2p, const P2GArgs&... p2gArgs) {
  s.binParticles();
  s.clearGrid();
  scatterParticles<P2G>(s, p2gArgs...);
  s.updateGrid(GridKernel{s.grid(), p.dt, p.gravity, p.walls});
  s.placeShapes();
  s.exchangeContact(p.dt, true);
  s.moveShapes(p.dt);
  s.gather(g2p);
}

/// Stencil nodes reached through the block table, accumulated with `Add` (GPU atomics).
template <class Add>
struct GridNodes {
  GridView grid;
  MPM_HD void add(int i, int j, int k, float m, Vec3f mv) const {
    GridNode& n = grid.node(i, j, k);
    Add::add(n.mass, m);
    Add::add(n.mv.x, mv.x);
    Add::add(n.mv.y, mv.y);
    Add::add(n.mv.z, mv.z);
  }
  MPM_HD void add(int i, int j, int k, float m, Vec3f mv, Vec3f mx) const {
    add(i, j, k, m, mv);
    GridNode& n = grid.node(i, j, k);
    Add::add(n.mx.x, mx.x);
    Add::add(n.mx.y, mx.y);
    Add::add(n.mx.z, mx.z);
  }
  MPM_HD void addStressImpulse(int i, int j, int k, Vec3f dmv) const {
    GridNode& n = grid.node(i, j, k);
    Add::add(n.dmv.x, dmv.x);
    Add::add(n.dmv.y, dmv.y);
    Add::add(n.dmv.z, dmv.z);
  }
  MPM_HD Vec3f velocity(int i, int j, int k) const { return grid.node(i, j, k).mv; }
  MPM_HD Vec3f oldVelocity(int i, int j, int k) const { return grid.node(i, j, k).dmv; }
};

}  // namespace mpm
