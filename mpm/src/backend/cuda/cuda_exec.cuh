#pragma once
// CUDA execution backend: device memory, one launch helper, binning with CCCL (CUB and
// thrust), and the launches of the transfers (tile_transfers.cuh). The development and CI
// machines have no GPU: this is compiled and linked there and run only where a device is
// present (the whole suite passed on an H100 once, the CUDA test cases on an H200); the
// kernel bodies it launches are the ones the CPU tests exercise.
#include <cuda_runtime.h>
#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_select.cuh>
#include <thrust/execution_policy.h>
#include <thrust/iterator/counting_iterator.h>
#include <thrust/iterator/transform_iterator.h>
#include <thrust/system/cuda/execution_policy.h>
#include <thrust/sequence.h>
#include <thrust/sort.h>
#include <thrust/unique.h>
#include <type_traits>

#include <map>
#include <string>

#include "backend/cuda/tile_transfers.cuh"
#include "system/sim_backend.h"
#include "transfer/apic.h"
#include "transfer/grid_nodes.h"

namespace mpm {

inline void cudaCheck(cudaError_t e, const char* what, size_t bytes = 0) {
  if (e == cudaErrorMemoryAllocation) {
    cudaGetLastError();  // not sticky: clear it, so the scene steps on once memory allows
    throw OutOfMemory(std::string("CUDA device memory (") + what + ")", bytes);
  }
  if (e != cudaSuccess)
    throw Error(std::string("CUDA backend: ") + what + " failed: " + cudaGetErrorString(e));
}

template <class F>
__global__ void forEachKernel(size_t n, F f) {
  const size_t i = (size_t)blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) f(i);
}

/// clearNode of every node, before P2G adds to them.
struct ClearNodes {
  GridNode* nodes;
  bool keepCentroids;
  MPM_HD void operator()(size_t n) const { clearNode(nodes[n], keepCentroids); }
};

/// Grid contact per active node; each touched part's momentum exchange is added
/// atomically to its body's sums.
static __global__ void contactKernel(GridView grid, const PartView* parts, int nParts, const BodyView* bodies,
                              ContactSums* out, int pass) {
  const size_t n = (size_t)blockIdx.x * blockDim.x + threadIdx.x;
  if (n >= (size_t)grid.activeCount * kBlockNodes) return;
  GridNode& node = grid.nodes[n];
  int bx, by, bz;
  grid.geo.blockCoords(grid.activeBlocks[n / kBlockNodes], bx, by, bz);
  const int local = (int)(n % kBlockNodes);
  const Vec3f x = grid.geo.lower + grid.geo.dx * Vec3f{(float)((bx << kBlockBits) + (local >> (2 * kBlockBits))),
                                                       (float)((by << kBlockBits) + ((local >> kBlockBits) & kBlockMask)),
                                                       (float)((bz << kBlockBits) + (local & kBlockMask))};
  if (!takesContact(node, x, grid.geo)) return;
  for (int p = 0; p < nParts; ++p) {
    if (!parts[p].mayTouch(x, x)) continue;
    ContactSums s{};
    if (!contactNodePart(x, node.mass, node.mv, (1.f / node.mass) * node.mx, materialTouches(node) ? grid.geo.dx : 0.f, parts,
                         nParts, p, bodies, s, pass))
      continue;
    float* dst = &out[parts[p].body].impulse[0];
    const float* src = &s.impulse[0];
    for (int k = 0; k < kContactSumFloats; ++k) atomicAdd(dst + k, src[k]);
  }
}

