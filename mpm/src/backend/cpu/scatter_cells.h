#pragma once
// P2G's APIC scatter summed by stencil cell (CPU).
//
// A block's particles whose stencils start at the same node reach the same 27 nodes. They
// are recorded (their ApicTerms and weights) and summed cell by cell in registers, then
// added to the tile once per cell (about 8 particles at the usual 2^3 per cell); with
// AVX-512 a stencil row of three nodes (side by side in the tile, k fastest) is one
// 16-float vector, so a particle's row is a multiply and two multiply-adds.
//
// Why both: P2G's scatter node by node was bound by its instruction count, not by its adds
// to the tile. Summing by cell alone took about 5 % off P2G, rows of three alone nothing (a
// row's load then waited on the previous particle's overlapping store); together about 15 %
// (MLS-MPM and PB-MPM, embedding scene). Taking a particle's nine rows at once from its row
// terms q_ik, w_ik (apicScatterTerms's factoring) took P2G's share at 125k particles from
// about 54 % to 51.5 %.
//
// Order: each cell's particles are summed in the order they were recorded (the block's
// particle order), the cells in index order, and the cells' sums are added to the tile after
// any particle the kernel wrote straight to it (a cut particle). That order is fixed by the
// particles alone, so the result is the same on any thread count.
#include <cstdint>
#include <vector>
#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#include "grid/block_grid.h"
#include "transfer/apic.h"

namespace mpm {

class CellScatter {
 public:
  static constexpr int kCells = kBlockNodes;  ///< stencil bases a block's particles can have

  /// Room for n more particles (before recording them: record does not grow the buffers).
  void reserve(uint32_t n) {
    if (entries_.size() < count_ + n) {
      entries_.resize(count_ + n);
      cell_.resize(count_ + n);
    }
  }
  /// Records a particle whose stencil base is node `cell` of the block ((i * 4 + j) * 4 + k).
  /// Member by member: a copy of the whole struct read back as wider vectors what was just
  /// stored in narrower ones (a store-forwarding stall on every particle).
  void record(int cell, const float (&w)[3][3], const ApicTerms& t) {
    Entry& e = entries_[count_];
    e.t.q0 = t.q0;
    e.t.qx = t.qx;
    e.t.qy = t.qy;
    e.t.qz = t.qz;
    e.t.mx4 = t.mx4;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) e.w[a][b] = w[a][b];
    cell_[count_++] = (uint8_t)cell;
  }

  /// Adds the recorded particles, summed cell by cell, to a tile of kEdge^3 nodes whose
  /// first node is the block's first (mv: {mass, momentum}; mx with kCentroid: {w m touch,
  /// w m x}), and forgets them.
  template <bool kCentroid, int kEdge>
  void flush(Float4* mv, Float4* mx) {
    const uint32_t n = count_;
    if (n == 0) return;
    // a stable counting sort by cell
    uint32_t start[kCells + 1] = {};
    for (uint32_t e = 0; e < n; ++e) ++start[cell_[e] + 1];
    for (int c = 0; c < kCells; ++c) start[c + 1] += start[c];
    order_.resize(n);
    uint32_t cursor[kCells];
    for (int c = 0; c < kCells; ++c) cursor[c] = start[c];
    for (uint32_t e = 0; e < n; ++e) order_[cursor[cell_[e]]++] = e;

    for (int c = 0; c < kCells; ++c) {
      if (start[c] == start[c + 1]) continue;
      const int ci = c / (kBlockSize * kBlockSize), cj = (c / kBlockSize) % kBlockSize, ck = c % kBlockSize;
#if defined(__AVX512F__) && defined(MPM_FLOAT4_VECTOR)
      sumCellRows<kCentroid, kEdge>(start[c], start[c + 1], ((ci * kEdge + cj) * kEdge + ck), mv, mx);
#else
      // this cell's particles through apicScatterTerms into 27 sums (stencil base 0), in order
      CellSums sums;
      QuadraticStencil st;
      st.base[0] = st.base[1] = st.base[2] = 0;
      for (uint32_t o = start[c]; o < start[c + 1]; ++o) {
        const Entry& e = entries_[order_[o]];
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) st.w[a][b] = e.w[a][b];
        apicScatterTerms<kCentroid>(st, e.t, sums);
      }
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          for (int k = 0; k < 3; ++k) {
            const int node = ((ci + i) * kEdge + (cj + j)) * kEdge + (ck + k), q = (i * 3 + j) * 3 + k;
            mv[node] += sums.mv[q];
            if constexpr (kCentroid) mx[node] += sums.mx[q];
          }
#endif
    }
    count_ = 0;
  }

 private:
  /// A cell's 27 stencil nodes (offsets 0..2 along each axis) as apicScatterTerms's `Nodes`.
  struct CellSums {
    Float4 mv[27], mx[27];
    CellSums() {
      for (int q = 0; q < 27; ++q) mv[q] = mx[q] = Float4::zero();
    }
    void add(int i, int j, int k, const Float4& v) { mv[(i * 3 + j) * 3 + k] += v; }
    void addCentroid(int i, int j, int k, const Float4& v) { mx[(i * 3 + j) * 3 + k] += v; }
  };

