#pragma once
// The CUDA backend's transfers (CudaExec::particleToGrid, gridToParticle): one CUDA block per
// occupied grid block, whose particles reach only the 6^3 nodes of a tile (the CPU's
// BlockTile), kept in shared memory. Binning (cuda_exec.cuh) hands them the particles sorted
// by block and, within a block, by stencil cell, and each block's run in that order.
#include <cuda_runtime.h>

#include "core/substep.h"
#include "transfer/apic.h"
#include "transfer/grid_nodes.h"

namespace mpm {

/// GPU threads of different particles meet on the same node: accumulate atomically.
struct AtomicAdd {
  MPM_HD static void add(float& a, float b) {
#ifdef __CUDA_ARCH__
    atomicAdd(&a, b);
#else
    a += b;
#endif
  }
};

/// Adds to a float in shared memory. The hardware has no float add there: ptxas makes it a
/// compare-and-swap loop, which is why the lanes of a warp sum their shares first (WarpGroup).
/// Written with the shared address so that the loop needs no test of the address space.
__device__ inline void sharedAdd(float* p, float v) {
  asm volatile("red.shared.add.f32 [%0], %1;" ::"r"((unsigned)__cvta_generic_to_shared(p)), "f"(v) : "memory");
}

/// The largest and smallest value over the 32 lanes of a warp, all of them here.
__device__ inline unsigned warpMax(unsigned v) {
#if __CUDA_ARCH__ >= 800
  return __reduce_max_sync(0xffffffffu, v);
#else
  for (int s = 16; s > 0; s >>= 1) v = max(v, __shfl_xor_sync(0xffffffffu, v, s));
  return v;
#endif
}
__device__ inline unsigned warpMin(unsigned v) {
#if __CUDA_ARCH__ >= 800
  return __reduce_min_sync(0xffffffffu, v);
#else
  for (int s = 16; s > 0; s >>= 1) v = min(v, __shfl_xor_sync(0xffffffffu, v, s));
  return v;
#endif
}

/// The lanes of a warp that add to the same nodes at once (the same key: a particle's
/// stencil cell in the tile): each float is summed over them with shuffles, and one lane
/// adds the sum. Particles are ordered by cell within their block (binning's keys) and the
/// lanes take consecutive particles, so a cell's lanes are consecutive; a group that is not
/// (a lane in between took another path) adds lane by lane.
struct WarpGroup {
  unsigned active;  ///< the lanes here now: they all make the same shuffles
  int lane, last;   ///< this lane, and the last lane of its group (itself if it adds alone)
  int steps;        ///< shuffle steps that sum the longest group of the warp
  bool adds;        ///< this lane adds the sum: its group's first lane, or a lane alone

  __device__ explicit WarpGroup(int key) {
    active = __activemask();
    lane = (int)(threadIdx.x % 32);
    const unsigned same = __match_any_sync(active, key);
    const int first = __ffs((int)same) - 1;
    const unsigned run = same >> first;
    const bool consecutive = (run & (run + 1)) == 0;
    last = consecutive ? 31 - __clz((int)same) : lane;
    adds = !consecutive || lane == first;
#if __CUDA_ARCH__ >= 800
    const unsigned longest = __reduce_max_sync(active, consecutive ? (unsigned)(last - first + 1) : 1u);
    steps = longest > 1 ? 32 - __clz((int)(longest - 1)) : 0;
#else
    steps = 5;  // no warp reduction before sm_80: as many steps as a whole warp's group needs
#endif
  }
  /// The group's sum, in its first lane: lane l ends with the sum over l .. last.
  __device__ float sum(float v) const {
    for (int s = 0; s < steps; ++s) {
      const float o = __shfl_down_sync(active, v, 1 << s);
      if (lane + (1 << s) <= last) v += o;
    }
    return v;
  }
  __device__ Float4 sum(const Float4& v) const { return Float4::make(sum(v[0]), sum(v[1]), sum(v[2]), sum(v[3])); }
};

/// The 6^3 nodes a grid block's particles reach (their stencil bases lie in the block), in
/// tile order: node t is (origin + (t / 36, t / 6 % 6, t % 6)).
struct TileNodes {
  static constexpr int kEdge = kBlockSize + 2;
  static constexpr int kNodes = kEdge * kEdge * kEdge;
  int origin[3];  ///< the grid coordinates of the block's first node