/// Scratch memory for thrust's algorithms, kept between calls. thrust's default policy
/// takes its temporary storage with cudaMalloc and gives it back with cudaFree, which waits
/// for the device: binning every substep paid that several times.
class ScratchAllocator {
 public:
  using value_type = char;
  ScratchAllocator() = default;
  ScratchAllocator(const ScratchAllocator&) = delete;
  ScratchAllocator& operator=(const ScratchAllocator&) = delete;
  ~ScratchAllocator() {
    for (auto& [bytes, p] : free_) cudaFree(p);
    for (auto& [p, bytes] : used_) cudaFree(p);
  }
  char* allocate(std::ptrdiff_t n) {
    const size_t bytes = (size_t)n;
    auto it = free_.lower_bound(bytes);  // the smallest kept block that fits
    char* p = nullptr;
    if (it != free_.end()) {
      p = it->second;
      used_.emplace(p, it->first);
      free_.erase(it);
      return p;
    }
    cudaCheck(cudaMalloc(&p, bytes), "cudaMalloc(thrust scratch)", bytes);
    used_.emplace(p, bytes);
    return p;
  }
  /// Device bytes held, in use or kept.
  size_t bytes() const {
    size_t total = 0;
    for (const auto& [bytes, p] : free_) total += bytes;
    for (const auto& [p, bytes] : used_) total += bytes;
    return total;
  }
  void deallocate(char* p, size_t) {
    auto it = used_.find(p);
    if (it == used_.end()) return;
    free_.emplace(it->second, p);
    used_.erase(it);
  }

 private:
  std::multimap<size_t, char*> free_;  ///< size -> block
  std::map<char*, size_t> used_;       ///< block -> size
};

struct CudaExec {
  static constexpr int kThreads = 256;
  /// Threads of the transfers' CUDA blocks, one per occupied grid block (a few hundred
  /// particles): 128 where there are blocks enough to fill the device several times over
  /// (more blocks per multiprocessor hide more latency), else 256, so that a small scene's
  /// few blocks take their particles in fewer rounds (256 threads launch with any register
  /// count a kernel may need, up to 255).
  unsigned int tileThreads(size_t occupied) const { return occupied >= 4 * (size_t)multiprocessors_ ? 128u : 256u; }

  /// Each scene's work goes to its own stream, so the steps of scenes advanced together
  /// (SceneBatch) overlap on the device. A blocking stream: it still waits for work left on
  /// the legacy default stream, should anything launch there.
  CudaExec() {
    int device = 0;
    cudaCheck(cudaGetDevice(&device), "cudaGetDevice");
    cudaCheck(cudaDeviceGetAttribute(&multiprocessors_, cudaDevAttrMultiProcessorCount, device), "device attributes");
    cudaCheck(cudaStreamCreate(&stream_), "cudaStreamCreate");
    cudaCheck(cudaMalloc(&checkBuffer_, 2 * sizeof(uint32_t)), "cudaMalloc(check)");
    resetCheck();
  }
  ~CudaExec() {
    cudaFree(checkBuffer_);
    cudaStreamDestroy(stream_);
  }
  CudaExec(const CudaExec&) = delete;
  CudaExec& operator=(const CudaExec&) = delete;

  template <class T>
  T* allocate(size_t n) {
    void* p = nullptr;
    cudaCheck(cudaMalloc(&p, n * sizeof(T)), "cudaMalloc", n * sizeof(T));
    return static_cast<T*>(p);
  }
  void release(void* p) { cudaFree(p); }
  // host copies wait for the stream, as cudaMemcpy waited for the default stream: the
  // host buffer may go (or be read) when they return
  void copyToDevice(void* dst, const void* src, size_t bytes) {
    if (!bytes) return;
    cudaCheck(cudaMemcpyAsync(dst, src, bytes, cudaMemcpyHostToDevice, stream_), "copy to device");
    cudaCheck(cudaStreamSynchronize(stream_), "copy to device");
  }
  void copyToHost(void* dst, const void* src, size_t bytes) const {
    if (!bytes) return;
    cudaCheck(cudaMemcpyAsync(dst, src, bytes, cudaMemcpyDeviceToHost, stream_), "copy to host");
    cudaCheck(cudaStreamSynchronize(stream_), "copy to host");
  }
  void copyOnDevice(void* dst, const void* src, size_t bytes) {
    if (bytes) cudaCheck(cudaMemcpyAsync(dst, src, bytes, cudaMemcpyDeviceToDevice, stream_), "device copy");
  }
  cudaStream_t stream() const { return stream_; }

