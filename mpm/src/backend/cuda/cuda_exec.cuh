#pragma once
// CUDA execution backend: device memory, one launch helper, atomics for P2G, and
// binning with CCCL (thrust) sorts. The development and CI machines have no GPU: this is
// compiled and linked there and run only where a device is present (the whole suite passed
// on an H100 once); the kernel bodies it launches are the ones the CPU tests exercise.
#include <cuda_runtime.h>
#include <thrust/execution_policy.h>
#include <thrust/system/cuda/execution_policy.h>
#include <thrust/sequence.h>
#include <thrust/sort.h>
#include <thrust/unique.h>

#include <map>
#include <string>

#include "backend/sim_backend.h"
#include "solvers/transfer.h"

namespace mpm {

inline void cudaCheck(cudaError_t e, const char* what) {
  if (e != cudaSuccess)
    throw Error(std::string("CUDA backend: ") + what + " failed: " + cudaGetErrorString(e));
}

template <class F>
__global__ void forEachKernel(size_t n, F f) {
  const size_t i = (size_t)blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) f(i);
}

/// G2P of every particle straight from the grid, folding each StepCheck into one
/// device-side check with atomics.
template <class F, class Nodes>
__global__ void gridToParticleKernel(size_t n, F f, Nodes nodes, unsigned int* maxSpeed2Bits,
                                     uint32_t* firstBad) {
  const size_t i = (size_t)blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  const StepCheck c = f((uint32_t)i, nodes);
  // non-negative floats order like their bit patterns
  atomicMax(maxSpeed2Bits, __float_as_uint(c.maxSpeed2));
  if (c.firstBadParticle != 0xffffffffu) atomicMin(firstBad, c.firstBadParticle);
}

/// clearNode of every node, before P2G adds to them.
struct ClearNodes {
  GridNode* nodes;
  bool keepCentroids;
  MPM_HD void operator()(size_t n) const { clearNode(nodes[n], keepCentroids); }
};

/// P2G of every particle, in block order so neighbouring threads hit neighbouring nodes.
template <class F, class Nodes>
__global__ void particleToGridKernel(size_t n, const uint32_t* order, F f, Nodes nodes) {
  const size_t i = (size_t)blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) f(order[i], nodes);
}

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
    cudaCheck(cudaMalloc(&p, bytes), "cudaMalloc(thrust scratch)");
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

  /// GPU threads of different particles meet on the same node: accumulate atomically.
  struct Add {
    MPM_HD static void add(float& a, float b) {
#ifdef __CUDA_ARCH__
      atomicAdd(&a, b);
#else
      a += b;
#endif
    }
  };

  /// Each scene's work goes to its own stream, so the steps of scenes advanced together
  /// (SceneBatch) overlap on the device. A blocking stream: it still waits for work left on
  /// the legacy default stream, should anything launch there.
  CudaExec() {
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
    cudaCheck(cudaMalloc(&p, n * sizeof(T)), "cudaMalloc");
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
    c.maxSpeed2 = speed2;
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
  void findNearParts(Binning& /*b*/, const PartView* /*parts*/, int /*nParts*/) {}
  void contactPass(Binning& b, const PartView* parts, int nParts, const BodyView* bodies, int nBodies,
                   ContactSums* out, int pass);
  template <class F>
  void particleToGrid(const Binning& b, const F& f, bool keepCentroids);
  template <class F>
  void gridToParticle(const Binning& b, const F& f);

 private:
  cudaStream_t stream_ = nullptr;
  uint32_t* checkBuffer_ = nullptr;
};

