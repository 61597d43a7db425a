#pragma once
// CPU execution backend: loops over host memory on a team of threads (thread_team.h).
//
// Transfers by grid block: particles are binned by the 4^3 block holding their stencil
// base, so a block's particles reach only a 6^3 tile of nodes (the block and its +1
// neighbours). P2G accumulates into that tile in L1 and keeps it for the grid's sums; G2P
// copies the tile's velocities once and gathers from it. No block-table lookup per node.
//
// P2G without float atomics: every block's particles go to its own tile, all blocks in
// parallel, and then each node sums the tiles that reach it in a fixed order whatever the
// thread count, which makes the CPU path bit-for-bit deterministic.
#if defined(_OPENMP)
#include <omp.h>  // omp_get_max_threads: OMP_NUM_THREADS as the default thread count
#endif

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <thread>
#include <new>
#include <numeric>
#include <type_traits>
#include <vector>

#include "backend/cpu/gather_batch.h"
#include "backend/cpu/scatter_cells.h"
#include "backend/cpu/stencil_batch.h"
#include "backend/cpu/stress_batch.h"
#include "backend/cpu/thread_team.h"
#include "backend/cpu/update_batch.h"
#include "transfer/grid_nodes.h"
#include "system/sim_backend.h"

namespace mpm {

// Which tile fields a transfer kernel uses: UsesCentroid, UsesImpulse, UsesOldVelocity
// (solvers/transfer.h).

/// kBatchedStress: P2G needs of the material only tau = kirchhoffStress(materials[
/// P.object[p]], P.F[p]) and takes it in scatterStressed(p, tau, nodes), so the CPU
/// computes it for a run of particles at once (kirchhoffStressBatch).
template <class F, class = void>
struct BatchesStress : std::false_type {};
template <class F>
struct BatchesStress<F, std::void_t<decltype(F::kBatchedStress)>> : std::bool_constant<F::kBatchedStress> {};
/// PB-MPM's P2G: the projected velocity gradient enters only through scatterProjected
/// (pbProjectionBatch computes it for a run of particles at once).
template <class F, class = void>
struct BatchesProjection : std::false_type {};
template <class F>
struct BatchesProjection<F, std::void_t<decltype(F::kBatchedProjection)>> : std::bool_constant<F::kBatchedProjection> {};
/// BatchedStencil: a transfer kernel takes each particle's stencil, BatchedStencil(geo,
/// P.x[p]), from the caller (P2G: scatterStressed(p, stencil, tau, nodes), G2P: gatherSummed(p,
/// stencil, sums or null, nodes)), so the CPU computes them for a run of particles at once
/// (StencilRun). Stencil: that type; char for kernels without one (never built then).
template <class F, class = void>
struct BatchesStencil : std::false_type {
  using Stencil = char;
};
template <class F>
struct BatchesStencil<F, std::void_t<typename F::BatchedStencil>> : std::true_type {
  using Stencil = typename F::BatchedStencil;
};
/// kBatchedSums: a G2P kernel with a BatchedStencil takes its APIC sums, apicSums(stencil,
/// nodes), from the caller too (gatherSummed(p, stencil, &sums, nodes)), computed for a run
/// of particles at once (apicSumsBatch), and the rest of gatherSummed as well, in lanes
/// (apicUpdateBatch, update_batch.h: the kernel names with integrates() whether it moves
/// the particles).
template <class F, class = void>
struct BatchesSums : std::false_type {};
template <class F>
struct BatchesSums<F, std::void_t<decltype(F::kBatchedSums)>> : std::bool_constant<F::kBatchedSums> {};

/// The 6^3 nodes a block's particles reach, as dense arrays of Float4 (one vector load,
/// add and store per node and field).
struct BlockTile {
  static constexpr int kEdge = kBlockSize + 2;
  static constexpr int kNodes = kEdge * kEdge * kEdge;
  int origin[3];
  /// G2P: the parts near the block's particles (Binning::findNearParts), or none listed
  NearParts near;
  Float4 mv[kNodes];   ///< {mass, momentum}; {mass, velocity} in G2P
  Float4 mx[kNodes];   ///< {sum w m touch_p, sum w m x_p}
  Float4 dmv[kNodes];  ///< {0, stress impulse}; {0, velocity before the force} in G2P

  int index(int i, int j, int k) const {
    return ((i - origin[0]) * kEdge + (j - origin[1])) * kEdge + (k - origin[2]);
  }
  void add(int i, int j, int k, const Float4& q) { mv[index(i, j, k)] += q; }
  void addCentroid(int i, int j, int k, const Float4& q) { mx[index(i, j, k)] += q; }
  void addStressImpulse(int i, int j, int k, const Float4& q) { dmv[index(i, j, k)] += q; }
  Float4 velocity4(int i, int j, int k) const { return mv[index(i, j, k)]; }
  Float4 oldVelocity4(int i, int j, int k) const { return dmv[index(i, j, k)]; }
  NearParts nearParts() const { return near; }

  void setBlock(const GridGeometry& geo, uint32_t block) {
    geo.blockCoords(block, origin[0], origin[1], origin[2]);
    for (int& o : origin) o <<= kBlockBits;
  }
  template <bool kMx, bool kDmv>
  void clear() {
    const Float4 zero = Float4::zero();
    for (int n = 0; n < kNodes; ++n) {
      mv[n] = zero;
      if (kMx) mx[n] = zero;
      if (kDmv) dmv[n] = zero;
    }
  }
  /// Calls f(tileNode, gridNode) for every tile node that exists in the grid.
  template <class F>
  void forEachGridNode(const GridView& grid, F f) {
    for (int i = 0; i < kEdge; ++i)
      for (int j = 0; j < kEdge; ++j)
        for (int k = 0; k < kEdge; ++k) {
          const int gi = origin[0] + i, gj = origin[1] + j, gk = origin[2] + k;
          if (gi > grid.geo.cells[0] || gj > grid.geo.cells[1] || gk > grid.geo.cells[2]) continue;
          f((i * kEdge + j) * kEdge + k, grid.node(gi, gj, gk));
        }
  }
  /// Copies the grid's {mass, velocity} (and old velocity) into the tile.
  template <bool kDmv>
  void load(const GridView& grid) {
    forEachGridNode(grid, [this](int t, const GridNode& g) {
      mv[t] = Float4::make(g.mass, g.mv.x, g.mv.y, g.mv.z);
      if (kDmv) dmv[t] = Float4::make(0.f, g.dmv.x, g.dmv.y, g.dmv.z);
    });
  }
};

/// P2G's tile: a particle's APIC scatter (apicScatter) is recorded and summed with the
/// other particles of its stencil cell when the block is done (finish), not added node by
/// node; what a kernel adds itself (a cut particle, standard MPM) goes straight in.
struct P2GTile : BlockTile {
  static constexpr bool kDefersApic = true;
  CellScatter* cells = nullptr;