  static unsigned int blocksFor(size_t n) { return (unsigned int)((n + kThreads - 1) / kThreads); }

  /// The one launch helper: rounds the grid, skips empty launches, checks the launch.
  template <class F>
  void forEach(size_t n, const F& f) {
    if (n == 0) return;
    forEachKernel<<<blocksFor(n), kThreads, 0, stream_>>>(n, f);
    cudaCheck(cudaGetLastError(), "kernel launch");
  }


  StepCheck takeCheck() {
    uint32_t h[2];
    copyToHost(h, checkBuffer_, sizeof h);
    resetCheck();
    StepCheck c;
    float speed2;
    static_assert(sizeof(speed2) == sizeof(h[0]), "float is 32 bits");
    memcpy(&speed2, &h[0], sizeof speed2);
    c.maxSpeed2 = speed2;  // the device's maximum runs over the whole advance
    c.peakSpeed2 = speed2;
    c.firstBadParticle = h[1];
    return c;
  }

  void resetCheck() {
    const uint32_t init[2] = {0u, 0xffffffffu};
    copyToDevice(checkBuffer_, init, sizeof init);
  }

  /// Particles sorted by grid block (order), and the active blocks they reach.
  class Binning;

  void bin(const ParticleView& P, Binning& b);
  /// The parts and the active blocks are device data: asking whether they meet would wait
  /// on the device every substep, so the CUDA backend answers yes whenever parts exist (a
  /// far shape still costs its contact terms there; the CPU backend skips them).
  bool partsReach(const Binning& /*b*/, const PartView* /*parts*/, int nParts) const { return nParts > 0; }
  /// Every node and particle tries every part (bounds first): no lists per block.
  void findNearParts(Binning& /*b*/, const PartView* /*parts*/, int /*nParts*/, bool /*selectCentroids*/) {}
  void contactPass(Binning& b, const PartView* parts, int nParts, const BodyView* bodies, int nBodies,
                   ContactSums* out, int pass);
  /// P2G, then the node kernel `update` on every active node (NoNodeUpdate: none) in a
  /// launch of its own.
  template <class F, class U = NoNodeUpdate>
  void particleToGrid(const Binning& b, const F& f, bool keepCentroids, const U& update = U{});
  template <class F>
  void gridToParticle(const Binning& b, const F& f);
  /// G2P with `g`, then P2G with `f` and the node kernel `update`, one after the other.
  template <class G, class F, class U>
  void gatherThenScatter(const Binning& b, const G& g, const F& f, bool keepCentroids, const U& update) {
    gridToParticle(b, g);
    particleToGrid(b, f, keepCentroids, update);
  }

 private:
  cudaStream_t stream_ = nullptr;
  uint32_t* checkBuffer_ = nullptr;
  int multiprocessors_ = 1;
};