#if defined(__AVX512F__) && defined(MPM_FLOAT4_VECTOR)
  /// One cell's particles (order_[first, last)) added to the tile from node `n0` (the
  /// cell's first stencil node): a stencil row of three nodes (k fastest, side by side in
  /// the tile) is one 16-float vector (the fourth node's lanes zero and never stored), and
  /// the cell's nine rows are summed in registers, particle by particle. A particle's rows
  /// share q_ik and w_ik along the row (one vector each per i), so a row is one multiply
  /// and two multiply-adds. Lane by lane apicScatterTerms's arithmetic: the same bits as
  /// the path without AVX-512 on a machine with fused multiply-adds.
  template <bool kCentroid, int kEdge>
  void sumCellRows(uint32_t first, uint32_t last, int n0, Float4* mv, Float4* mx) const {
    constexpr __mmask16 kRow = 0x0fff;
    const __m512i spread = _mm512_set_epi32(3, 3, 3, 3, 2, 2, 2, 2, 1, 1, 1, 1, 0, 0, 0, 0);
    const __m512 kOf = _mm512_set_ps(0, 0, 0, 0, 2, 2, 2, 2, 1, 1, 1, 1, 0, 0, 0, 0);
    __m512 sm[9], sx[kCentroid ? 9 : 1];
    for (__m512& s : sm) s = _mm512_setzero_ps();
    for (__m512& s : sx) s = _mm512_setzero_ps();
    for (uint32_t o = first; o < last; ++o) {
      const Entry& e = entries_[order_[o]];
      const __m512 w2 = _mm512_permutexvar_ps(spread, _mm512_castps128_ps512(_mm_maskz_loadu_ps(0x7, e.w[2])));
      const __m512 qy = _mm512_broadcast_f32x4((__m128)e.t.qy.v);
      const __m512 qz = _mm512_broadcast_f32x4((__m128)e.t.qz.v);
      const __m512 x4 = _mm512_broadcast_f32x4((__m128)e.t.mx4.v);
      for (int i = 0; i < 3; ++i) {
        const Float4 qi = e.t.q0 + (float)i * e.t.qx;
        const __m512 qik = _mm512_maskz_fmadd_ps(kRow, kOf, qz, _mm512_broadcast_f32x4((__m128)qi.v));
        const __m512 wik = _mm512_mul_ps(_mm512_set1_ps(e.w[0][i]), w2);
        for (int j = 0; j < 3; ++j) {
          // q_ik + j qy as a multiply-add for every j (j = 0 too): apicScatterTerms's rounding
          const __m512 q = _mm512_fmadd_ps(_mm512_set1_ps((float)j), qy, qik);
          const __m512 wt = _mm512_mul_ps(_mm512_set1_ps(e.w[1][j]), wik);
          sm[3 * i + j] = _mm512_fmadd_ps(wt, q, sm[3 * i + j]);
          if constexpr (kCentroid) sx[3 * i + j] = _mm512_maskz_fmadd_ps(kRow, wt, x4, sx[3 * i + j]);
        }
      }
    }
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        float* pm = reinterpret_cast<float*>(mv + n0 + (i * kEdge + j) * kEdge);
        _mm512_mask_storeu_ps(pm, kRow, _mm512_add_ps(_mm512_maskz_loadu_ps(kRow, pm), sm[3 * i + j]));
        if constexpr (kCentroid) {
          float* px = reinterpret_cast<float*>(mx + n0 + (i * kEdge + j) * kEdge);
          _mm512_mask_storeu_ps(px, kRow, _mm512_add_ps(_mm512_maskz_loadu_ps(kRow, px), sx[3 * i + j]));
        }
      }
  }
#endif

  struct Entry {
    ApicTerms t;
    float w[3][3];
  };
  std::vector<Entry> entries_;
  std::vector<uint8_t> cell_;
  std::vector<uint32_t> order_;
  uint32_t count_ = 0;
};

}  // namespace mpm