  template <bool kCentroid>
  void deferApic(const QuadraticStencil& st, const ApicTerms& t) {
    const int ci = st.base[0] - origin[0], cj = st.base[1] - origin[1], ck = st.base[2] - origin[2];
    // binned by its stencil base's block, so always inside; anything else goes straight in
    if ((unsigned)ci < (unsigned)kBlockSize && (unsigned)cj < (unsigned)kBlockSize && (unsigned)ck < (unsigned)kBlockSize)
      cells->record((ci * kBlockSize + cj) * kBlockSize + ck, st.w, t);
    else
      apicScatterTerms<kCentroid>(st, t, *this);
  }
  /// Adds the recorded particles to the tile (before flush).
  template <bool kCentroid>
  void finish() { cells->flush<kCentroid, kEdge>(mv, mx); }
};

/// The G2P kernel of a P2G that gathers nothing first (Binning::particleToGrid).
struct NoGather {};

struct CpuExec {
  int threads = 1;

  /// Below this many elements a loop runs on the calling thread: waking the team costs
  /// more than it saves, and spinning teams are what hurts when the machine is shared.
  static constexpr long long kMinParallel = 4096;
  /// Same, in grid blocks (one block holds up to a few hundred particles).
  static constexpr long long kMinParallelBlocks = 16;
  /// P2G computes the stresses of this many particles of a block at once (BatchesStress).
  static constexpr int kStressRun = 64;
  /// G2P (BatchesStencil) and binning compute the stencils of this many particles at once.
  static constexpr int kStencilRun = 64;

  explicit CpuExec(int threadCount) { setThreads(threadCount); }
  /// Every loop reads `threads` when it starts: results do not depend on it (see above).
  void setThreads(int threadCount) { threads = threadCount > 0 ? threadCount : defaultThreads(); }
  /// OMP_NUM_THREADS where OpenMP is linked (the convention users know), else the cores.
  static int defaultThreads() {
#if defined(_OPENMP)
    return omp_get_max_threads();
#else
    return (int)std::max(1u, std::thread::hardware_concurrency());
#endif
  }
  /// The workers of every loop below (thread_team.h: why not OpenMP's).
  std::unique_ptr<ThreadTeam> team_ = std::make_unique<ThreadTeam>();

  template <class T>
  T* allocate(size_t n) {
    const size_t bytes = ((n * sizeof(T) + 63) / 64) * 64;
    void* p = std::aligned_alloc(64, bytes);
    if (!p) throw OutOfMemory("host memory for " + std::to_string(n) + " elements of " + std::to_string(sizeof(T)) + " bytes", bytes);
    return static_cast<T*>(p);
  }
  void release(void* p) { std::free(p); }
  void copyToDevice(void* dst, const void* src, size_t bytes) { if (bytes) std::memcpy(dst, src, bytes); }
  void copyToHost(void* dst, const void* src, size_t bytes) const { if (bytes) std::memcpy(dst, src, bytes); }
  void copyOnDevice(void* dst, const void* src, size_t bytes) { if (bytes) std::memcpy(dst, src, bytes); }

  /// Sorting gathers each particle field on one thread, the fields side by side.
  static constexpr bool kGatherByField = true;
  /// out[i] = in[order[i]] on the calling thread (`order` a permutation, out and in apart).
  template <class T>
  static void gatherSerial(T* out, const T* in, const uint32_t* order, size_t n) {
    for (size_t i = 0; i < n; ++i) out[i] = in[order[i]];
  }

  /// f(task, slot) for task in [0, n), tasks handed out one at a time; `slot` (below
  /// `threads`) names the thread running it, for per-thread scratch. `work`: the elements
  /// the tasks touch together, for the kMinParallel test.
  template <class F>
  void forEachTask(int n, size_t work, const F& f) {
    std::atomic<int> next{0};
    team_->run((long long)work >= kMinParallel ? std::min(threads, n) : 1, [&](int slot, int) {
      for (int task; (task = next.fetch_add(1)) < n;) f(task, slot);
    });
  }

  template <class F>
  void forEach(size_t n, const F& f) {
    team_->run((long long)n >= kMinParallel ? threads : 1, [&](int t, int nt) {
      for (size_t i = n * t / nt, end = n * (t + 1) / nt; i < end; ++i) f(i);
    });
  }

  StepCheck takeCheck() {
    const StepCheck c = check_;
    check_.firstBadParticle = 0xffffffffu;
    check_.peakSpeed2 = 0.f;
    return c;
  }
  StepCheck check_;

  /// Particles binned by grid block, and the active grid blocks they reach.
  class Binning {
   public:
    Binning(CpuExec&, const GridGeometry& geo)
        : geo_(geo),
          blockCount_(nBlocks(geo), 0),
          blockSlot_(nBlocks(geo), -1),
          occupiedRank_(nBlocks(geo), -1) {}