namespace cuda_kernels {

/// A particle's sort key (GridGeometry::particleKey); particles whose stencil leaves the
/// grid: 0.
struct ParticleKeys {
  ParticleView P;
  GridGeometry geo;
  uint32_t* keys;
  MPM_HD void operator()(size_t i) const { keys[i] = geo.stencilInside(P.x[i]) ? geo.particleKey(P.x[i]) : 0u; }
};

/// The block of a sort key.
struct KeyBlock {
  MPM_HD uint32_t operator()(uint32_t key) const { return GridGeometry::keyBlock(key); }
};

/// The eight blocks an occupied block's particles reach (those outside the grid: the block
/// itself); past the occupied count, the first occupied block's eight.
struct StencilBlocks {
  GridGeometry geo;
  const uint32_t* occupied;
  const uint32_t* occupiedCount;
  uint32_t* candidates;
  MPM_HD void operator()(size_t j) const {
    const uint32_t block = occupied[j < *occupiedCount ? j : 0];
    int bx, by, bz;
    geo.blockCoords(block, bx, by, bz);
    for (int c = 0; c < 8; ++c) {
      const int x = bx + (c & 1), y = by + ((c >> 1) & 1), z = bz + (c >> 2);
      const bool inside = x < geo.blocks[0] && y < geo.blocks[1] && z < geo.blocks[2];
      // outside the grid: the block itself again, which the unique blocks drop
      candidates[8 * j + c] = inside ? geo.blockIndex(x, y, z) : block;
    }
  }
};

struct SetSlot {
  int32_t* blockSlot;
  const uint32_t* active;
  int clear;
  MPM_HD void operator()(size_t k) const { blockSlot[active[k]] = clear ? -1 : (int32_t)k; }
};

/// The end of the last run: runStart[runCount] = n.
struct EndRuns {
  uint32_t* runStart;
  const uint32_t* runCount;
  uint32_t n;
  MPM_HD void operator()(size_t) const { runStart[*runCount] = n; }
};

struct FillInt {
  int32_t* out;
  int32_t value;
  MPM_HD void operator()(size_t i) const { out[i] = value; }
};

}  // namespace cuda_kernels

class CudaExec::Binning {
 public:
  Binning(CudaExec& exec, const GridGeometry& geo) : exec_(exec), geo_(geo) {
    blocks_ = (size_t)geo.blocks[0] * geo.blocks[1] * geo.blocks[2];
    if (blocks_ > (size_t{1} << (32 - GridGeometry::kCellKeyBits)))
      throw InvalidArgument("SceneSettings.domain (CUDA backend)", std::to_string(blocks_) + " grid blocks",
                            "at most 2^26 blocks of 4^3 nodes (a particle's sort key is 32 bits)");
    blockSlot_ = exec_.allocate<int32_t>(blocks_);
    runCount_ = exec_.allocate<uint32_t>(1);
    exec_.forEach(blocks_, cuda_kernels::FillInt{blockSlot_, -1});
  }
  ~Binning() {
    for (void* p : {(void*)blockSlot_, (void*)runCount_, (void*)keys_, (void*)keysAlt_, (void*)order_, (void*)orderAlt_,
                    (void*)runBlock_, (void*)runStart_, (void*)candidates_, (void*)active_, (void*)nodes_})
      if (p) exec_.release(p);
  }