namespace cuda_kernels {

struct ParticleKeys {
  ParticleView P;
  GridGeometry geo;
  uint32_t* keys;
  MPM_HD void operator()(size_t i) const {
    keys[i] = geo.stencilInside(P.x[i]) ? geo.particleBlock(P.x[i]) : 0u;
  }
};

/// The eight blocks an occupied block's particles reach (sentinel outside the grid).
struct StencilBlocks {
  GridGeometry geo;
  const uint32_t* occupied;
  uint32_t* candidates;
  MPM_HD void operator()(size_t j) const {
    int bx, by, bz;
    geo.blockCoords(occupied[j], bx, by, bz);
    for (int c = 0; c < 8; ++c) {
      const int x = bx + (c & 1), y = by + ((c >> 1) & 1), z = bz + (c >> 2);
      const bool inside = x < geo.blocks[0] && y < geo.blocks[1] && z < geo.blocks[2];
      candidates[8 * j + c] = inside ? geo.blockIndex(x, y, z) : 0xffffffffu;
    }
  }
};

struct SetSlot {
  int32_t* blockSlot;
  const uint32_t* active;
  int clear;
  MPM_HD void operator()(size_t k) const { blockSlot[active[k]] = clear ? -1 : (int32_t)k; }
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
    blockSlot_ = exec_.allocate<int32_t>(blocks_);
    exec_.forEach(blocks_, cuda_kernels::FillInt{blockSlot_, -1});
  }
  ~Binning() {
    for (void* p : {(void*)blockSlot_, (void*)keys_, (void*)order_, (void*)candidates_,
                    (void*)active_, (void*)nodes_})
      if (p) exec_.release(p);
  }

  void build(const ParticleView& P) {
    const size_t n = P.count;
    grow(keys_, keysCap_, n);
    grow(order_, orderCap_, n);
    exec_.forEach(n, cuda_kernels::ParticleKeys{P, geo_, keys_});
    const auto policy = thrust::cuda::par(scratch_).on(exec_.stream());
    thrust::sequence(policy, order_, order_ + n);
    thrust::stable_sort_by_key(policy, keys_, keys_ + n, order_);
    // occupied blocks, in place at the front of keys_
    const size_t occupied = thrust::unique(policy, keys_, keys_ + n) - keys_;
    grow(candidates_, candidatesCap_, 8 * occupied);
    exec_.forEach(occupied, cuda_kernels::StencilBlocks{geo_, keys_, candidates_});
    thrust::sort(policy, candidates_, candidates_ + 8 * occupied);
    size_t active = thrust::unique(policy, candidates_, candidates_ + 8 * occupied) - candidates_;
    uint32_t last = 0;
    if (active) exec_.copyToHost(&last, candidates_ + active - 1, sizeof last);
    if (active && last == 0xffffffffu) --active;  // drop the sentinel

    exec_.forEach(activeCount_, cuda_kernels::SetSlot{blockSlot_, active_, 1});
    grow(active_, activeCap_, active);
    exec_.copyOnDevice(active_, candidates_, active * sizeof(uint32_t));
    activeCount_ = active;
    exec_.forEach(activeCount_, cuda_kernels::SetSlot{blockSlot_, active_, 0});
    grow(nodes_, nodesCap_, activeCount_ * kBlockNodes);
    count_ = n;
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
  size_t memoryBytes() const {
    return blocks_ * 4 + (keysCap_ + orderCap_ + candidatesCap_ + activeCap_) * 4 +
           nodesCap_ * sizeof(GridNode) + scratch_.bytes();
  }

 private:
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
  size_t blocks_ = 0, count_ = 0, activeCount_ = 0;
  int32_t* blockSlot_ = nullptr;
  uint32_t *keys_ = nullptr, *order_ = nullptr, *candidates_ = nullptr, *active_ = nullptr;
  size_t keysCap_ = 0, orderCap_ = 0, candidatesCap_ = 0, activeCap_ = 0, nodesCap_ = 0;
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

template <class F>
void CudaExec::particleToGrid(const Binning& b, const F& f, bool keepCentroids) {
  const GridView grid = b.gridView();
  forEach((size_t)grid.activeCount * kBlockNodes, ClearNodes{grid.nodes, keepCentroids});
  if (b.count() == 0) return;
  particleToGridKernel<<<blocksFor(b.count()), kThreads, 0, stream_>>>(b.count(), b.order(), f,
                                                                      GridNodes<Add>{grid});
  cudaCheck(cudaGetLastError(), "kernel launch");
}

template <class F>
void CudaExec::gridToParticle(const Binning& b, const F& f) {
  if (b.count() == 0) return;
  // the speed that matters for the next substep count is the latest one
  cudaCheck(cudaMemsetAsync(checkBuffer_, 0, sizeof(uint32_t), stream_), "reset speed");
  gridToParticleKernel<<<blocksFor(b.count()), kThreads, 0, stream_>>>(
      b.count(), f, GridNodes<Add>{b.gridView()}, checkBuffer_, checkBuffer_ + 1);
  cudaCheck(cudaGetLastError(), "kernel launch");
}

}  // namespace mpm
