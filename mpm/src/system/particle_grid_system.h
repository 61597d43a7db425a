#pragma once
// ParticleGridSystem<Exec, Method>: particle and grid memory, and the stages every
// particle-grid solver is made of (binning, grid clear, scatter, grid update, rigid
// contact, gather), written once for any execution backend. The Method (solvers/) composes
// the stages into its substep and supplies the per-particle and per-node kernels; adding a
// solver is a new Method and a line in solvers/solver_list.h, nothing here.
//
// Exec supplies memory (allocate/release/copies), a parallel forEach, and the things
// that genuinely differ between CPU and GPU: binning particles into grid blocks
// (activating the blocks they reach) and how the transfers reach the nodes (on the CPU
// through a per-block tile, blocks coloured so that no atomics are needed; on the GPU
// straight into the grid with atomics). Kernel bodies are the host/device functions in
// solvers/ and grid/, called with either kind of node accessor.
#include <algorithm>
#include <chrono>
#include <cstring>
#include <type_traits>
#include <utility>

#include "system/exec_array.h"
#include "system/shape_set.h"
#include "system/sim_backend.h"
#include "tools/cutting_stage.h"

namespace mpm {

namespace kernels {

/// out[i] = in[order[i]]: applies a sort permutation to one field.
template <class T>
struct Gather {
  T* out;
  const T* in;
  const uint32_t* order;
  MPM_HD void operator()(size_t i) const { out[i] = in[order[i]]; }
};

}  // namespace kernels

/// Exec::Binning::renumberSorted: the binning made for a sort holds after it (CpuExec), so
/// the first substep's binParticles keeps it.
template <class Exec, class = void>
struct KeepsBinning : std::false_type {};
template <class Exec>
struct KeepsBinning<Exec, std::void_t<decltype(std::declval<typename Exec::Binning&>().renumberSorted())>>
    : std::true_type {};

/// Exec::kGatherByField: the backend gathers a field on one thread (CpuExec::gatherSerial),
/// so sorting gathers the fields side by side, a field per thread; otherwise (GPU) each
/// field is one parallel gather.
template <class Exec, class = void>
struct GathersByField : std::false_type {};
template <class Exec>
struct GathersByField<Exec, std::void_t<decltype(Exec::kGatherByField)>>
    : std::bool_constant<Exec::kGatherByField> {};

template <class Exec, class Method>
class ParticleGridSystem final : private ExecOwner<Exec>, public ShapeBackend<Exec> {
  using ExecOwner<Exec>::exec_;
  using ShapeBackend<Exec>::shapes_;
  using ShapeBackend<Exec>::timings;

 public:
  template <class... Args>
  ParticleGridSystem(const GridGeometry& geo, Args&&... execArgs)
      : ExecOwner<Exec>(std::forward<Args>(execArgs)...), ShapeBackend<Exec>(this->exec_), geo_(geo), bins_(exec_, geo),
        cutting_(exec_) {
#define MPM_BIND(type, name) \
  name##_.bind(&exec_);      \
  name##Saved_.bind(&exec_);
    MPM_PARTICLE_FIELDS(MPM_BIND)
#undef MPM_BIND
    materials_.bind(&exec_);
  }

