#pragma once
// The APIC gather's sums (transfer/apic.h, apicSums) of many particles at once, for the
// CPU's G2P: a node's {mass, velocity} is a Float4, so a vector of kLanes floats holds
// kLanes / 4 particles' nodes side by side and each instruction of the separable sum serves
// all of them. Lane by lane the same arithmetic in the same order as apicSums (the same
// products, sums and fused multiply-adds), so the result is the per-particle one, bit for
// bit. Host only (GCC / Clang vector extensions); elsewhere each particle sums its own.
//
// Why: the gather is G2P's arithmetic, and per particle it runs on 4-float vectors, a
// quarter of an AVX-512 register.
#include <cstdint>
#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#include "backend/cpu/stencil_batch.h"
#include "transfer/apic.h"

namespace mpm {

/// out[q] = apicSums(st.at(q), tile) for q < n, where the tile's {mass, velocity} are `mv`
/// (kEdge^3 nodes, k fastest) from node `origin`. A particle whose stencil leaves the grid
/// (a stray, QuadraticStencil::inside false) gets no sums: G2P does not read them.
template <int kEdge, int kRun>
void apicSumsBatch(const StencilRun<kRun>& st, int n, const GridGeometry& geo, const Float4* mv, const int origin[3],
                   ApicSums* out) {
#if defined(MPM_CPU_LANES) && (defined(__clang__) || __GNUC__ >= 12)
  using simd::Floats;
  constexpr int kPer = simd::kLanes / 4;  // particles per vector
  typedef float F4 __attribute__((vector_size(16)));
  typedef float F8 __attribute__((vector_size(32)));
  // lanes 4p..4p+3 = w[p], p < kPer: the run's weights of particles q0.. are consecutive
  // floats (StencilRun computes whole vectors, so the lanes past n hold numbers too,
  // unused); reads w[0 .. kPer) only (with 1 particle per vector, q0 goes up to the run's
  // last particle)
  const auto spread = [](const float* w) {
#if defined(__AVX512F__)
    F4 w4;
    __builtin_memcpy(&w4, w, sizeof(w4));
    // one vpermps (GCC widens a shuffle of a 4-float vector to 16 lanes through the stack,
    // a store-forwarding stall per weight)
    const __m512i lanes = _mm512_set_epi32(3, 3, 3, 3, 2, 2, 2, 2, 1, 1, 1, 1, 0, 0, 0, 0);
    return (Floats)_mm512_permutexvar_ps(lanes, _mm512_castps128_ps512((__m128)w4));
#else
    Floats v;
    for (int l = 0; l < simd::kLanes; ++l) v[l] = w[l / 4];
    return v;
#endif
  };
  static_assert(kRun % 4 == 0, "whole groups of four particles in a run");
  for (int q0 = 0; q0 < n; q0 += kPer) {
    int t[kPer];  // each particle's first stencil node in the tile
    for (int p = 0; p < kPer; ++p) {
      const int q = q0 + p < n ? q0 + p : q0;  // past the end: repeat the first, unused
      const int b[3] = {st.base[0][q], st.base[1][q], st.base[2][q]};
      t[p] = geo.baseInside(b) ? ((b[0] - origin[0]) * kEdge + (b[1] - origin[1])) * kEdge + (b[2] - origin[2]) : 0;
    }
    Floats w[3][3];
    for (int a = 0; a < 3; ++a)
      for (int k = 0; k < 3; ++k) w[a][k] = spread(&st.w[a][k][q0]);
    // the particles' nodes at `offset` from their first, side by side
    const auto nodes = [&](int offset) {
      F4 n[kPer];
      for (int p = 0; p < kPer; ++p) __builtin_memcpy(&n[p], &mv[t[p] + offset], sizeof(F4));
      if constexpr (kPer == 4) {
        const F8 lo = __builtin_shufflevector(n[0], n[1], 0, 1, 2, 3, 4, 5, 6, 7);
        const F8 hi = __builtin_shufflevector(n[2], n[3], 0, 1, 2, 3, 4, 5, 6, 7);
        return __builtin_shufflevector(lo, hi, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
      } else if constexpr (kPer == 2) {
        return __builtin_shufflevector(n[0], n[1], 0, 1, 2, 3, 4, 5, 6, 7);
      } else {
        return n[0];
      }
    };
    // apicSums, with its scalar products ((float)j * w, 2 * w) taken lane by lane
    const Floats w22two = 2.f * w[2][2];
    Floats sv{}, bi{}, bj{}, bk{};
    for (int i = 0; i < 3; ++i) {
      Floats si{}, sj{}, sk{};
      for (int j = 0; j < 3; ++j) {
        const int row = (i * kEdge + j) * kEdge;
        const Floats n0 = nodes(row), n1 = nodes(row + 1), n2 = nodes(row + 2);
        const Floats s = w[2][0] * n0 + w[2][1] * n1 + w[2][2] * n2;
        const Floats u = w[2][1] * n1 + w22two * n2;
        si += w[1][j] * s;
        sj += ((float)j * w[1][j]) * s;
        sk += w[1][j] * u;
      }
      sv += w[0][i] * si;
      bi += ((float)i * w[0][i]) * si;
      bj += w[0][i] * sj;
      bk += w[0][i] * sk;
    }
    for (int p = 0; p < kPer && q0 + p < n; ++p) {
      ApicSums& o = out[q0 + p];
      __builtin_memcpy(&o.v, reinterpret_cast<const float*>(&sv) + 4 * p, sizeof(Float4));
      __builtin_memcpy(&o.bi, reinterpret_cast<const float*>(&bi) + 4 * p, sizeof(Float4));
      __builtin_memcpy(&o.bj, reinterpret_cast<const float*>(&bj) + 4 * p, sizeof(Float4));
      __builtin_memcpy(&o.bk, reinterpret_cast<const float*>(&bk) + 4 * p, sizeof(Float4));
    }
  }
#else
  for (int q = 0; q < n; ++q) {
    const QuadraticStencil s = st.template at<QuadraticStencil>(q);
    if (!s.inside(geo)) continue;
    struct TileNodes {
      const Float4* mv;
      const int* origin;
      Float4 velocity4(int i, int j, int k) const {
        return mv[((i - origin[0]) * kEdge + (j - origin[1])) * kEdge + (k - origin[2])];
      }
    } nodes{mv, origin};
    out[q] = apicSums(s, nodes);
  }
#endif
}

}  // namespace mpm
