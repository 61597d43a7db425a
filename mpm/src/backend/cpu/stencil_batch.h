#pragma once
// The quadratic stencils of many particles at once, for the CPU's P2G and G2P: kLanes
// particles per SIMD vector, the same arithmetic as GridGeometry::stencilBase and
// quadraticWeights (the same fused multiply-add, clamps and floor, so the same base as
// binning found: a tile index depends on it), lane by lane. Host only (GCC / Clang vector
// extensions); elsewhere every particle builds its own stencil.
//
// Why: per particle the stencil is a chain of scalar conversions and roundings, built
// twice per substep (P2G and G2P).
#include <cstdint>

#include "backend/cpu/lanes_layout.h"
#include "backend/cpu/stress_batch.h"
#include "grid/block_grid.h"

namespace mpm {

/// The stencils of up to kRun particles, one array per field (the lanes store whole
/// vectors); at<QuadraticStencil>(q) is particle q's (transfer/stencil.h).
template <int kRun>
struct StencilRun {
  alignas(64) int base[3][kRun];
  alignas(64) float fx[3][kRun];
  alignas(64) float w[3][3][kRun];

  template <class Stencil>
  Stencil at(int q) const {
    Stencil s;
    for (int a = 0; a < 3; ++a) {
      s.base[a] = base[a][q];
      s.fx[a] = fx[a][q];
      for (int k = 0; k < 3; ++k) s.w[a][k] = w[a][k][q];
    }
    return s;
  }

  /// The stencils of particles ids[0, n) at x[ids[q]], n <= kRun: at(q) =
  /// QuadraticStencil(geo, x[ids[q]]). kWeights false: the bases only (binning's need).
  template <bool kWeights = true>
  void compute(const GridGeometry& geo, const Vec3f* x, const uint32_t* ids, int n) {
#ifdef MPM_CPU_LANES
    using simd::Floats;
    using simd::kLanes;
    static_assert(kRun % kLanes == 0, "whole vectors");
    typedef int Ints __attribute__((vector_size(4 * kLanes)));
    for (int q0 = 0; q0 < n; q0 += kLanes) {
      const int lanes = n - q0 < kLanes ? n - q0 : kLanes;
      Floats xa[3];
      simd::loadVec3Lanes(x, ids + q0, lanes, xa);
      for (int a = 0; a < 3; ++a) {
        const Floats d = xa[a] - geo.lower[a];
        Floats t;
        for (int l = 0; l < kLanes; ++l) t[l] = __builtin_fmaf(d[l], geo.invDx, -0.5f);  // one vfmadd
        const float hi = (float)geo.cells[a] + 4.f;
        t = t > -4.f ? t : simd::splat(-4.f);  // NaN takes -4, as in stencilBase
        t = t < hi ? t : simd::splat(hi);
        // floor: the truncation, one less where it rounded up (t < 0); exact, t being small
        Ints b = __builtin_convertvector(t, Ints);
        b += (Ints)(__builtin_convertvector(b, Floats) > t);
        __builtin_memcpy(&base[a][q0], &b, sizeof(b));
        if (!kWeights) continue;
        const Floats f = (t - __builtin_convertvector(b, Floats)) + 0.5f;
        Floats wa[3];
        quadraticWeights(f, wa);
        __builtin_memcpy(&fx[a][q0], &f, sizeof(f));
        for (int k = 0; k < 3; ++k) __builtin_memcpy(&w[a][k][q0], &wa[k], sizeof(Floats));
      }
    }
#else
    for (int q = 0; q < n; ++q) {  // QuadraticStencil's constructor
      int b[3];
      Vec3f f;
      geo.stencilBase(x[ids[q]], b, f);
      for (int a = 0; a < 3; ++a) {
        base[a][q] = b[a];
        if (!kWeights) continue;
        float wa[3];
        quadraticWeights(f[a], wa);
        fx[a][q] = f[a];
        for (int k = 0; k < 3; ++k) w[a][k][q] = wa[k];
      }
    }
#endif
  }

};

}  // namespace mpm
