#pragma once
// ParticleGridSystem<Exec>: the substep written once, for any execution backend.
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
#include "solvers/mls_mpm_kernels.h"

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
  }
};

/// P2G of particle p into `nodes` (the global grid or a block tile).
template <bool kCentroid>
struct P2G {
  ParticleView P;
  GridGeometry geo;
  const MaterialParams* materials;
  float dt;
  template <class Nodes>
  MPM_HD void operator()(uint32_t p, Nodes& nodes) const {
    if (geo.stencilInside(P.x[p])) mlsP2G<kCentroid>(p, P, geo, nodes, materials, dt);
  }
};

struct GridUpdate {
  GridView grid;
  float dt;
  Vec3f gravity;
  WallParams walls;
  MPM_HD void operator()(size_t n) const { gridUpdateNode((uint32_t)n, grid, dt, gravity, walls); }
};

/// G2P of particle p from `nodes`, the push-out from shapes, and the per-particle checks.
struct G2P {
  ParticleView P;
  GridGeometry geo;
  float dt;
  const PartView* parts;
  int nParts;
  template <class Nodes>
  MPM_HD StepCheck operator()(uint32_t p, const Nodes& nodes) const {
    StepCheck c;
    // a particle already outside keeps its state; G2P would read nodes that do not exist
    if (!geo.stencilInside(P.x[p]) || !mlsG2P(p, P, geo, nodes, dt)) c.firstBadParticle = p;
    if (nParts) pushOutOfParts(P.x[p], parts, nParts);
    c.maxSpeed2 = dot(P.v[p], P.v[p]);
    return c;
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

struct FinishBodies {
  BodyView* bodies;
  const ContactSums* sums;
  ContactSums* record;  ///< momentum exchanged, summed over the substeps of an advance
  float dt;
  MPM_HD void operator()(size_t i) const {
    finishBodySubstep(bodies[i], sums[i], dt);
    for (int k = 0; k < 3; ++k) {
      record[i].impulse[k] += sums[i].impulse[k];
      record[i].angular[k] += sums[i].angular[k];
    }
  }
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

template <class Exec>
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
    const ParticleView P = view();

    auto t0 = Clock::now();
    exec_.bin(P, bins_);
    const GridView grid = bins_.gridView();
    const size_t nodes = (size_t)grid.activeCount * kBlockNodes;
    exec_.forEach(nodes, kernels::ZeroNodes{grid.nodes});
    timings.sort += seconds(t0);

    t0 = Clock::now();
    // a scene without shapes does not pay for the material centroid contact needs
    if (parts_.size())
      exec_.particleToGrid(bins_, kernels::P2G<true>{P, geo_, materials_.data(), s.dt});
    else
      exec_.particleToGrid(bins_, kernels::P2G<false>{P, geo_, materials_.data(), s.dt});
    timings.p2g += seconds(t0);

    t0 = Clock::now();
    exec_.forEach(nodes, kernels::GridUpdate{grid, s.dt, s.gravity, s.walls});
    timings.gridUpdate += seconds(t0);

    const int nParts = (int)parts_.size(), nBodies = (int)bodies_.size();
    if (nParts) {
      t0 = Clock::now();
      // the contact band of a node reaches one cell beyond the part's own bounds
      exec_.forEach(nParts, kernels::PlaceParts{parts_.data(), bodies_.data(), geo_.dx});
      if (anyDynamic_) {
        exec_.forEach(nBodies, kernels::AccelerateBodies{bodies_.data(), s.dt});
        exec_.contactPass(bins_, parts_.data(), nParts, bodies_.data(), nBodies, stepSums_.data(), 0);
        exec_.forEach(nBodies, kernels::PredictBodies{bodies_.data(), stepSums_.data()});
      }
      exec_.contactPass(bins_, parts_.data(), nParts, bodies_.data(), nBodies, stepSums_.data(), 1);
      exec_.forEach(nBodies, kernels::FinishBodies{bodies_.data(), stepSums_.data(), record_.data(), s.dt});
      timings.contact += seconds(t0);
    }

    t0 = Clock::now();
    exec_.gridToParticle(bins_, kernels::G2P{P, geo_, s.dt, parts_.data(), nParts});
    timings.g2p += seconds(t0);
    timings.substeps += 1;
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
