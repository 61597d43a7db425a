#pragma once
// The quadratic B-spline stencil every particle-grid transfer runs over: a particle's
// lowest node, its offset from it and the weights (and their gradients) along each axis.
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
  /// Filled by the CPU for many particles at once (backend/cpu/stencil_batch.h).
  QuadraticStencil() = default;
  /// The whole stencil lies on grid nodes (GridGeometry::stencilInside of the same x).
  MPM_HD bool inside(const GridGeometry& geo) const { return geo.baseInside(base); }
  /// d w / d x along axis a for the three nodes [1/m] (standard MPM's force and L).
  MPM_HD void gradients(float invDx, float dw[3][3]) const {
    for (int a = 0; a < 3; ++a) {
      dw[a][0] = -(1.5f - fx[a]) * invDx;
      dw[a][1] = -2.f * (fx[a] - 1.f) * invDx;
      dw[a][2] = (fx[a] - 0.5f) * invDx;
    }
  }
};

/// 1 / M_p of the quadratic B-spline APIC/MLS transfers, 4 / dx^2 [1/m^2].
MPM_HD float apicInverseInertia(const GridGeometry& geo) { return 4.f * geo.invDx * geo.invDx; }

}  // namespace mpm