  __device__ void setBlock(const GridGeometry& geo, uint32_t block) {
    geo.blockCoords(block, origin[0], origin[1], origin[2]);
    for (int& o : origin) o <<= kBlockBits;
  }
  /// The tile node of grid node (i, j, k), or -1 outside the tile.
  __device__ int index(int i, int j, int k) const {
    const unsigned a = (unsigned)(i - origin[0]), b = (unsigned)(j - origin[1]), c = (unsigned)(k - origin[2]);
    return a < (unsigned)kEdge && b < (unsigned)kEdge && c < (unsigned)kEdge ? (int)((a * kEdge + b) * kEdge + c) : -1;
  }
  /// The grid node of tile node t, or null past the grid's last node.
  __device__ GridNode* gridNode(const GridView& g, int t) const {
    const int i = origin[0] + t / (kEdge * kEdge), j = origin[1] + (t / kEdge) % kEdge, k = origin[2] + t % kEdge;
    return i <= g.geo.cells[0] && j <= g.geo.cells[1] && k <= g.geo.cells[2] ? &g.node(i, j, k) : nullptr;
  }
};

/// P2G's tile on the GPU: the 6^3 nodes one grid block's particles reach, in shared memory
/// (the CPU's BlockTile). The block's particles add to it, their shares summed over the
/// lanes of a stencil cell first (WarpGroup), and the tile goes to the grid once, one
/// global atomic per node and field.
///
/// Why: every particle adding its 27 nodes x 4 floats to the grid with global atomics, the
/// particles sorted by block so that the threads of a warp met on the same nodes, was 84 %
/// of an MLS-MPM substep at 1M particles on an H200 (1.64 of 1.94 ms, ncu); the tile with
/// shared atomics lane by lane, 0.58 ms (the lanes of a cell retrying each other's
/// compare-and-swap).
template <bool kMx, bool kDmv>
struct SharedTile : TileNodes {
  /// [field][node][4]: {mass, mv}, then {touch, mx} (kMx), then {0, dmv} (kDmv)
  static constexpr int kFloats = (1 + kMx + kDmv) * 4 * kNodes;
  /// The APIC scatter comes whole (apicScatter), so a particle's lanes are grouped once.
  static constexpr bool kDefersApic = true;
  float* s;
  GridNodes<AtomicAdd> grid;  ///< a node outside the tile (never, for a binned particle) goes straight there

  /// The group key of an add at tile node t: the node, or the lane alone outside the tile.
  __device__ static int key(int t) { return t >= 0 ? t : kNodes + (int)(threadIdx.x % 32); }

  __device__ void add(int i, int j, int k, const Float4& q) const { addSummed(index(i, j, k), WarpGroup(key(index(i, j, k))), i, j, k, q); }
  __device__ void addCentroid(int i, int j, int k, const Float4& mx) const {
    addCentroidSummed(index(i, j, k), WarpGroup(key(index(i, j, k))), i, j, k, mx);
  }
  __device__ void addStressImpulse(int i, int j, int k, const Float4& dmv) const {
    const int t = index(i, j, k);
    const WarpGroup g(key(t));
    const Float4 sum = g.sum(dmv);
    if (!g.adds) return;
    if (!kDmv || t < 0) return grid.addStressImpulse(i, j, k, sum);
    float* d = s + 4 * ((1 + kMx) * kNodes + t);
    for (int l = 1; l < 4; ++l) sharedAdd(d + l, sum[l]);
  }

