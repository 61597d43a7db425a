#pragma once
// CpuExec::Binning's transfers by block: P2G into kept tiles and their sums per node
// (particleToGrid, sumTiles), G2P from a tile of grid velocities (Gatherer,
// gridToParticle), and each thread's share of the blocks (ownBlocks).

#include <algorithm>
#include <type_traits>
#include <vector>

#include "backend/cpu/cpu_exec.h"

namespace mpm {

/// A thread's G2P over its blocks (gridToParticle, and PB-MPM's gather before P2G in
/// particleToGrid): the block's grid velocities as a tile, a run's APIC sums, and the
/// check of the particles gathered so far.
struct CpuExec::Binning::Gatherer {
  BlockTile tile;
  ApicSums sums[kStencilRun]{};  // zeros: apicUpdateBatch reads whole vectors
  StepCheck check{0.f, 0xffffffffu};
  template <bool kOldVelocity>
  void load(const Binning& b, const GridView& grid, uint32_t block) {
    tile.setBlock(b.geo_, block);
    tile.near = b.nearParts(block);
    tile.load<kOldVelocity>(grid);
  }
  /// G2P of particles ids[0, n) (BatchesSums), their stencils in st.
  template <class F, int kRun>
  void gatherRun(const F& f, const uint32_t* ids, int n, const StencilRun<kRun>& st) {
    static_assert(kRun <= kStencilRun, "the sums hold a run");
    apicSumsBatch<BlockTile::kEdge>(st, n, f.geo, tile.mv, tile.origin, sums);
    fold(check, apicUpdateBatch(f, ids, n, st, sums, tile));
  }
};

/// P2G in two parallel passes: each occupied block's particles into its own tile,
/// kept (tiles_); then each active block's nodes sum the tiles that reach them. Each
/// thread takes its own share of the blocks in each pass (ownBlocks).
///
/// Why: the blocks had been coloured by the parity of their coordinates, eight colours
/// one after another with a barrier between, each colour's blocks flushing straight to
/// the grid (no two reach the same node). A small scene has a few blocks per colour, so
/// a thread often waited at each barrier for the other's last block: on the embedding
/// scene (9000 particles) on 2 threads 17-20 % of P2G was that wait.
///
/// The same bits: a node is reached by the tiles of its own block and of up to seven
/// neighbours below it, each of another colour, and the second pass adds them in colour
/// order to the node as cleared, the float additions the coloured flushes made. So the
/// result depends on the particles alone, not on the thread count.
///
/// `update`: the grid update (a node kernel taking the node's index in the active
/// pool), run on each block's nodes as soon as the second pass has summed them, while
/// they are in the summing thread's cache: a pass over the nodes and a wake of the team
/// fewer than a separate update (NoNodeUpdate: none).
///
/// `gather`: a G2P kernel run on each run of a block's particles just before their P2G,
/// from the grid as it was before this call, returning their StepCheck (NoGather:
/// none). PB-MPM's cycles hold the positions, so a cycle's G2P and the next cycle's P2G
/// share each particle's stencil: computed once, and the particles' v and C scattered
/// from the cache they were just gathered into. The first pass only reads the grid
/// and the second, after the barrier, writes it: the gather sees the old grid whole.
template <class F, class U, class G>
StepCheck CpuExec::Binning::particleToGrid(const F& f, bool keepCentroids, ThreadTeam& pool, int threads,
                                           const U& update, const G& gather) const {
  constexpr bool kMx = UsesCentroid<F>::value, kDmv = UsesImpulse<F>::value;
  constexpr bool kGathers = !std::is_same_v<G, NoGather>;
  constexpr int kFields = 1 + kMx + kDmv, kNodes = BlockTile::kNodes;
  const GridView grid = gridView();
  const size_t nOcc = occupied_.size();
  if (tiles_.size() < nOcc * kFields * kNodes) tiles_.resize(nOcc * kFields * kNodes);
  const int team = (long long)nOcc >= kMinParallelBlocks ? threads : 1;
  std::vector<StepCheck> checks(kGathers ? (size_t)team : 0);  // per thread; max and min in any order
  pool.run(team, [&](int t, int nt) {
    P2GTile tile;
    thread_local CellScatter cells;  // grows to the largest block once per thread
    tile.cells = &cells;
    Mat3f tau[kStressRun];  // BatchesStress / BatchesProjection: the next particles' tau or C_c
    static_assert(!BatchesStencil<F>::value || BatchesStress<F>::value || BatchesProjection<F>::value,
                  "a batched stencil comes with the stress or the projection");
    static_assert(!BatchesProjection<F>::value || BatchesStencil<F>::value, "the projection comes with the stencil");
    using Stencil = typename BatchesStencil<F>::Stencil;
    StencilRun<kStressRun> st;  // BatchesStencil: their stencils
    static_assert(!kGathers || (BatchesProjection<F>::value && BatchesSums<G>::value &&
                                std::is_same_v<Stencil, typename BatchesStencil<G>::Stencil>),
                  "a gather before P2G shares the projection's batched stencils");
    [[maybe_unused]] std::conditional_t<kGathers, Gatherer, NoGather> g;
    uint32_t first, last;
    ownBlocks(t, nt, first, last);
    for (uint32_t j = first; j < last; ++j) {
      tile.setBlock(geo_, occupied_[j]);
      tile.clear<kMx, kDmv>();
      cells.reserve(start_[j + 1] - start_[j]);
      if constexpr (kGathers) g.template load<UsesOldVelocity<G>::value>(*this, grid, occupied_[j]);
      if constexpr (BatchesStress<F>::value || BatchesProjection<F>::value) {
        for (uint32_t r = start_[j]; r < start_[j + 1];) {
          const int n = (int)std::min<uint32_t>(kStressRun, start_[j + 1] - r);
          if constexpr (kGathers) {
            st.compute(f.geo, f.P.x, &order_[r], n);
            g.gatherRun(gather, &order_[r], n, st);
          }
          if constexpr (BatchesStress<F>::value)
            kirchhoffStressBatch(f.materials, f.P.object, f.P.F, &order_[r], n, tau);
          else
            pbProjectionBatch(f.P.F, f.P.C, &order_[r], n, f.dt, f.relaxation, f.rigidity, tau);
          if constexpr (BatchesStencil<F>::value) {
            if constexpr (!kGathers) st.compute(f.geo, f.P.x, &order_[r], n);
            for (int q = 0; q < n; ++q) {
              if constexpr (BatchesStress<F>::value)
                f.scatterStressed(order_[r + q], st.template at<Stencil>(q), tau[q], tile);
              else
                f.scatterProjected(order_[r + q], st.template at<Stencil>(q), tau[q], tile);
            }
          } else {
            for (int q = 0; q < n; ++q) f.scatterStressed(order_[r + q], tau[q], tile);
          }
          r += n;
        }
      } else {
        for (uint32_t r = start_[j]; r < start_[j + 1]; ++r) f(order_[r], tile);
      }
      // the material centroids only where the contact pass will read them
      const bool centroids = kMx && (!centroidsSelected_ || centroidRank_[j]);
      if (centroids)
        tile.finish<kMx>();
      else
        tile.finish<false>();
      Float4* kept = &tiles_[(size_t)j * kFields * kNodes];
      std::copy(tile.mv, tile.mv + kNodes, kept);
      if (centroids) std::copy(tile.mx, tile.mx + kNodes, kept + kNodes);
      if constexpr (kDmv) std::copy(tile.dmv, tile.dmv + kNodes, kept + (1 + kMx) * kNodes);
    }
    if constexpr (kGathers) checks[(size_t)t] = g.check;
    pool.barrier(nt);
    const size_t nActive = active_.size();
    for (size_t a = nActive * t / nt, aEnd = nActive * (t + 1) / nt; a < aEnd; ++a) {
      if (kMx && (!centroidsSelected_ || centroidSlot_[a]))
        sumTiles<kMx, kDmv, kMx>(grid, (uint32_t)a, keepCentroids);
      else
        sumTiles<kMx, kDmv, false>(grid, (uint32_t)a, keepCentroids);
      if constexpr (!std::is_same_v<U, NoNodeUpdate>)
        for (size_t n = a * kBlockNodes, nEnd = n + kBlockNodes; n < nEnd; ++n) update(n);
    }
  });
  // the same particles scattered again with their centroids kept (PB-MPM's later
  // cycles) leave each node's mass, centroid and touch as they were: the contacts hold
  if (!keepCentroids) contactsFound_ = false;
  return combined(checks);
}

/// Active block `slot`'s nodes: cleared (clearNode), then the kept tiles that reach
/// them added in colour order (particleToGrid). The tile of the block d below (d in
/// {0, 1}^3, in blocks) reaches its nodes 0..3 - 2 d along each axis. The tiles hold
/// kMx (centroids) and kDmv fields; kSumMx: the centroids are summed (else left as
/// cleared).
template <bool kMx, bool kDmv, bool kSumMx>
void CpuExec::Binning::sumTiles(const GridView& grid, uint32_t slot, bool keepCentroids) const {
  constexpr int kFields = 1 + kMx + kDmv, kEdge = BlockTile::kEdge, kNodes = BlockTile::kNodes;
  int c[3];
  geo_.blockCoords(active_[slot], c[0], c[1], c[2]);
  const int colour = (c[0] & 1) | ((c[1] & 1) << 1) | ((c[2] & 1) << 2);
  int end[3];  // the block's nodes on the grid (a block may reach past its last node)
  for (int a = 0; a < 3; ++a) end[a] = std::min(kBlockSize, geo_.cells[a] - (c[a] << kBlockBits) + 1);
  GridNode* nodes = grid.nodes + (size_t)slot * kBlockNodes;
  for (int n = 0; n < kBlockNodes; ++n) clearNode(nodes[n], keepCentroids);
  for (int k = 0; k < 8; ++k) {
    const int d = k ^ colour;  // the block below with colour k: its coordinates' parities differ where d is 1
    const int dx = d & 1, dy = (d >> 1) & 1, dz = (d >> 2) & 1;
    if (c[0] < dx || c[1] < dy || c[2] < dz) continue;
    const int32_t rank = occupiedRank_[geo_.blockIndex(c[0] - dx, c[1] - dy, c[2] - dz)];
    if (rank < 0) continue;
    const Float4* tile = &tiles_[(size_t)rank * kFields * kNodes];
    const int iEnd = std::min(end[0], kEdge - kBlockSize * dx), jEnd = std::min(end[1], kEdge - kBlockSize * dy),
              kEnd = std::min(end[2], kEdge - kBlockSize * dz);
    for (int i = 0; i < iEnd; ++i)
      for (int j = 0; j < jEnd; ++j)
        for (int l = 0; l < kEnd; ++l) {
          const int t = ((kBlockSize * dx + i) * kEdge + (kBlockSize * dy + j)) * kEdge + (kBlockSize * dz + l);
          GridNode& g = nodes[(i << (2 * kBlockBits)) | (j << kBlockBits) | l];
          g.mass += tile[t][0];
          g.mv += tile[t].xyz();
          if constexpr (kSumMx) {
            g.touch += tile[kNodes + t][0];
            g.mx += tile[kNodes + t].xyz();
          }
          if constexpr (kDmv) g.dmv += tile[(1 + kMx) * kNodes + t].xyz();
        }
  }
}

/// G2P by blocks (any order: reads only), each from a tile of grid velocities, each
/// thread its share of them (ownBlocks).
template <class F>
StepCheck CpuExec::Binning::gridToParticle(const F& f, ThreadTeam& pool, int threads) const {
  const GridView grid = gridView();
  const int nt = (long long)occupied_.size() >= kMinParallelBlocks ? threads : 1;
  std::vector<StepCheck> checks((size_t)nt);  // per thread; max and min in any order
  pool.run(nt, [&](int t, int) {
    Gatherer g;
    using Stencil = typename BatchesStencil<F>::Stencil;
    StencilRun<kStencilRun> st;  // BatchesStencil: the next particles'
    uint32_t first, last;
    ownBlocks(t, nt, first, last);
    for (uint32_t j = first; j < last; ++j) {
      g.load<UsesOldVelocity<F>::value>(*this, grid, occupied_[j]);
      if constexpr (BatchesStencil<F>::value) {
        for (uint32_t r = start_[j]; r < start_[j + 1];) {
          const int n = (int)std::min<uint32_t>(kStencilRun, start_[j + 1] - r);
          st.compute(f.geo, f.P.x, &order_[r], n);
          if constexpr (BatchesSums<F>::value) {
            g.gatherRun(f, &order_[r], n, st);
          } else {
            for (int q = 0; q < n; ++q)
              fold(g.check, f.gatherSummed(order_[r + q], st.template at<Stencil>(q), nullptr, g.tile));
          }
          r += n;
        }
      } else {
        for (uint32_t r = start_[j]; r < start_[j + 1]; ++r) fold(g.check, f(order_[r], g.tile));
      }
    }
    checks[(size_t)t] = g.check;
  });
  return combined(checks);
}

/// Thread t of nt's share of the occupied blocks, ranks [first, last): contiguous, and
/// about a nt-th of the particles (from the first block whose particles start at or
/// after t n / nt). The transfers split the blocks so, not one block at a time to
/// whichever thread is free: a thread then gathers, in G2P, the particles it scatters
/// in the next P2G, and sums (P2G's second pass, active blocks split likewise) most of
/// the nodes it gathers from, so what it wrote is still in its own core's cache. Handed
/// out one at a time, 2 threads at 125k particles took 20 % more CPU time than one
/// (MLS-MPM, 113-117 against 94.5 ms a frame; two one-thread runs side by side ran at
/// one's speed alone): split, 97-100 ms, and a frame 58.7-60.3 -> 50.5-52.3 ms.
inline void CpuExec::Binning::ownBlocks(int t, int nt, uint32_t& first, uint32_t& last) const {
  const uint32_t nOcc = (uint32_t)occupied_.size();
  if (nOcc == 0) {
    first = last = 0;
    return;
  }
  const size_t n = start_[nOcc];
  const auto from = [&](int k) -> uint32_t {
    if (k <= 0) return 0u;
    if (k >= nt) return nOcc;
    const uint32_t target = (uint32_t)(n * (size_t)k / (size_t)nt);
    return (uint32_t)(std::lower_bound(start_.begin(), start_.begin() + nOcc, target) - start_.begin());
  };
  first = from(t);
  last = from(t + 1);
}

}  // namespace mpm
