#pragma once
// MLS-MPM (Hu et al. 2018; seed 000 eqs. 9-12) as per-particle host/device functions.
// P2G fuses the APIC momentum and the stress force: the affine matrix
//   A = m C - dt V0 (4 / dx^2) tau,   tau = P F^T (Kirchhoff stress),
// and G2P rebuilds v and C from the updated grid and advances F <- (I + dt C) F.
#include "core/constitutive.h"
#include "core/particle_state.h"
#include "grid/block_grid.h"

namespace mpm {

/// Scatter of one particle to its 27 stencil nodes. `Add` is the backend's accumulate
/// (a plain += where blocks are coloured on the CPU, atomicAdd on the GPU).
template <class Add>
MPM_HD void mlsP2G(uint32_t p, const ParticleView& P, const GridView& grid,
                   const MaterialParams* materials, float dt) {
  const float dx = grid.geo.dx;
  const float Dinv = 4.f * grid.geo.invDx * grid.geo.invDx;
  int base[3];
  Vec3f fx;
  grid.geo.stencilBase(P.x[p], base, fx);
  float w[3][3];
  for (int a = 0; a < 3; ++a) quadraticWeights(fx[a], w[a]);

  const float m = P.mass[p];
  const Mat3f tau = kirchhoffStress(materials[P.object[p]], P.F[p]);
  const Mat3f affine = m * P.C[p] - (dt * P.volume0[p] * Dinv) * tau;
  const Vec3f mv = m * P.v[p];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) {
        const Vec3f dpos{((float)i - fx.x) * dx, ((float)j - fx.y) * dx, ((float)k - fx.z) * dx};
        const float wt = w[0][i] * w[1][j] * w[2][k];
        GridNode& node = grid.node(base[0] + i, base[1] + j, base[2] + k);
        const Vec3f dmv = wt * (mv + affine * dpos);
        Add::add(node.mass, wt * m);
        Add::add(node.mv.x, dmv.x);
        Add::add(node.mv.y, dmv.y);
        Add::add(node.mv.z, dmv.z);
      }
}

/// Gather of one particle from the updated grid; moves it and advances F.
/// Returns false if the particle's state is no longer finite or its stencil left the grid.
MPM_HD bool mlsG2P(uint32_t p, const ParticleView& P, const GridView& grid, float dt) {
  const float dx = grid.geo.dx;
  const float Dinv = 4.f * grid.geo.invDx * grid.geo.invDx;
  int base[3];
  Vec3f fx;
  grid.geo.stencilBase(P.x[p], base, fx);
  float w[3][3];
  for (int a = 0; a < 3; ++a) quadraticWeights(fx[a], w[a]);

  Vec3f v{0.f, 0.f, 0.f};
  Mat3f B;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) {
        const Vec3f dpos{((float)i - fx.x) * dx, ((float)j - fx.y) * dx, ((float)k - fx.z) * dx};
        const float wt = w[0][i] * w[1][j] * w[2][k];
        const Vec3f vi = grid.node(base[0] + i, base[1] + j, base[2] + k).mv;
        v += wt * vi;
        B = B + outer(wt * vi, dpos);
      }
  const Mat3f C = Dinv * B;
  const Vec3f x = P.x[p] + dt * v;
  P.v[p] = v;
  P.C[p] = C;
  P.x[p] = x;
  P.F[p] = (Mat3f::identity() + dt * C) * P.F[p];
  const float check = x.x + x.y + x.z + v.x + v.y + v.z + trace(P.F[p]);
  return isFinite(check) && grid.geo.stencilInside(x);
}

}  // namespace mpm
