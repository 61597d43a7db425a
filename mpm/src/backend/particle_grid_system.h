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
#include <chrono>
#include <cstring>
#include <utility>

#include "backend/sim_backend.h"
#include "solvers/transfer.h"

namespace mpm {

/// Array in an Exec's memory space, owned.
template <class T, class Exec>
class ExecArray {
 public:
  ExecArray() = default;
  ExecArray(const ExecArray&) = delete;
  ExecArray& operator=(const ExecArray&) = delete;
  ~ExecArray() { reset(); }
  void bind(Exec* exec) { exec_ = exec; }
  /// Resizes to exactly n elements; contents are not kept.
  void resizeDiscard(size_t n) {
    if (n == size_) return;
    reset();
    if (n) data_ = exec_->template allocate<T>(n);
    size_ = n;
  }
  /// Grows to at least n elements (never shrinks); contents are not kept.
  void reserveDiscard(size_t n) {
    if (n > size_) resizeDiscard(n);
  }
  void reset() {
    if (data_) exec_->release(data_);
    data_ = nullptr;
    size_ = 0;
  }
  void swap(ExecArray& o) {
    std::swap(data_, o.data_);
    std::swap(size_, o.size_);
  }
  T* data() const { return data_; }
  size_t size() const { return size_; }
  size_t bytes() const { return size_ * sizeof(T); }

 private:
  Exec* exec_ = nullptr;
  T* data_ = nullptr;
  size_t size_ = 0;
};

namespace kernels {

struct ZeroNodes {
  GridNode* nodes;
  MPM_HD void operator()(size_t n) const {
    nodes[n].mass = 0.f;
    nodes[n].mv = Vec3f{0.f, 0.f, 0.f};
    nodes[n].mx = Vec3f{0.f, 0.f, 0.f};
    nodes[n].dmv = Vec3f{0.f, 0.f, 0.f};
  }
};

struct PlaceParts {
  PartView* parts;
  const BodyView* bodies;
  float margin;
  MPM_HD void operator()(size_t i) const { placePart(parts[i], bodies[parts[i].body], margin); }
};

struct AccelerateBodies {
  BodyView* bodies;
  float dt;
  MPM_HD void operator()(size_t i) const { accelerateBody(bodies[i], dt); }
};

struct PredictBodies {
  BodyView* bodies;
  const ContactSums* sums;
  MPM_HD void operator()(size_t i) const { predictBodyVelocity(bodies[i], sums[i]); }
};

struct SettleBodies {
  BodyView* bodies;
  const ContactSums* sums;
  ContactSums* record;  ///< momentum exchanged, summed over the substeps of an advance
  MPM_HD void operator()(size_t i) const {
    settleBodyVelocity(bodies[i], sums[i]);
    for (int k = 0; k < 3; ++k) {
      record[i].impulse[k] += sums[i].impulse[k];
      record[i].angular[k] += sums[i].angular[k];
    }
  }
};

struct MoveBodies {
  BodyView* bodies;
  float dt;
  MPM_HD void operator()(size_t i) const { moveBody(bodies[i], dt); }
};

/// out[i] = in[order[i]]: applies a sort permutation to one field.
template <class T>
struct Gather {
  T* out;
  const T* in;
  const uint32_t* order;
  MPM_HD void operator()(size_t i) const { out[i] = in[order[i]]; }
};

}  // namespace kernels

template <class Exec, class Method>
class ParticleGridSystem final : public SimBackend {
 public:
  template <class... Args>
  ParticleGridSystem(const GridGeometry& geo, Args&&... execArgs)
      : exec_(std::forward<Args>(execArgs)...), geo_(geo), bins_(exec_, geo) {
#define MPM_BIND(type, name) name##_.bind(&exec_);
    MPM_PARTICLE_FIELDS(MPM_BIND)
#undef MPM_BIND
    scratch_.bind(&exec_);
    materials_.bind(&exec_);
    bodies_.bind(&exec_);
    parts_.bind(&exec_);
    stepSums_.bind(&exec_);
    record_.bind(&exec_);
  }

  void append(const HostParticles& add) override {
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
#define MPM_CLEAR(type, name) name##_.reset();
    MPM_PARTICLE_FIELDS(MPM_CLEAR)
#undef MPM_CLEAR
    count_ = 0;
    append(kept);
  }