  void append(const HostParticles& add) override {
    binned_ = false;
    const size_t old = count_, n = count_ + add.size();
#define MPM_APPEND(type, name)                                                          \
  {                                                                                     \
    ExecArray<type, Exec> grown;                                                        \
    grown.bind(&exec_);                                                                 \
    grown.resizeDiscard(n);                                                             \
    if (old) exec_.copyOnDevice(grown.data(), name##_.data(), old * sizeof(type));      \
    exec_.copyToDevice(grown.data() + old, add.name.data(), add.size() * sizeof(type)); \
    name##_.swap(grown);                                                                \
  }
    MPM_PARTICLE_FIELDS(MPM_APPEND)
#undef MPM_APPEND
    count_ = n;
    // the particles' largest touch distance, for the parts' push-out boxes (placeShapes);
    // a volume that is no finite size leaves it unknown (infinite: the parts' bounds)
    for (const float v : add.volume0) touchReach_ = std::max(touchReach_, v >= 0.f && v < INFINITY ? touchDistance(v) : INFINITY);
  }

  /// The state kept (restoreState) and the particles ordered by grid block in one pass:
  /// each field is gathered in block order into its spare copy and the two swap, so the
  /// copy holds the state as it was and the transfers walk memory in order. Sorting in
  /// place after a separate copy walked the particle memory twice (permute and copy: 13 %
  /// of the suturing demo, whose tissue advances one substep per Bullet tick). Particles
  /// already in block order (most advances of a substep or two: none crossed a block since
  /// the last sort) have only their state fields copied, the model fields staying put.
  void saveStateAndSort() override {
    if (count_ == 0) return;
    auto t0 = Clock::now();
    exec_.bin(view(), bins_);
    const uint32_t* order = bins_.order();
    bool inOrder = false;
    if constexpr (KeepsBinning<Exec>::value) inOrder = bins_.inOrder();
    modelKept_ = !inOrder;
    // the copies' memory first, here on the calling thread: running out is then an error
    // before anything moved, not an exception in one of the team's tasks halfway through
    size_t bytes = 0;
#define MPM_BYTES(type, name) bytes += count_ * sizeof(type);
    MPM_PARTICLE_STATE_FIELDS(MPM_BYTES)
    if (!inOrder) {
      MPM_PARTICLE_MODEL_FIELDS(MPM_BYTES)
    }
#undef MPM_BYTES
    try {
#define MPM_RESERVE(type, name) name##Saved_.resizeDiscard(count_);
      MPM_PARTICLE_STATE_FIELDS(MPM_RESERVE)
      if (!inOrder) {
        MPM_PARTICLE_MODEL_FIELDS(MPM_RESERVE)
      }
#undef MPM_RESERVE
    } catch (const OutOfMemory&) {
      throw OutOfMemory("the copy of " + std::to_string(count_) + " particles' state kept to undo the advance", bytes);
    }
    // a field's copy: moved into block order, or as it is when nothing moves (the model
    // fields then not at all)
    const auto keep = [&](auto& saved, const auto& field, bool model) {
      using T = std::remove_pointer_t<decltype(field.data())>;
      if (inOrder && model) return;
      if (inOrder)
        exec_.copyOnDevice(saved.data(), field.data(), count_ * sizeof(T));
      else if constexpr (GathersByField<Exec>::value)  // on the task's own thread
        exec_.gatherSerial(saved.data(), field.data(), order, count_);
      else
        exec_.forEach(count_, kernels::Gather<T>{saved.data(), field.data(), order});
    };
    // field k of the model fields, then the state fields
    constexpr int kFields = 0
#define MPM_COUNT(type, name) +1
        MPM_PARTICLE_FIELDS(MPM_COUNT);
#undef MPM_COUNT
    const auto keepField = [&](int field) {
      int k = 0;
#define MPM_KEEP_MODEL(type, name) if (field == k++) keep(name##Saved_, name##_, true);
#define MPM_KEEP_STATE(type, name) if (field == k++) keep(name##Saved_, name##_, false);
      MPM_PARTICLE_MODEL_FIELDS(MPM_KEEP_MODEL)
      MPM_PARTICLE_STATE_FIELDS(MPM_KEEP_STATE)
#undef MPM_KEEP_MODEL
#undef MPM_KEEP_STATE
    };
    if constexpr (GathersByField<Exec>::value)  // a field per thread at a time: one wake of the team for all
      exec_.forEachTask(kFields, count_, [&](int field, int) { keepField(field); });
    else
      for (int field = 0; field < kFields; ++field) keepField(field);
    if (!inOrder) {  // the gathered copies are the state in block order, the fields the kept one
#define MPM_SWAP(type, name) name##_.swap(name##Saved_);
      MPM_PARTICLE_FIELDS(MPM_SWAP)
#undef MPM_SWAP
      if constexpr (KeepsBinning<Exec>::value) bins_.renumberSorted();
    }
    // a coupler's tissue advancing one substep a tick had binned twice
    binned_ = KeepsBinning<Exec>::value;
    timings.sort += seconds(t0);
  }
  void restoreState() override {
    binned_ = false;
#define MPM_RESTORE(type, name) exec_.copyOnDevice(name##_.data(), name##Saved_.data(), count_ * sizeof(type));
    MPM_PARTICLE_STATE_FIELDS(MPM_RESTORE)
    if (modelKept_) {  // else the advance moved no particle: the model fields are as they were
      MPM_PARTICLE_MODEL_FIELDS(MPM_RESTORE)
    }
#undef MPM_RESTORE
  }

  void removeObjects(const std::vector<uint8_t>& keep) override {
    HostParticles all, kept;
    download(all);
    for (size_t i = 0; i < all.size(); ++i) {
      if (!keep[all.object[i]]) continue;
#define MPM_KEEP(type, name) kept.name.push_back(all.name[i]);
      MPM_PARTICLE_FIELDS(MPM_KEEP)
#undef MPM_KEEP
    }
    clear();
    append(kept);
  }

  void importState(const BackendState& in) override {
    clear();
    append(in.particles);
    cutting_.particlesReplaced(in.particles.cut);
  }

  void setShapes(const std::vector<BodyView>& bodies, const std::vector<PartView>& parts) override {
    ShapeBackend<Exec>::setShapes(bodies, parts);
    cutting_.setParts(parts, count_);
  }

  /// The shapes' impulses, the slicers' faces with the resistance to cutting added.
  std::vector<ContactSums> takeImpulses() override {
    std::vector<ContactSums> out = ShapeBackend<Exec>::takeImpulses();
    cutting_.addImpulses(out, count_);
    return out;  // setShapes, before every advance, zeroes them again
  }

  void setMaterials(const std::vector<MaterialParams>& m) override {
    cutting_.setMaterials(m);
    materials_.resizeDiscard(m.size());
    exec_.copyToDevice(materials_.data(), m.data(), m.size() * sizeof(MaterialParams));
  }

  void substep(const SubstepParams& s) override {
    if (count_ == 0) return;
    walls_ = s.walls;
    Method::substep(*this, s);
    timings.substeps += 1;
  }

  // ---- the stages a Method composes its substep from ----------------------------------

  ParticleView particles() const { return view(); }
  const GridGeometry& geometry() const { return geo_; }
  const MaterialParams* materials() const { return materials_.data(); }
  GridView grid() const { return bins_.gridView(); }
  /// Whether a part can reach the material this substep (placeShapes decides): only then
  /// do P2G sum the material centroids, the contact pass visit nodes and G2P test
  /// particles against the parts, so a shape far from every particle costs nothing more.
  bool hasShapes() const { return shapesInReach_; }
  const PartView* parts() const { return shapes_.parts(); }
  int partCount() const { return shapesInReach_ ? shapes_.partCount() : 0; }

  /// Whether some particle may carry a cut: a blade is in the scene, or was since the
  /// particles were last replaced. Until then the transfers do not read the cut field.
  bool cuts() const { return cutting_.cuts(); }
  /// The impulse the resistance to cutting (and to a needle's tip) gives each particle
  /// this substep, which P2G adds to the grid as a force (so standard MPM's FLIP sees it as
  /// the grid's change, not a kick the particle keeps); null when the shapes of this
  /// advance have no such resistance. The same for every substep of an advance: the
  /// solvers take it before recordCuts fills it (taken as "filled by the last recordCuts",
  /// a substep whose last one had none in reach lost its push while the blade took its
  /// share: 3 % of an insertion's momentum went missing).
  const Vec3f* cuttingPush() const { return cutting_.push(); }
  /// Records the cuts of the blades in reach on the particles beside them (before P2G,
  /// after placeShapes), and the resistances of this substep. Nothing without a blade or a
  /// needle's tip in the scene; with them out of reach, the push is zero.
  void recordCuts(float dt) {
    if (!cutting_.active()) return;
    const auto t0 = Clock::now();
    cutting_.record(view(), parts(), partCount(), shapes_.bodies(), materials_.data(), geo_, dt);
    timings.contact += seconds(t0);
  }

  /// Bins the particles by grid block and activates the blocks they reach.
  void binParticles() {
    if (binned_) {  // sorted just now: bins_ is the binning of the positions as they are
      binned_ = false;
      return;
    }
    const auto t0 = Clock::now();
    exec_.bin(view(), bins_);
    timings.sort += seconds(t0);
  }
  /// P2G: every node of the active blocks becomes the sum over the particles of what
  /// `k(p, nodes)` adds to it (fields k does not scatter: zero). With keepCentroids the
  /// material centroids (touch, mx) stay as the last P2G left them (k must not scatter
  /// them: PB-MPM's later cycles).
  ///
  /// Then the grid update: `u(n)` for every node of the active blocks (grid/grid_update.h).
  /// Where mirror planes must first fold their ghost nodes onto the material, after P2G
  /// in a pass of its own; otherwise in P2G's pass (Exec::particleToGrid: the CPU updates a
  /// block's nodes as soon as their sums are complete, while they are in its cache), and
  /// then timed as P2G.
  template <class K, class U>
  void scatterAndUpdate(const K& k, const U& u, bool keepCentroids = false) {
    auto t0 = Clock::now();
    centroidsKept_ = keepCentroids;
    if (!walls_.mirror) {
      exec_.particleToGrid(bins_, k, keepCentroids, u);
      timings.p2g += seconds(t0);
      return;
    }
    exec_.particleToGrid(bins_, k, keepCentroids);
    timings.p2g += seconds(t0);
    t0 = Clock::now();
    const size_t nodes = (size_t)grid().activeCount * kBlockNodes;
    exec_.forEach(nodes, MirrorFold{grid(), walls_, centroidsKept_});
    exec_.forEach(nodes, u);
    timings.gridUpdate += seconds(t0);
  }
  /// G2P with `g` (gather), then P2G with `k` and the grid update `u` (scatterAndUpdate):
  /// in one pass where the backend can (the CPU without mirror planes: each run of a
  /// block's particles gathered and then scattered, with the stencil both use computed
  /// once; timed as P2G), otherwise one after the other. The positions must not move
  /// (`g` does not integrate): PB-MPM's cycles before its last.
  template <class G, class K, class U>
  void gatherThenScatter(const G& g, const K& k, const U& u, bool keepCentroids) {
    if (walls_.mirror) {
      gather(g);
      scatterAndUpdate(k, u, keepCentroids);
      return;
    }
    const auto t0 = Clock::now();
    centroidsKept_ = keepCentroids;
    exec_.gatherThenScatter(bins_, g, k, keepCentroids, u);
    timings.p2g += seconds(t0);
  }
  /// Places the shapes' parts at their bodies' poses (once per substep, after binning and
  /// before P2G) and decides whether any can reach the active blocks.
  void placeShapes() {
    shapesInReach_ = false;
    if (shapes_.partCount() == 0) return;
    const auto t0 = Clock::now();
    // the contact band of a node reaches one cell beyond the part's own bounds
    shapes_.place(geo_.dx, touchReach_);
    shapesInReach_ = exec_.partsReach(bins_, shapes_.parts(), shapes_.partCount());
    // which parts are near which blocks, for the contact passes and G2P, and where P2G
    // must sum the material centroids (CPU; mirror planes fold them across blocks)
    if (shapesInReach_) exec_.findNearParts(bins_, shapes_.parts(), shapes_.partCount(), !walls_.mirror);
    timings.contact += seconds(t0);
  }
  /// Grid contact with the shapes (contact/contact_law.h) and the momentum exchange with dynamic
  /// bodies (ShapeSet::exchange), with gravity for the substep if `bodyGravity`. With
  /// every part out of reach the passes get no parts: they only zero the bodies' sums, and
  /// dynamic bodies feel gravity alone.
  /// `exchanges`: how often the solver exchanges with the shapes per substep (PB-MPM's
  /// iterations): a needle's shaft friction budget (dt) is shared among them.
  void exchangeContact(float dt, bool bodyGravity, int exchanges = 1) {
    if (shapes_.partCount() == 0) return;
    const int nParts = partCount(), nBodies = shapes_.bodyCount();
    const auto t0 = Clock::now();
    shapes_.exchange(dt / (float)exchanges, bodyGravity ? dt : 0.f, [&](int pass) {
      exec_.contactPass(bins_, shapes_.parts(), nParts, shapes_.bodies(), nBodies, shapes_.stepSums(), pass);
    });
    timings.contact += seconds(t0);
  }
  /// Advances the bodies' poses over the substep.
  void moveShapes(float dt) { shapes_.move(dt); }
  /// G2P: `k(p, nodes)` for every particle, returning its StepCheck; the mirror planes'
  /// ghost nodes take their velocities first.
  template <class K>
  void gather(const K& k) {
    const auto t0 = Clock::now();
    if (walls_.mirror) exec_.forEach((size_t)grid().activeCount * kBlockNodes, MirrorUnfold{grid(), walls_});
    exec_.gridToParticle(bins_, k);
    timings.g2p += seconds(t0);
  }

  StepCheck takeCheck() override { return exec_.takeCheck(); }


  void download(HostParticles& out) const override {
#define MPM_DOWNLOAD(type, name) \
  out.name.resize(count_);       \
  exec_.copyToHost(out.name.data(), name##_.data(), count_ * sizeof(type));
    MPM_PARTICLE_FIELDS(MPM_DOWNLOAD)
#undef MPM_DOWNLOAD
  }

  void setCpuThreads(int threads) override { this->setExecThreads(threads); }
  size_t particleCount() const override { return count_; }
  void clear() {
#define MPM_CLEAR(type, name) name##_.reset();
    MPM_PARTICLE_FIELDS(MPM_CLEAR)
#undef MPM_CLEAR
    count_ = 0;
    touchReach_ = 0.f;
  }
  size_t activeBlocks() const override { return bins_.gridView().activeCount; }
  size_t memoryBytes() const override {
    size_t b = materials_.bytes() + cutting_.memoryBytes() + bins_.memoryBytes() + shapes_.memoryBytes();
#define MPM_BYTES(type, name) b += name##_.bytes() + name##Saved_.bytes();
    MPM_PARTICLE_FIELDS(MPM_BYTES)
#undef MPM_BYTES
    return b;
  }

 private:
  using Clock = std::chrono::steady_clock;
  static double seconds(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
  }

  ParticleView view() const {
    ParticleView v;
#define MPM_VIEW(type, name) v.name = name##_.data();
    MPM_PARTICLE_FIELDS(MPM_VIEW)
#undef MPM_VIEW
    v.count = (uint32_t)count_;
    return v;
  }

  GridGeometry geo_;
  typename Exec::Binning bins_;
  size_t count_ = 0;
  WallParams walls_;  ///< of the current substep
  bool shapesInReach_ = false;  ///< of the current substep (placeShapes)
  float touchReach_ = 0.f;      ///< the particles' largest touchDistance (append)
  bool centroidsKept_ = false;  ///< the last scatter kept the centroids (MirrorFold)
  bool binned_ = false;         ///< bins_ holds since the sort (KeepsBinning): binParticles keeps it
  bool modelKept_ = false;      ///< saveStateAndSort moved the particles and kept the model fields too
#define MPM_MEMBER(type, name) ExecArray<type, Exec> name##_, name##Saved_;  // the state, its copy (saveStateAndSort)
  MPM_PARTICLE_FIELDS(MPM_MEMBER)
#undef MPM_MEMBER
  ExecArray<MaterialParams, Exec> materials_;
  CuttingStage<Exec> cutting_;  ///< the tools' stage (recordCuts)
};

}  // namespace mpm