  void build(const ParticleView& P) {
    const size_t n = P.count;
    count_ = n;
    if (n == 0) {  // no particles: no active blocks
      exec_.forEach(activeCount_, cuda_kernels::SetSlot{blockSlot_, active_, 1});
      activeCount_ = occupiedBound_ = 0;
      return;
    }
    grow(keys_, keysCap_, n);
    grow(keysAlt_, keysAltCap_, n);
    grow(order_, orderCap_, n);
    grow(orderAlt_, orderAltCap_, n);
    exec_.forEach(n, cuda_kernels::ParticleKeys{P, geo_, keys_});
    // The host waits for the device once per binning, for the active-block count that sizes
    // the node arrays and the node launches; the occupied blocks stay a device-side count
    // (runCount_), the transfers launching one CUDA block per possible one: no more than the
    // particles, the grid's blocks or the active blocks (each occupied block is active).
    const auto queued = thrust::cuda::par_nosync(scratch_).on(exec_.stream());
    const auto counted = thrust::cuda::par(scratch_).on(exec_.stream());
    thrust::sequence(queued, order_, order_ + n);
    sortByKey(n);
    // the occupied blocks and where each one's particles start in the order (P2G's runs)
    const size_t runsBound = std::min(n, blocks_);
    grow(runBlock_, runBlockCap_, runsBound);
    grow(runStart_, runStartCap_, runsBound + 1);
    const auto blockOf = thrust::make_transform_iterator(keys_, cuda_kernels::KeyBlock{});
    size_t bytes = 0;
    cudaCheck(cub::DeviceSelect::UniqueByKey(nullptr, bytes, blockOf, thrust::counting_iterator<uint32_t>(0), runBlock_,
                                             runStart_, runCount_, (int64_t)n, exec_.stream()),
              "unique blocks (size)");
    char* temp = scratch_.allocate((std::ptrdiff_t)bytes);
    cudaCheck(cub::DeviceSelect::UniqueByKey(temp, bytes, blockOf, thrust::counting_iterator<uint32_t>(0), runBlock_,
                                             runStart_, runCount_, (int64_t)n, exec_.stream()),
              "unique blocks");
    scratch_.deallocate(temp, bytes);
    exec_.forEach(1, cuda_kernels::EndRuns{runStart_, runCount_, (uint32_t)n});
    // the blocks their stencils reach: the active blocks, which get slots
    grow(candidates_, candidatesCap_, 8 * runsBound);
    exec_.forEach(runsBound, cuda_kernels::StencilBlocks{geo_, runBlock_, runCount_, candidates_});
    thrust::sort(queued, candidates_, candidates_ + 8 * runsBound);
    exec_.forEach(activeCount_, cuda_kernels::SetSlot{blockSlot_, active_, 1});  // the last binning's
    grow(active_, activeCap_, 8 * runsBound);
    activeCount_ = thrust::unique_copy(counted, candidates_, candidates_ + 8 * runsBound, active_) - active_;
    occupiedBound_ = std::min(runsBound, activeCount_);
    exec_.forEach(activeCount_, cuda_kernels::SetSlot{blockSlot_, active_, 0});
    grow(nodes_, nodesCap_, activeCount_ * kBlockNodes);
  }

  GridView gridView() const {
    GridView g;
    g.geo = geo_;
    g.blockSlot = blockSlot_;
    g.activeBlocks = active_;
    g.nodes = nodes_;
    g.activeCount = (uint32_t)activeCount_;
    return g;
  }
  const uint32_t* order() const { return order_; }
  size_t count() const { return count_; }
  /// Grid blocks that hold particles (their stencil bases): at most occupiedBound(), their
  /// number on the device (runCount()), and where each one's run of particles starts in
  /// order() (runCount() + 1 entries, the last one count()).
  size_t occupiedBound() const { return occupiedBound_; }
  const uint32_t* runCount() const { return runCount_; }
  const uint32_t* runBlocks() const { return runBlock_; }
  const uint32_t* runStarts() const { return runStart_; }
  size_t memoryBytes() const {
    return blocks_ * 4 +
           (keysCap_ + keysAltCap_ + orderCap_ + orderAltCap_ + runBlockCap_ + runStartCap_ + candidatesCap_ + activeCap_) *
               4 +
           nodesCap_ * sizeof(GridNode) + scratch_.bytes();
  }

 private:
  /// Sorts keys_ with order_ by the key bits that can be set (the grid's block count and
  /// the cell within the block: 18 of 32 bits for the 56^3-node CRESSim grid, three radix
  /// passes instead of four); the sorted arrays may come back in the other buffers.
  void sortByKey(size_t n) {
    const int bits = keyBits();
    cub::DoubleBuffer<uint32_t> keys(keys_, keysAlt_), order(order_, orderAlt_);
    size_t bytes = 0;
    cudaCheck(cub::DeviceRadixSort::SortPairs(nullptr, bytes, keys, order, (int)n, 0, bits, exec_.stream()),
              "radix sort (size)");
    char* temp = scratch_.allocate((std::ptrdiff_t)bytes);
    cudaCheck(cub::DeviceRadixSort::SortPairs(temp, bytes, keys, order, (int)n, 0, bits, exec_.stream()), "radix sort");
    scratch_.deallocate(temp, bytes);  // kept for the next sort, which the stream orders after this one
    if (keys.Current() != keys_) std::swap(keys_, keysAlt_);
    if (order.Current() != order_) std::swap(order_, orderAlt_);
  }
  int keyBits() const {
    const uint64_t keys = (uint64_t)blocks_ << GridGeometry::kCellKeyBits;
    int bits = 1;
    while (bits < 32 && (uint64_t{1} << bits) < keys) ++bits;
    return bits;
  }