  /// {mass, momentum} at tile node t (-1: outside) summed over the group g.
  __device__ void addSummed(int t, const WarpGroup& g, int i, int j, int k, const Float4& q) const {
    const Float4 sum = g.sum(q);
    if (!g.adds) return;
    if (t < 0) return grid.add(i, j, k, sum);
    float* d = s + 4 * t;
    for (int l = 0; l < 4; ++l) sharedAdd(d + l, sum[l]);
  }
  __device__ void addCentroidSummed(int t, const WarpGroup& g, int i, int j, int k, const Float4& mx) const {
    const Float4 sum = g.sum(mx);
    if (!g.adds) return;
    if (!kMx || t < 0) return grid.addCentroid(i, j, k, sum);
    float* d = s + 4 * (kNodes + t);
    if (sum[0] != 0.f) sharedAdd(d, sum[0]);
    for (int l = 1; l < 4; ++l) sharedAdd(d + l, sum[l]);
  }

  /// One particle's APIC scatter (apicScatterTerms), its lanes grouped by stencil cell once.
  template <bool kCentroid>
  __device__ void deferApic(const QuadraticStencil& st, const ApicTerms& terms) const {
    const unsigned a = (unsigned)(st.base[0] - origin[0]), b = (unsigned)(st.base[1] - origin[1]),
                   c = (unsigned)(st.base[2] - origin[2]);
    const bool inside = a < (unsigned)kBlockSize && b < (unsigned)kBlockSize && c < (unsigned)kBlockSize;
    const CellNodes cell{this, WarpGroup(inside ? (int)((a * kEdge + b) * kEdge + c) : key(-1)), inside};
    apicScatterTerms<kCentroid>(st, terms, cell);
  }
  /// The nodes of one stencil cell's group (deferApic).
  struct CellNodes {
    const SharedTile* tile;
    WarpGroup group;
    bool inside;  ///< the whole stencil lies in the tile
    __device__ void add(int i, int j, int k, const Float4& q) const {
      tile->addSummed(inside ? tile->index(i, j, k) : -1, group, i, j, k, q);
    }
    __device__ void addCentroid(int i, int j, int k, const Float4& mx) const {
      tile->addCentroidSummed(inside ? tile->index(i, j, k) : -1, group, i, j, k, mx);
    }
  };

  /// Adds the tile's non-zero sums to the grid's nodes (cleared before: ClearNodes); the
  /// tiles of neighbouring blocks overlap, hence the atomics.
  __device__ void flush() const {
    for (int t = threadIdx.x; t < kNodes; t += blockDim.x) {
      const float* q = s + 4 * t;
      if (q[0] == 0.f) continue;  // no particle's weight reached it
      GridNode* on = gridNode(grid.grid, t);
      if (!on) continue;
      GridNode& n = *on;
      atomicAdd(&n.mass, q[0]);
      atomicAdd(&n.mv.x, q[1]);
      atomicAdd(&n.mv.y, q[2]);
      atomicAdd(&n.mv.z, q[3]);
      if (kMx) {
        const float* c = s + 4 * (kNodes + t);
        if (c[0] != 0.f) atomicAdd(&n.touch, c[0]);
        atomicAdd(&n.mx.x, c[1]);
        atomicAdd(&n.mx.y, c[2]);
        atomicAdd(&n.mx.z, c[3]);
      }
      if (kDmv) {
        const float* d = s + 4 * ((1 + kMx) * kNodes + t);
        atomicAdd(&n.dmv.x, d[1]);
        atomicAdd(&n.dmv.y, d[2]);
        atomicAdd(&n.dmv.z, d[3]);
      }
    }
  }
};

/// G2P's tile on the GPU: the grid's {mass, velocity} (and with kOld the velocity before
/// the force) at the 6^3 nodes one grid block's particles read, loaded into shared memory
/// once (the CPU's BlockTile::load).
///
/// Why: each particle reading its 27 nodes from the grid through the block table made G2P
/// bound by L2 traffic (87 % of its throughput, 106 us per MLS-MPM substep at 1M particles
/// on an H200, ncu): 27 nodes of 56 bytes per particle.
template <bool kOld>
struct G2PTile : TileNodes {
  Float4* v;  ///< [node] {mass, velocity}, then (kOld) [node] {0, velocity before the force}
  GridNodes<AtomicAdd> grid;  ///< a node outside the tile (a stray's) is read from there

