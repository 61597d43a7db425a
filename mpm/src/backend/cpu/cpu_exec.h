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
// (transfer/grid_nodes.h).

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

  /// Particles binned by grid block, and the active grid blocks they reach. Its members
  /// are defined by concern: the binning in binning_sort.h, the transfers in
  /// binning_transfers.h, the parts near each block and the grid contact in
  /// binning_contact.h (all included at the end of this file).
  class Binning {
   public:
    Binning(CpuExec&, const GridGeometry& geo)
        : geo_(geo),
          blockCount_(nBlocks(geo), 0),
          blockSlot_(nBlocks(geo), -1),
          occupiedRank_(nBlocks(geo), -1) {}

    /// Bins the particles (binning_sort.h).
    void build(const ParticleView& P, ThreadTeam& pool, int threads);

    // The transfers (binning_transfers.h).
    template <class F, class U = NoNodeUpdate, class G = NoGather>
    StepCheck particleToGrid(const F& f, bool keepCentroids, ThreadTeam& pool, int threads, const U& update = U{},
                             const G& gather = G{}) const;
    template <bool kMx, bool kDmv, bool kSumMx>
    void sumTiles(const GridView& grid, uint32_t slot, bool keepCentroids) const;
    template <class F>
    StepCheck gridToParticle(const F& f, ThreadTeam& pool, int threads) const;
    void ownBlocks(int t, int nt, uint32_t& first, uint32_t& last) const;
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
    struct Gatherer;

    // The parts near each block and the grid contact with them (binning_contact.h).
    void findNearParts(const PartView* parts, int nParts, bool selectCentroids);
    void selectCentroidBlocks();
    void contactPass(const PartView* parts, int nParts, const BodyView* bodies, int nBodies,
                     ContactSums* out, int pass, ThreadTeam& pool, int threads);
    void findSegmentRuns(const PartView* parts, int nParts, const BodyView* bodies);
    bool partsReach(const PartView* parts, int nParts) const;

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
    void activate();  ///< binning_sort.h
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

    // binning_contact.h
    void nearBox(uint32_t block, Vec3f& lo, Vec3f& hi) const;
    void nearBox(int bx, int by, int bz, Vec3f& lo, Vec3f& hi) const;
    void addNear(const PartView& part, int p, uint32_t slot, int bx, int by, int bz);
    void nodeBox(int bx, int by, int bz, Vec3f& lo, Vec3f& hi) const;
    NearParts nearParts(uint32_t block) const;
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

// CpuExec::Binning's members, by concern
#include "backend/cpu/binning_sort.h"
#include "backend/cpu/binning_transfers.h"
#include "backend/cpu/binning_contact.h"