    /// Bins the particles: `order` lists particle indices block by block (stable),
    /// `blocks` the occupied blocks in index order with their ranges in `order`.
    ///
    /// A stable counting sort over the occupied blocks only, in parallel: each thread takes
    /// a contiguous range of particles and records it as runs of one block (particles come
    /// sorted by block since the last reorder, so runs are long), noting the blocks it sees
    /// first; one thread then counts the runs per block and range and places each range's
    /// particles of a block after the ranges before it; each thread writes its range. The
    /// result is the one stable sort by block, whatever the thread count. Two barriers
    /// (with a counting pass between two more, the 2-thread binning of 125k particles took
    /// 0.89 ms against 0.99 ms on one, measured on OpenMP's passive team, where every
    /// barrier was a wake-up of about 0.1 ms on the 2-core VM).
    void build(const ParticleView& P, ThreadTeam& pool, int threads) {
      const size_t n = P.count;
      for (uint32_t b : occupied_) occupiedRank_[b] = -1;  // the last binning's
      order_.resize(n);
      const int team = (long long)n >= kMinParallel ? std::max(threads, 1) : 1;
      if ((int)firstSeen_.size() < team) {
        firstSeen_.resize(team);
        runs_.resize(team);
        runsInPlace_.resize(team);
      }
      pool.run(team, [&](int t, int nt) {
        const size_t lo = n * t / nt, hi = n * (t + 1) / nt;
        // blockCount_ (all zero between calls) first marks the blocks seen
        std::vector<uint32_t>& seen = firstSeen_[t];
        std::vector<BlockRun>& runs = runs_[t];
        seen.clear();
        runs.clear();
        StencilRun<kStencilRun> st;  // the stencil bases of the next particles, in lanes
        uint32_t ids[kStencilRun];
        for (size_t i = lo; i < hi; ++i) {
          const int q = (int)((i - lo) % kStencilRun);
          if (q == 0) {
            const int count = (int)std::min<size_t>(kStencilRun, hi - i);
            for (int c = 0; c < count; ++c) ids[c] = (uint32_t)(i + c);
            st.compute<false>(geo_, P.x, ids, count);
          }
          // GridGeometry::particleBlock, or 0 for a stray (skipped by P2G)
          const int base[3] = {st.base[0][q], st.base[1][q], st.base[2][q]};
          const uint32_t key = geo_.baseInside(base) ? geo_.blockIndex(base[0] >> kBlockBits, base[1] >> kBlockBits,
                                                                       base[2] >> kBlockBits)
                                                     : 0u;
          if (!runs.empty() && runs.back().block == key) {
            ++runs.back().count;
            continue;
          }
          runs.push_back({key, 1u});
          if (__atomic_load_n(&blockCount_[key], __ATOMIC_RELAXED) == 0 &&
              __atomic_exchange_n(&blockCount_[key], 1u, __ATOMIC_RELAXED) == 0)
            seen.push_back(key);
        }
        pool.barrier(nt);
        if (t == 0) {
          occupied_.clear();
          for (int s = 0; s < nt; ++s) occupied_.insert(occupied_.end(), firstSeen_[s].begin(), firstSeen_[s].end());
          std::sort(occupied_.begin(), occupied_.end());
          const size_t nOcc = occupied_.size();
          for (size_t j = 0; j < nOcc; ++j) blockCount_[occupied_[j]] = (uint32_t)j;  // block -> rank until reset
          // each range's particles per block, then where they start: blocks in order,
          // ranges in order within a block
          cursor_.assign((size_t)nt * nOcc, 0u);
          for (int s = 0; s < nt; ++s)
            for (const BlockRun& r : runs_[s]) cursor_[(size_t)s * nOcc + blockCount_[r.block]] += r.count;
          start_.resize(nOcc + 1);
          uint32_t running = 0;
          for (size_t j = 0; j < nOcc; ++j) {
            start_[j] = running;
            for (int s = 0; s < nt; ++s) {
              uint32_t& c = cursor_[(size_t)s * nOcc + j];
              const uint32_t here = c;
              c = running;
              running += here;
            }
          }
          start_[nOcc] = running;
        }
        pool.barrier(nt);
        uint32_t* cursor = cursor_.data() + (size_t)t * occupied_.size();
        uint32_t i = (uint32_t)lo;
        bool inPlace = true;  // every run lands where its particles are
        for (const BlockRun& r : runs) {
          uint32_t& c = cursor[blockCount_[r.block]];
          inPlace = inPlace && c == i;
          for (uint32_t q = 0; q < r.count; ++q) order_[c + q] = i++;
          c += r.count;
        }
        runsInPlace_[t] = inPlace;
      });
      inOrder_ = true;
      for (int t = 0; t < team; ++t) inOrder_ = inOrder_ && runsInPlace_[t];
      for (uint32_t b : occupied_) blockCount_[b] = 0;

      activate();
      nearListed_ = contactsFound_ = centroidsSelected_ = false;  // the lists belong to the old active blocks
      for (size_t j = 0; j < occupied_.size(); ++j) occupiedRank_[occupied_[j]] = (int32_t)j;
    }

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
    template <class F, class U = NoNodeUpdate, class G = NoGather>
    StepCheck particleToGrid(const F& f, bool keepCentroids, ThreadTeam& pool, int threads, const U& update = U{},
                             const G& gather = G{}) const {
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
    void sumTiles(const GridView& grid, uint32_t slot, bool keepCentroids) const {
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
    StepCheck gridToParticle(const F& f, ThreadTeam& pool, int threads) const {
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
    void ownBlocks(int t, int nt, uint32_t& first, uint32_t& last) const {
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
    /// Adds `c` to `into`: the fastest particle and the first bad one (any order).
    static void fold(StepCheck& into, const StepCheck& c) {
      into.maxSpeed2 = std::max(into.maxSpeed2, c.maxSpeed2);
      into.firstBadParticle = std::min(into.firstBadParticle, c.firstBadParticle);
    }
    /// The StepCheck of all the threads' (none: nothing to report).
    static StepCheck combined(const std::vector<StepCheck>& checks) {
      StepCheck c{0.f, 0xffffffffu};
      for (const StepCheck& k : checks) fold(c, k);
      return c;
    }
    /// A thread's G2P over its blocks (gridToParticle, and PB-MPM's gather before P2G in
    /// particleToGrid): the block's grid velocities as a tile, a run's APIC sums, and the
    /// check of the particles gathered so far.
    struct Gatherer {
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

    /// The parts near each active block, for the contact passes and G2P of this substep
    /// (after binning and placing the parts): those whose bounds meet the block's nodes
    /// grown by kNearBelow cells below and kNearAbove above (nearBox), in part order, as
    /// one list per block (nearStart_, nearParts_), and G2P's shorter one of the parts
    /// whose push-out boxes meet it (pushStart_, pushParts_).
    ///
    /// Why: with every part tried everywhere, 100 small spheres on 8000 particles cost 2.6x
    /// a substep without them (issue 19): G2P tried each part's bounds for every particle,
    /// the contact passes each part for every block, and summed nBlocks x nBodies momenta.
    /// Built here once per substep, by part over the blocks its bounds reach (one block
    /// lookup each), or over the active blocks for a part reaching more blocks than are
    /// active (a ground plane). Each list keeps the part order, so what each node and
    /// particle sees, in which order, is what it saw when every part was tried.
    void findNearParts(const PartView* parts, int nParts, bool selectCentroids) {
      const size_t nActive = active_.size();
      nearPairs_.clear();
      for (int p = 0; p < nParts; ++p) {
        const PartView& part = parts[p];
        // the blocks whose box may meet the part's bounds, with a slack for the rounding (a
        // hundredth of a cell, more far from the grid's corner); the exact test decides.
        // A block of slack either side had made it 4^3 blocks for a small sphere, not 2^3.
        int first[3], last[3];
        long long range = 1;
        bool finite = true;  // bounds of NaN meet every box (mayTouch): tried on all blocks
        for (int a = 0; a < 3; ++a) {
          finite = finite && std::isfinite(part.boundsLower[a]) && std::isfinite(part.boundsUpper[a]);
          const float lo = (part.boundsLower[a] - geo_.lower[a]) * geo_.invDx, hi = (part.boundsUpper[a] - geo_.lower[a]) * geo_.invDx;
          // a block b's box spans nodes kBlockSize b - kNearBelow to kBlockSize b + kBlockSize - 1 + kNearAbove
          const float slack = 0.01f + 1e-5f * (std::fabs(lo) + std::fabs(hi));
          const float f = std::floor((lo - (float)(kBlockSize - 1 + kNearAbove) - slack) / (float)kBlockSize);
          const float l = std::floor((hi + (float)kNearBelow + slack) / (float)kBlockSize);
          first[a] = (int)std::max(0.f, std::min(f, (float)geo_.blocks[a]));
          last[a] = (int)std::max(-1.f, std::min(l, (float)geo_.blocks[a] - 1.f));
          range *= std::max(0, last[a] - first[a] + 1);
        }
        if (!finite || range > (long long)nActive) {
          for (size_t slot = 0; slot < nActive; ++slot) {
            int bx, by, bz;
            geo_.blockCoords(active_[slot], bx, by, bz);
            addNear(part, p, (uint32_t)slot, bx, by, bz);
          }
          continue;
        }
        for (int bx = first[0]; bx <= last[0]; ++bx)
          for (int by = first[1]; by <= last[1]; ++by)
            for (int bz = first[2]; bz <= last[2]; ++bz) {
              const int32_t slot = blockSlot_[geo_.blockIndex(bx, by, bz)];
              if (slot >= 0) addNear(part, p, (uint32_t)slot, bx, by, bz);
            }
      }
      // by block, stable: each block's parts stay in part order
      nearStart_.assign(nActive + 1, 0u);
      pushStart_.assign(nActive + 1, 0u);
      for (const NearPair& q : nearPairs_) {
        ++nearStart_[q.slot + 1];
        pushStart_[q.slot + 1] += q.push;
      }
      for (size_t slot = 0; slot < nActive; ++slot) {
        nearStart_[slot + 1] += nearStart_[slot];
        pushStart_[slot + 1] += pushStart_[slot];
      }
      listed_.clear();
      for (size_t slot = 0; slot < nActive; ++slot)
        if (nearStart_[slot + 1] > nearStart_[slot]) listed_.push_back((uint32_t)slot);
      nearParts_.resize(nearPairs_.size());
      pushParts_.resize(pushStart_[nActive]);
      cursor_.assign(nearStart_.begin(), nearStart_.end() - 1);
      pushCursor_.assign(pushStart_.begin(), pushStart_.end() - 1);
      for (const NearPair& q : nearPairs_) {
        nearParts_[cursor_[q.slot]++] = q.part;
        if (q.push) pushParts_[pushCursor_[q.slot]++] = NearPart{q.part, parts[q.part].pushLower, parts[q.part].pushUpper};
      }
      nearListed_ = true;
      contactsFound_ = false;  // the parts were placed anew
      centroidsSelected_ = selectCentroids;
      if (selectCentroids) selectCentroidBlocks();
    }

    /// The blocks whose nodes need their material centroids this substep (centroidSlot_)
    /// and the occupied blocks whose tiles reach them (centroidRank_): the only nodes whose
    /// centroid (mx, touch) anything reads are the contact pass's, in the active blocks
    /// whose nodes' box meets a listed part's bounds (contactPass, the same test). P2G sums
    /// the centroids there alone.
    ///
    /// Why: the centroid is a second sum as large as the momentum's (w m x_p and w m touch_p
    /// for every stencil node) and was the largest cost of 100 small spheres on the top face
    /// of a box of 17576 particles (P2G 1.2x the plain scene's), though it is read only in
    /// the blocks along the spheres.
    void selectCentroidBlocks() {
      centroidSlot_.assign(active_.size(), 0);
      for (const NearPair& q : nearPairs_) centroidSlot_[q.slot] |= q.nodes;
      centroidRank_.assign(occupied_.size(), 0);
      for (size_t j = 0; j < occupied_.size(); ++j) {
        int c[3];
        geo_.blockCoords(occupied_[j], c[0], c[1], c[2]);
        for (int d = 0; d < 8 && !centroidRank_[j]; ++d) {  // the tile reaches the blocks d above (d in {0, 1}^3)
          const int x = c[0] + (d & 1), y = c[1] + ((d >> 1) & 1), z = c[2] + ((d >> 2) & 1);
          if (x >= geo_.blocks[0] || y >= geo_.blocks[1] || z >= geo_.blocks[2]) continue;
          const int32_t slot = blockSlot_[geo_.blockIndex(x, y, z)];
          centroidRank_[j] = slot >= 0 && centroidSlot_[slot];
        }
      }
    }

    /// Grid contact with rigid parts, block by block: each part near the block
    /// (findNearParts) is tested against the block's bounds once, and only then against
    /// its nodes. Each block sums its momentum exchange per body on its own, one sum per
    /// run of the body's parts in its list (a body's parts are consecutive); the blocks'
    /// sums are added in slot order, so the result does not depend on the thread count.
    /// Only bodies near a block have a sum there: a block adds nothing to the others
    /// (nothing but +0, which leaves a sum as it was). `out` is zeroed first; with no parts
    /// (none in reach) that is all.
    ///
    /// The nodes in contact with each listed part, and where (nodeContactGeometry), are
    /// found in the first pass after the material was scattered and kept for the passes
    /// that follow until the particles are binned or scattered again (contactAt_,
    /// contactsBy_): only the velocities change between them. A dynamic body has four passes a substep (three
    /// measuring), PB-MPM's ten cycles forty; each had looked up every node's distances
    /// again (2 distances for a node near a part). The same arithmetic in the same order:
    /// the same bits.
    void contactPass(const PartView* parts, int nParts, const BodyView* bodies, int nBodies,
                     ContactSums* out, int pass, ThreadTeam& pool, int threads) {
      for (int b = 0; b < nBodies; ++b) out[b] = ContactSums{};
      if (nParts == 0) return;
      if (!nearListed_) findNearParts(parts, nParts, false);
      const GridView grid = gridView();
      const size_t nActive = active_.size();
      blockSums_.resize(nearParts_.size());
      const bool find = !contactsFound_;
      if (find) {
        findSegmentRuns(parts, nParts, bodies);
        contactAt_.resize(nearParts_.size());
        if ((int)contactsBy_.size() < threads) contactsBy_.resize(threads);
        if ((int)candidatesBy_.size() < threads) candidatesBy_.resize(threads, std::vector<NodeCandidate>(kBlockNodes));
        if ((int)segmentsBy_.size() < threads) segmentsBy_.resize(threads);
        for (auto& c : contactsBy_) c.clear();
      }
      const auto block = [&](uint32_t slot, int t) {
        const uint32_t begin = nearStart_[slot], end = nearStart_[slot + 1];
        if (begin == end) return;
        int bx, by, bz;
        geo_.blockCoords(active_[slot], bx, by, bz);
        const int o[3] = {bx << kBlockBits, by << kBlockBits, bz << kBlockBits};
        Vec3f lo, hi;
        nodeBox(bx, by, bz, lo, hi);
        GridNode* nodes = grid.nodes + slot * kBlockNodes;
        // The block's nodes that take contact at all, with where their material is: asked
        // once for all the parts near the block (under 100 small spheres a block has about
        // ten). Contact changes only velocities, never these.
        NodeCandidate* candidates = find ? candidatesBy_[t].data() : nullptr;
        int nCandidates = -1;  // not yet gathered
        NearSegments near;  // a thread's segments that may be nearer to a node (nearerSegment)
        near.runFirst = runFirst_.data();
        near.runLast = runLast_.data();
        uint32_t run = begin;  // the sum of the current body's run
        for (uint32_t k = begin; k < end; ++k) {
          const int p = nearParts_[k];
          if (k == begin || parts[p].body != parts[nearParts_[k - 1]].body) {
            run = k;
            blockSums_[run] = ContactSums{};
          }
          ContactRun& at = contactAt_[k];
          if (find) {
            std::vector<NodeContact>& mine = contactsBy_[t];
            at = ContactRun{(uint32_t)mine.size(), (uint8_t)t, 0};
            if (!parts[p].mayTouch(lo, hi)) continue;
            if (nCandidates < 0) {
              nCandidates = 0;
              for (int n = 0; n < kBlockNodes; ++n) {
                const GridNode& node = nodes[n];
                const Vec3f x = geo_.lower + geo_.dx * Vec3f{(float)(o[0] + (n >> (2 * kBlockBits))),
                                                             (float)(o[1] + ((n >> kBlockBits) & kBlockMask)),
                                                             (float)(o[2] + (n & kBlockMask))};
                if (!takesContact(node, x, geo_)) continue;
                candidates[nCandidates++] = NodeCandidate{x, (1.f / node.mass) * node.mx,
                                                          materialTouches(node) ? geo_.dx : 0.f, (uint8_t)n, {}};
              }
              std::vector<int>& segments = segmentsBy_[t];
              segments.resize(end - begin);
              near.parts = segments.data();
              near.count = segmentsWithin(parts, nearParts_.data() + begin, (int)(end - begin), segment_.data(), lo, hi,
                                          segmentBand_, segments.data());
              near.reach = segmentReach_;
            }
            NodeContact g;
            for (int c = 0; c < nCandidates; ++c) {
              NodeCandidate& q = candidates[c];
              if (!parts[p].mayTouch(q.x, q.x)) continue;  // as the CUDA pass: beyond the part's reach
              near.nearest = &q.nearest;
              if (!nodeContactGeometry(q.x, q.xbar, q.touchingCell, parts, nParts, p, bodies, g, &near)) continue;
              g.node = q.node;
              mine.push_back(g);
            }
            at.count = (uint8_t)(mine.size() - at.start);  // at most kBlockNodes (64)
          }
          // the measuring pass asks only dynamic bodies (contactNodePart)
          const BodyView& body = bodies[parts[p].body];
          if (pass == 0 && !body.dynamic) continue;
          const NodeContact* contacts = contactsBy_[at.thread].data() + at.start;
          for (int c = 0; c < at.count; ++c) {
            GridNode& node = nodes[contacts[c].node];
            applyNodeContact(contacts[c], node.mass, node.mv, parts[p], body, blockSums_[run], pass);
          }
        }
      };
      // Only the blocks with parts near: they hold all the work (a slab on a ground plane:
      // its bottom layer). Each thread takes those among the active slots whose nodes it
      // summed in P2G (particleToGrid splits the slots so): their nodes are in its core's
      // cache, and the list entries it writes (contactAt_, blockSums_) lie together. Under
      // 100 spheres on 2 threads, blocks handed out one at a time took 54 + 50 us for what
      // one thread did in 59 (neighbouring entries to both threads in turn, nodes from the
      // other core's cache); split by list entries, 36 + 48 us and a pass of 54-59 us; so,
      // 47-53 us. The cost: a scene whose contact lies in one thread's slots leaves the
      // other idle, as P2G's sums do. A replay of a few thousand recorded contacts is
      // shorter than waking a thread (PB-MPM's box on the slab: ~1500 contacts, forty
      // passes a substep).
      const uint32_t nListed = (uint32_t)listed_.size();
      size_t recorded = 0;
      if (!find)
        for (const auto& c : contactsBy_) recorded += c.size();
      const bool parallel = nListed >= kMinParallelBlocks && (find || recorded >= (size_t)kMinParallel);
      pool.run(parallel ? threads : 1, [&](int t, int nt) {
        // the listed blocks among the slots P2G's sums gave this thread
        const auto from = [&](int k) -> uint32_t {
          const uint32_t slot = (uint32_t)(nActive * (size_t)k / (size_t)nt);
          return (uint32_t)(std::lower_bound(listed_.begin(), listed_.end(), slot) - listed_.begin());
        };
        for (uint32_t s = from(t), sEnd = from(t + 1); s < sEnd; ++s) block(listed_[s], t);
      });
      contactsFound_ = true;
      for (size_t slot = 0; slot < nActive; ++slot)
        for (uint32_t k = nearStart_[slot]; k < nearStart_[slot + 1]; ++k) {
          const int b = parts[nearParts_[k]].body;
          if (k > nearStart_[slot] && b == parts[nearParts_[k - 1]].body) continue;  // within the run
          const float* src = &blockSums_[k].impulse[0];
          float* dst = &out[b].impulse[0];
          for (int f = 0; f < kContactSumFloats; ++f) dst[f] += src[f];
        }
    }

    /// The runs of thread segments among the parts (runFirst_, runLast_: per segment its
    /// run's first and last part, isThreadSegment), which parts are segments (segment_), their
    /// widest band (segmentBand_) and how near a segment off a block's segmentsWithin list
    /// can lie to its nodes at the least (segmentReach_, NearSegments::reach: the least bounds
    /// growth, and that band), for nearerSegment's lists.
    void findSegmentRuns(const PartView* parts, int nParts, const BodyView* bodies) {
      runFirst_.resize((size_t)nParts);
      runLast_.resize((size_t)nParts);
      segment_.resize((size_t)nParts);
      segmentReach_ = INFINITY;
      segmentBand_ = 0.f;
      for (int p = 0; p < nParts; ++p) {
        const bool segment = isThreadSegment(parts, nParts, p, bodies);
        segment_[p] = segment;
        runFirst_[p] = segment && isThreadSegment(parts, nParts, p - 1, bodies) ? runFirst_[p - 1] : p;
        if (!segment) continue;
        segmentReach_ = std::min(segmentReach_, parts[p].boundsGrowth);
        segmentBand_ = std::max(segmentBand_, std::max(bodies[parts[p].body].band, parts[p].band));
      }
      segmentReach_ = std::min(segmentReach_, segmentBand_);
      for (int p = nParts - 1; p >= 0; --p)
        runLast_[p] = isThreadSegment(parts, nParts, p, bodies) && isThreadSegment(parts, nParts, p + 1, bodies)
                          ? runLast_[p + 1] : p;
    }

    /// Whether any part's bounds (grown by its contact reach) meet the box of the active
    /// blocks: if none does, no node or particle can touch a shape this substep.
    bool partsReach(const PartView* parts, int nParts) const {
      if (active_.empty() || nParts == 0) return false;
      int lo[3] = {1 << 30, 1 << 30, 1 << 30}, hi[3] = {-1, -1, -1};
      for (uint32_t b : active_) {
        int c[3];
        geo_.blockCoords(b, c[0], c[1], c[2]);
        for (int a = 0; a < 3; ++a) {
          lo[a] = std::min(lo[a], c[a]);
          hi[a] = std::max(hi[a], c[a]);
        }
      }
      // from the first node of the lowest blocks to the last node of the highest, as the
      // contact pass bounds each block
      const Vec3f boxLo = geo_.lower + (geo_.dx * kBlockSize) * Vec3f{(float)lo[0], (float)lo[1], (float)lo[2]};
      const Vec3f boxHi = geo_.lower + geo_.dx * Vec3f{(float)(hi[0] * kBlockSize + kBlockSize - 1),
                                                       (float)(hi[1] * kBlockSize + kBlockSize - 1),
                                                       (float)(hi[2] * kBlockSize + kBlockSize - 1)};
      for (int p = 0; p < nParts; ++p)
        if (parts[p].mayTouch(boxLo, boxHi)) return true;
      return false;
    }

    GridView gridView() const {
      GridView g;
      g.geo = geo_;
      g.blockSlot = blockSlot_.data();
      g.activeBlocks = active_.data();
      g.nodes = const_cast<GridNode*>(nodes_.data());
      g.activeCount = (uint32_t)active_.size();
      return g;
    }
    const uint32_t* order() const { return order_.data(); }
    size_t memoryBytes() const {
      size_t runs = 0;
      for (const auto& r : runs_) runs += r.capacity() * sizeof(BlockRun);
      for (const auto& c : contactsBy_) runs += c.capacity() * sizeof(NodeContact);
      for (const auto& s : segmentsBy_) runs += s.capacity() * sizeof(int);
      runs += candidatesBy_.size() * kBlockNodes * sizeof(NodeCandidate);
      return blockCount_.capacity() * 4 + blockSlot_.capacity() * 4 + occupiedRank_.capacity() * 4 +
             tiles_.capacity() * sizeof(Float4) + runs +
             order_.capacity() * 4 + active_.capacity() * 4 + nodes_.capacity() * sizeof(GridNode) +
             occupied_.capacity() * 8 + nearPairs_.capacity() * sizeof(NearPair) + nearStart_.capacity() * 4 + listed_.capacity() * 4 +
             nearParts_.capacity() * 4 + pushStart_.capacity() * 4 + pushCursor_.capacity() * 4 +
             pushParts_.capacity() * sizeof(NearPart) + centroidSlot_.capacity() + centroidRank_.capacity() +
             blockSums_.capacity() * sizeof(ContactSums) +
             contactAt_.capacity() * sizeof(ContactRun) + (runFirst_.capacity() + runLast_.capacity()) * 4 +
             segment_.capacity();
    }

    /// The particles have just been reordered by this binning's order (the i-th listed now
    /// sits at i): the binning stays the one of their positions, listed in order, and the
    /// first substep after the sort need not bin again.
    void renumberSorted() { std::iota(order_.begin(), order_.end(), 0u); }
    /// Whether the particles sit in this binning's order already (order() is the identity).
    bool inOrder() const { return inOrder_; }

   private:
    static size_t nBlocks(const GridGeometry& g) {
      return (size_t)g.blocks[0] * g.blocks[1] * g.blocks[2];
    }
    /// Active blocks: every occupied block and its +1 neighbours (the stencil's reach).
    void activate() {
      for (uint32_t b : active_) blockSlot_[b] = -1;
      active_.clear();
      for (uint32_t b : occupied_) {
        int bx, by, bz;
        geo_.blockCoords(b, bx, by, bz);
        for (int i = 0; i < 2; ++i)
          for (int j = 0; j < 2; ++j)
            for (int k = 0; k < 2; ++k) {
              if (bx + i >= geo_.blocks[0] || by + j >= geo_.blocks[1] || bz + k >= geo_.blocks[2])
                continue;
              const uint32_t nb = geo_.blockIndex(bx + i, by + j, bz + k);
              if (blockSlot_[nb] >= 0) continue;
              blockSlot_[nb] = (int32_t)active_.size();
              active_.push_back(nb);
            }
      }
      // node memory follows the active blocks; it only grows, so the step never reallocates
      // once the scene has reached its size
      const size_t need = active_.size() * kBlockNodes;
      if (nodes_.size() < need) nodes_.resize(need);
    }

    GridGeometry geo_;
    std::vector<uint32_t> blockCount_;
    std::vector<int32_t> blockSlot_;
    std::vector<uint32_t> order_, occupied_, start_, cursor_, active_;
    std::vector<int32_t> occupiedRank_;  ///< block -> its rank in occupied_, or -1
    mutable std::vector<Float4> tiles_;  ///< P2G: each occupied block's tile, by rank
    std::vector<std::vector<uint32_t>> firstSeen_;  ///< per thread: blocks it saw first
    /// Consecutive particles in one block.
    struct BlockRun {
      uint32_t block, count;
    };
    std::vector<std::vector<BlockRun>> runs_;  ///< per thread: its range as runs
    std::vector<uint8_t> runsInPlace_;         ///< per thread: its runs land where they are
    bool inOrder_ = false;                     ///< inOrder()
    std::vector<GridNode> nodes_;
    /// findNearParts: the box a block's list covers, in cells beyond its nodes. A block's
    /// particles lie from 0.5 to 4.5 cells above its first node (their stencil base is in
    /// it), so the box leaves them half a cell each side to move in a substep (the CFL
    /// number keeps most under 0.3 cells) before G2P falls back to every part. A wider box
    /// lists more parts for every particle: with 9 cells instead of these 6 the scan of the
    /// lists was still G2P's hottest loop under 100 spheres on 8000 particles.
    static constexpr int kNearBelow = 0, kNearAbove = 2;
    struct NearPair {
      uint32_t slot;
      int part;
      bool push;   ///< the part's push-out box meets the slot's box too (G2P's list)
      bool nodes;  ///< the part's bounds meet the slot's nodes (contactPass's test)
    };
    std::vector<NearPair> nearPairs_;   ///< (block, part) in part order
    std::vector<uint32_t> nearStart_;   ///< per active slot: its list in nearParts_
    std::vector<uint32_t> listed_;      ///< the active slots whose list is not empty
    std::vector<int> nearParts_;        ///< the lists (part indices), each in part order
    /// G2P's lists: per active slot, the parts on its list whose push-out box (PartView::
    /// pushLower, pushUpper) meets the slot's box, with a copy of that box, in part order.
    /// Under 100 small spheres G2P's lanes were tested against a dozen parts a vector,
    /// most of them the grid's reach away, none holding a particle.
    std::vector<uint32_t> pushStart_, pushCursor_;
    std::vector<NearPart> pushParts_;
    bool nearListed_ = false;           ///< the lists are this substep's
    /// selectCentroidBlocks: per active slot, its nodes need their centroids; per occupied
    /// rank, its tile carries them. Without it (mirror planes fold ghost nodes' centroids
    /// into others; before the lists) every block's do.
    std::vector<uint8_t> centroidSlot_, centroidRank_;
    bool centroidsSelected_ = false;
    struct NodeCandidate {  ///< contactPass: a node that takes contact (takesContact)
      Vec3f x, xbar;
      float touchingCell;
      uint8_t node;
      NearestSegment nearest;  ///< its nearest segment of a thread, once found (nearerSegment)
    };
    struct ContactRun {
      uint32_t start;
      uint8_t thread, count;
    };
    /// contactPass: per list entry k the nodes in contact with its part (contactAt_[k]:
    /// `count` of them from `start` in the records of the thread that found them), valid
    /// while contactsFound_ (mutable: the const P2G invalidates them). Each thread appends
    /// to its own records, so they take what the contacts need, not a block's nodes for
    /// every list entry.
    std::vector<ContactRun> contactAt_;
    std::vector<std::vector<NodeContact>> contactsBy_;
    std::vector<std::vector<NodeCandidate>> candidatesBy_;  ///< per thread: one block's candidates
    mutable bool contactsFound_ = false;
    std::vector<ContactSums> blockSums_;  ///< per list entry: its body's run's sum in the block
    std::vector<int> runFirst_, runLast_;  ///< findSegmentRuns
    std::vector<uint8_t> segment_;
    float segmentReach_ = 0.f, segmentBand_ = 0.f;
    std::vector<std::vector<int>> segmentsBy_;  ///< per thread: one block's segmentsWithin

    /// The box of active block `block`'s list: its nodes grown by kNearBelow cells below
    /// and kNearAbove above [m].
    void nearBox(uint32_t block, Vec3f& lo, Vec3f& hi) const {
      int bx, by, bz;
      geo_.blockCoords(block, bx, by, bz);
      nearBox(bx, by, bz, lo, hi);
    }
    /// The same, of the block at block coordinates (bx, by, bz).
    void nearBox(int bx, int by, int bz, Vec3f& lo, Vec3f& hi) const {
      Vec3f first, last;
      nodeBox(bx, by, bz, first, last);
      lo = first - ((float)kNearBelow * geo_.dx) * Vec3f{1.f, 1.f, 1.f};
      hi = first + ((float)(kBlockSize - 1 + kNearAbove) * geo_.dx) * Vec3f{1.f, 1.f, 1.f};
    }
    /// Lists part p for active slot `slot` (its block at bx, by, bz) if its bounds meet
    /// the slot's box.
    void addNear(const PartView& part, int p, uint32_t slot, int bx, int by, int bz) {
      Vec3f lo, hi;
      nearBox(bx, by, bz, lo, hi);
      if (!part.mayTouch(lo, hi)) return;
      Vec3f nodesLo, nodesHi;
      nodeBox(bx, by, bz, nodesLo, nodesHi);
      nearPairs_.push_back({slot, p, part.mayPush(lo, hi), part.mayTouch(nodesLo, nodesHi)});
    }
    /// The box of the nodes of the block at block coordinates (bx, by, bz) [m] (the contact
    /// pass's bound on them).
    void nodeBox(int bx, int by, int bz, Vec3f& lo, Vec3f& hi) const {
      lo = geo_.lower + geo_.dx * Vec3f{(float)(bx << kBlockBits), (float)(by << kBlockBits), (float)(bz << kBlockBits)};
      hi = lo + (geo_.dx * (kBlockSize - 1)) * Vec3f{1.f, 1.f, 1.f};
    }
    /// G2P's list for occupied block `block` (active too); none before findNearParts.
    NearParts nearParts(uint32_t block) const {
      NearParts near;
      if (!nearListed_) return near;
      const int32_t slot = blockSlot_[block];
      static const NearPart kNone{};  // an empty list is still a list
      near.parts = pushParts_.empty() ? &kNone : pushParts_.data() + pushStart_[slot];
      near.count = (int)(pushStart_[slot + 1] - pushStart_[slot]);
      nearBox(block, near.lower, near.upper);
      return near;
    }
  };

  void bin(const ParticleView& P, Binning& b) { b.build(P, *team_, threads); }
  /// P2G, then the node kernel `update` on every active node (NoNodeUpdate: none), each
  /// block's nodes updated as soon as they are summed (Binning::particleToGrid).
  template <class F, class U = NoNodeUpdate>
  void particleToGrid(const Binning& b, const F& f, bool keepCentroids, const U& update = U{}) {
    b.particleToGrid(f, keepCentroids, *team_, threads, update);
  }
  bool partsReach(const Binning& b, const PartView* parts, int nParts) const { return b.partsReach(parts, nParts); }
  /// `selectCentroids`: P2G may sum the material centroids only where the contact pass
  /// reads them (not with mirror planes, whose fold moves them between blocks).
  void findNearParts(Binning& b, const PartView* parts, int nParts, bool selectCentroids) {
    b.findNearParts(parts, nParts, selectCentroids);
  }
  void contactPass(Binning& b, const PartView* parts, int nParts, const BodyView* bodies, int nBodies,
                   ContactSums* out, int pass) {
    b.contactPass(parts, nParts, bodies, nBodies, out, pass, *team_, threads);
  }
  template <class F>
  void gridToParticle(const Binning& b, const F& f) { keepCheck(b.gridToParticle(f, *team_, threads)); }
  /// G2P with `g`, then P2G with `f` and the node kernel `update`: the particles the same
  /// as gridToParticle and particleToGrid one after the other give them, in one pass
  /// (Binning::particleToGrid's gather). `f` and `g` share their batched stencil.
  template <class G, class F, class U>
  void gatherThenScatter(const Binning& b, const G& g, const F& f, bool keepCentroids, const U& update) {
    keepCheck(b.particleToGrid(f, keepCentroids, *team_, threads, update, g));
  }

 private:
  void keepCheck(const StepCheck& c) {
    // the speed that matters for the next substep count is the latest one
    check_.maxSpeed2 = c.maxSpeed2;
    check_.peakSpeed2 = std::max(check_.peakSpeed2, c.maxSpeed2);
    check_.firstBadParticle = std::min(check_.firstBadParticle, c.firstBadParticle);
  }
};

}  // namespace mpm