  __device__ Float4 velocity4(int i, int j, int k) const {
    const int t = index(i, j, k);
    return t >= 0 ? v[t] : grid.velocity4(i, j, k);
  }
  __device__ Float4 oldVelocity4(int i, int j, int k) const {
    const int t = index(i, j, k);
    return kOld && t >= 0 ? v[kNodes + t] : grid.oldVelocity4(i, j, k);
  }
  __device__ NearParts nearParts() const { return NearParts{}; }

  /// Fills the tile from the grid (nodes past the grid's last node: zero).
  __device__ void load() const {
    for (int t = threadIdx.x; t < kNodes; t += blockDim.x) {
      const GridNode* n = gridNode(grid.grid, t);
      v[t] = n ? Float4::make(n->mass, n->mv.x, n->mv.y, n->mv.z) : Float4::zero();
      if (kOld) v[kNodes + t] = n ? Float4::make(0.f, n->dmv.x, n->dmv.y, n->dmv.z) : Float4::zero();
    }
  }
};

/// G2P of one occupied grid block's particles per CUDA block, through a G2PTile; each
/// StepCheck is folded within the warp, then into the device-side check with one atomic
/// per warp (one per particle had them queue on two addresses).
template <bool kOld, class F>
__global__ void gridToTileKernel(const uint32_t* order, const uint32_t* runCount, const uint32_t* runStart,
                                 const uint32_t* runBlock, F f, GridView grid, unsigned int* maxSpeed2Bits,
                                 uint32_t* firstBad) {
  if (blockIdx.x >= *runCount) return;  // launched for as many blocks as there may be
  using Tile = G2PTile<kOld>;
  __shared__ Float4 nodes[(1 + kOld) * Tile::kNodes];
  Tile tile;
  tile.v = nodes;
  tile.grid = GridNodes<AtomicAdd>{grid};
  tile.setBlock(grid.geo, runBlock[blockIdx.x]);
  tile.load();
  __syncthreads();
  const uint32_t begin = runStart[blockIdx.x], count = runStart[blockIdx.x + 1] - begin;
  unsigned int speed2 = 0u;  // non-negative floats order like their bit patterns
  uint32_t bad = 0xffffffffu;
  for (uint32_t q = threadIdx.x; q < count; q += blockDim.x) {
    const StepCheck c = f(order[begin + q], tile);
    speed2 = max(speed2, __float_as_uint(c.maxSpeed2));
    bad = min(bad, c.firstBadParticle);
  }
  speed2 = warpMax(speed2);
  bad = warpMin(bad);
  if (threadIdx.x % 32 == 0) {
    if (speed2) atomicMax(maxSpeed2Bits, speed2);
    if (bad != 0xffffffffu) atomicMin(firstBad, bad);
  }
}

/// P2G of one occupied grid block's particles (order[runStart[b] .. runStart[b + 1])) per
/// CUDA block, through a SharedTile; the lanes of a warp take consecutive particles, so
/// that a cell's particles share a WarpGroup.
template <bool kMx, bool kDmv, class F>
__global__ void particleToTileKernel(const uint32_t* order, const uint32_t* runCount, const uint32_t* runStart,
                                     const uint32_t* runBlock, F f, GridView grid) {
  if (blockIdx.x >= *runCount) return;  // launched for as many blocks as there may be
  using Tile = SharedTile<kMx, kDmv>;
  __shared__ float sums[Tile::kFloats];
  Tile tile;
  tile.s = sums;
  tile.grid = GridNodes<AtomicAdd>{grid};
  tile.setBlock(grid.geo, runBlock[blockIdx.x]);
  for (int t = threadIdx.x; t < Tile::kFloats; t += blockDim.x) sums[t] = 0.f;
  __syncthreads();
  const uint32_t begin = runStart[blockIdx.x], count = runStart[blockIdx.x + 1] - begin;
  for (uint32_t q = threadIdx.x; q < count; q += blockDim.x) f(order[begin + q], tile);
  __syncthreads();
  tile.flush();
}

}  // namespace mpm
