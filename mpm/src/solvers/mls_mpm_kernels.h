#pragma once
// MLS-MPM (Hu et al. 2018; seed 000 eqs. 9-12) as per-particle host/device functions.
// P2G fuses the APIC momentum and the stress force: the affine matrix
//   A = m C - dt V0 (4 / dx^2) tau,   tau = P F^T (Kirchhoff stress),
// and G2P rebuilds v and C from the updated grid and advances F <- (I + dt C) F.
#include "core/constitutive.h"
#include "core/particle_state.h"
#include "grid/block_grid.h"

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
};

/// Scatter of one particle to its 27 stencil nodes. `Nodes` is where they live: the
/// global grid with the backend's accumulate (GPU atomics), or a block's tile on the CPU.
/// kCentroid: also accumulate w m x_p (needed by shape contact only).
template <bool kCentroid, class Nodes>
MPM_HD void mlsP2G(uint32_t p, const ParticleView& P, const GridGeometry& geo, Nodes& nodes,
                   const MaterialParams* materials, float dt) {
  const float dx = geo.dx;
  const float Dinv = 4.f * geo.invDx * geo.invDx;
  const QuadraticStencil st(geo, P.x[p]);
  const int* base = st.base;
  const Vec3f fx = st.fx;
  const float(&w)[3][3] = st.w;

  const float m = P.mass[p];
  const Mat3f tau = kirchhoffStress(materials[P.object[p]], P.F[p]);
  const Mat3f affine = m * P.C[p] - (dt * P.volume0[p] * Dinv) * tau;
  const Vec3f mv = m * P.v[p];
  const Vec3f xp = P.x[p];
  // momentum at node offset d: mv + A d, built incrementally along each axis
  const Vec3f d0{-fx.x * dx, -fx.y * dx, -fx.z * dx};
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

/// Gather of one particle from the updated grid; moves it and advances F.
/// Returns false if the particle's state is no longer finite or its stencil left the grid.
template <class Nodes>
MPM_HD bool mlsG2P(uint32_t p, const ParticleView& P, const GridGeometry& geo, const Nodes& nodes,
                   float dt) {
  const float dx = geo.dx;
  const float Dinv = 4.f * geo.invDx * geo.invDx;
  const QuadraticStencil st(geo, P.x[p]);
  const int* base = st.base;
  const Vec3f fx = st.fx;
  const float(&w)[3][3] = st.w;

  // B = sum w v (x_i - x_p)^T, accumulated as sum (w v) i^T dx minus (sum w v) fx^T dx
  Vec3f v{0.f, 0.f, 0.f}, bi{0.f, 0.f, 0.f}, bj{0.f, 0.f, 0.f}, bk{0.f, 0.f, 0.f};
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
  const Mat3f B = Mat3f::fromColumns(dx * (bi - fx.x * v), dx * (bj - fx.y * v), dx * (bk - fx.z * v));
  const Mat3f C = Dinv * B;
  const Vec3f x = P.x[p] + dt * v;
  P.v[p] = v;
  P.C[p] = C;
  P.x[p] = x;
  P.F[p] = (Mat3f::identity() + dt * C) * P.F[p];
  const float check = x.x + x.y + x.z + v.x + v.y + v.z + trace(P.F[p]);
  return isFinite(check) && geo.stencilInside(x);
}

/// Stencil nodes reached through the block table, accumulated with `Add`.
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
  MPM_HD Vec3f velocity(int i, int j, int k) const { return grid.node(i, j, k).mv; }
};

}  // namespace mpm