  /// Grows a device array to at least n elements (contents not kept); never shrinks,
  /// so a scene at steady size allocates nothing inside the step.
  template <class T>
  void grow(T*& p, size_t& cap, size_t n) {
    if (n <= cap) return;
    if (p) exec_.release(p);
    p = exec_.allocate<T>(n);
    cap = n;
  }

  CudaExec& exec_;
  ScratchAllocator scratch_;
  GridGeometry geo_;
  size_t blocks_ = 0, count_ = 0, occupiedBound_ = 0, activeCount_ = 0;
  int32_t* blockSlot_ = nullptr;
  uint32_t* runCount_ = nullptr;
  uint32_t *keys_ = nullptr, *keysAlt_ = nullptr, *order_ = nullptr, *orderAlt_ = nullptr, *runBlock_ = nullptr,
           *runStart_ = nullptr, *candidates_ = nullptr, *active_ = nullptr;
  size_t keysCap_ = 0, keysAltCap_ = 0, orderCap_ = 0, orderAltCap_ = 0, runBlockCap_ = 0, runStartCap_ = 0,
         candidatesCap_ = 0, activeCap_ = 0, nodesCap_ = 0;
  GridNode* nodes_ = nullptr;
};

inline void CudaExec::bin(const ParticleView& P, Binning& b) { b.build(P); }

inline void CudaExec::contactPass(Binning& b, const PartView* parts, int nParts, const BodyView* bodies,
                                  int nBodies, ContactSums* out, int pass) {
  cudaCheck(cudaMemsetAsync(out, 0, nBodies * sizeof(ContactSums), stream_), "clear contact sums");
  const size_t nodes = (size_t)b.gridView().activeCount * kBlockNodes;
  if (nodes == 0 || nParts == 0) return;
  contactKernel<<<blocksFor(nodes), kThreads, 0, stream_>>>(b.gridView(), parts, nParts, bodies, out, pass);
  cudaCheck(cudaGetLastError(), "kernel launch");
}

template <class F, class U>
void CudaExec::particleToGrid(const Binning& b, const F& f, bool keepCentroids, const U& update) {
  const GridView grid = b.gridView();
  const size_t nodes = (size_t)grid.activeCount * kBlockNodes;
  forEach(nodes, ClearNodes{grid.nodes, keepCentroids});
  if (b.count() > 0) {
    particleToTileKernel<UsesCentroid<F>::value, UsesImpulse<F>::value>
        <<<(unsigned int)b.occupiedBound(), tileThreads(b.occupiedBound()), 0, stream_>>>(
            b.order(), b.runCount(), b.runStarts(), b.runBlocks(), f, grid);
    cudaCheck(cudaGetLastError(), "kernel launch");
  }
  if constexpr (!std::is_same_v<U, NoNodeUpdate>) forEach(nodes, update);
}

template <class F>
void CudaExec::gridToParticle(const Binning& b, const F& f) {
  if (b.count() == 0) return;
  // the speed that matters for the next substep count is the latest one
  cudaCheck(cudaMemsetAsync(checkBuffer_, 0, sizeof(uint32_t), stream_), "reset speed");
  gridToTileKernel<UsesOldVelocity<F>::value><<<(unsigned int)b.occupiedBound(), tileThreads(b.occupiedBound()), 0, stream_>>>(
      b.order(), b.runCount(), b.runStarts(), b.runBlocks(), f, b.gridView(), checkBuffer_, checkBuffer_ + 1);
  cudaCheck(cudaGetLastError(), "kernel launch");
}

}  // namespace mpm