  void setMaterials(const std::vector<MaterialParams>& m) override {
    materials_.resizeDiscard(m.size());
    exec_.copyToDevice(materials_.data(), m.data(), m.size() * sizeof(MaterialParams));
  }

  void sortParticles() override {
    if (count_ == 0) return;
    auto t0 = Clock::now();
    exec_.bin(view(), bins_);
    // one scratch buffer of the widest field serves every field in turn
    scratch_.resizeDiscard(count_ * sizeof(Mat3f));
#define MPM_PERMUTE(type, name)                                                          \
  {                                                                                      \
    type* tmp = reinterpret_cast<type*>(scratch_.data());                                \
    exec_.forEach(count_, kernels::Gather<type>{tmp, name##_.data(), bins_.order()});   \
    exec_.copyOnDevice(name##_.data(), tmp, count_ * sizeof(type));                     \
  }
    MPM_PARTICLE_FIELDS(MPM_PERMUTE)
#undef MPM_PERMUTE
    timings.sort += seconds(t0);
  }

  void substep(const SubstepParams& s) override {
    if (count_ == 0) return;
    Method::substep(*this, s);
    timings.substeps += 1;
  }

  // ---- the stages a Method composes its substep from ----------------------------------

  ParticleView particles() const { return view(); }
  const GridGeometry& geometry() const { return geo_; }
  const MaterialParams* materials() const { return materials_.data(); }
  GridView grid() const { return bins_.gridView(); }
  bool hasShapes() const { return parts_.size() > 0; }
  const PartView* parts() const { return parts_.data(); }
  int partCount() const { return (int)parts_.size(); }

  /// Bins the particles by grid block and activates the blocks they reach.
  void binParticles() {
    const auto t0 = Clock::now();
    exec_.bin(view(), bins_);
    timings.sort += seconds(t0);
  }
  /// Zeroes every node of the active blocks.
  void clearGrid() {
    const auto t0 = Clock::now();
    const GridView g = grid();
    exec_.forEach((size_t)g.activeCount * kBlockNodes, kernels::ZeroNodes{g.nodes});
    timings.sort += seconds(t0);
  }
  /// P2G: `k(p, nodes)` for every particle, nodes accumulating.
  template <class K>
  void scatter(const K& k) {
    const auto t0 = Clock::now();
    exec_.particleToGrid(bins_, k);
    timings.p2g += seconds(t0);
  }
  /// `k(n)` for every node of the active blocks.
  template <class K>
  void updateGrid(const K& k) {
    const auto t0 = Clock::now();
    exec_.forEach((size_t)grid().activeCount * kBlockNodes, k);
    timings.gridUpdate += seconds(t0);
  }
  /// Places the shapes' parts at their bodies' poses (once per substep).
  void placeShapes() {
    if (parts_.size() == 0) return;
    const auto t0 = Clock::now();
    // the contact band of a node reaches one cell beyond the part's own bounds
    exec_.forEach(parts_.size(), kernels::PlaceParts{parts_.data(), bodies_.data(), geo_.dx});
    timings.contact += seconds(t0);
  }
  /// Grid contact with the shapes (DESIGN 5) and the momentum exchange with dynamic
  /// bodies: gravity for the substep (if `bodyGravity`), the predicted body velocity, the
  /// projection of the nodes, then the bodies' velocities from what they received.
  void exchangeContact(float dt, bool bodyGravity) {
    const int nParts = (int)parts_.size(), nBodies = (int)bodies_.size();
    if (nParts == 0) return;
    const auto t0 = Clock::now();
    if (anyDynamic_) {
      if (bodyGravity) exec_.forEach(nBodies, kernels::AccelerateBodies{bodies_.data(), dt});
      exec_.contactPass(bins_, parts_.data(), nParts, bodies_.data(), nBodies, stepSums_.data(), 0);
      exec_.forEach(nBodies, kernels::PredictBodies{bodies_.data(), stepSums_.data()});
    }
    exec_.contactPass(bins_, parts_.data(), nParts, bodies_.data(), nBodies, stepSums_.data(), 1);
    exec_.forEach(nBodies, kernels::SettleBodies{bodies_.data(), stepSums_.data(), record_.data()});
    timings.contact += seconds(t0);
  }
  /// Advances the bodies' poses over the substep.
  void moveShapes(float dt) {
    if (bodies_.size() == 0) return;
    exec_.forEach(bodies_.size(), kernels::MoveBodies{bodies_.data(), dt});
  }
  /// G2P: `k(p, nodes)` for every particle, returning its StepCheck.
  template <class K>
  void gather(const K& k) {
    const auto t0 = Clock::now();
    exec_.gridToParticle(bins_, k);
    timings.g2p += seconds(t0);
  }

  StepCheck takeCheck() override { return exec_.takeCheck(); }

  void setShapes(const std::vector<BodyView>& bodies, const std::vector<PartView>& parts) override {
    bodies_.resizeDiscard(bodies.size());
    exec_.copyToDevice(bodies_.data(), bodies.data(), bodies.size() * sizeof(BodyView));
    parts_.resizeDiscard(parts.size());
    exec_.copyToDevice(parts_.data(), parts.data(), parts.size() * sizeof(PartView));
    stepSums_.resizeDiscard(bodies.size());
    // the impulse record restarts with the new shape list
    std::vector<ContactSums> zero(bodies.size(), ContactSums{});
    record_.resizeDiscard(bodies.size());
    exec_.copyToDevice(record_.data(), zero.data(), zero.size() * sizeof(ContactSums));
    anyDynamic_ = false;
    for (const BodyView& b : bodies) anyDynamic_ = anyDynamic_ || b.dynamic;
  }

  const float* meshValues(const std::vector<float>& values) override {
    auto& slot = meshes_[&values];
    if (!slot) {
      slot = std::make_unique<ExecArray<float, Exec>>();
      slot->bind(&exec_);
      slot->resizeDiscard(values.size());
      exec_.copyToDevice(slot->data(), values.data(), values.size() * sizeof(float));
    }
    return slot->data();
  }

  void releaseMeshesExcept(const std::vector<const std::vector<float>*>& live) override {
    for (auto it = meshes_.begin(); it != meshes_.end();) {
      bool keep = false;
      for (const auto* l : live) keep = keep || l == it->first;
      it = keep ? std::next(it) : meshes_.erase(it);
    }
  }

  void readBodies(std::vector<BodyView>& out) const override {
    out.resize(bodies_.size());
    exec_.copyToHost(out.data(), bodies_.data(), out.size() * sizeof(BodyView));
  }

  std::vector<ContactSums> takeImpulses() override {
    std::vector<ContactSums> out(record_.size()), zero(record_.size(), ContactSums{});
    exec_.copyToHost(out.data(), record_.data(), out.size() * sizeof(ContactSums));
    exec_.copyToDevice(record_.data(), zero.data(), zero.size() * sizeof(ContactSums));
    return out;
  }

  void download(HostParticles& out) const override {
#define MPM_DOWNLOAD(type, name) \
  out.name.resize(count_);       \
  exec_.copyToHost(out.name.data(), name##_.data(), count_ * sizeof(type));
    MPM_PARTICLE_FIELDS(MPM_DOWNLOAD)
#undef MPM_DOWNLOAD
  }

  size_t particleCount() const override { return count_; }
  size_t activeBlocks() const override { return bins_.gridView().activeCount; }
  size_t memoryBytes() const override {
    size_t b = scratch_.bytes() + materials_.bytes() + bins_.memoryBytes() + bodies_.bytes() +
               parts_.bytes() + stepSums_.bytes() + record_.bytes();
    for (const auto& m : meshes_) b += m.second->bytes();
#define MPM_BYTES(type, name) b += name##_.bytes();
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

  mutable Exec exec_;
  GridGeometry geo_;
  typename Exec::Binning bins_;
  size_t count_ = 0;
#define MPM_MEMBER(type, name) ExecArray<type, Exec> name##_;
  MPM_PARTICLE_FIELDS(MPM_MEMBER)
#undef MPM_MEMBER
  ExecArray<uint8_t, Exec> scratch_;
  ExecArray<MaterialParams, Exec> materials_;
  ExecArray<BodyView, Exec> bodies_;
  ExecArray<PartView, Exec> parts_;
  ExecArray<ContactSums, Exec> stepSums_, record_;
  bool anyDynamic_ = false;
  std::map<const std::vector<float>*, std::unique_ptr<ExecArray<float, Exec>>> meshes_;
};

}  // namespace mpm
