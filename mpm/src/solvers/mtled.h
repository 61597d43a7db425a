#pragma once
// MTLED: meshless Total Lagrangian explicit dynamics (Horton, Wittek, Joldes & Miller 2010;
// Joldes et al. sections 2-3). The particles are the nodes; stress is evaluated at integration
// points on a regular background grid (one point per cell holding material). The
// displacement is interpolated with moving least squares over the n nearest nodes (linear
// basis, quartic spline weight); each point's derivatives at the reference configuration
// are computed once (mtled_setup.cpp): the MLS derivatives at the point (the paper), or
// their average over the cell's material (MtledSettings::smoothedStrain). Every
// substep, for each integration point: F = I + sum_i u_i (x) grad phi_i over its nodes,
// first Piola stress P = tau F^-T, nodal forces V P grad phi_i; for each node the
// central-difference update with the lumped mass.
// Boundary conditions come from the shapes: a node in a shape's contact band gets the
// contact velocity of the grid contact (bonded: the shape's velocity, frictional: its
// normal velocity while pressed on), and the momentum that takes is the shape's impulse.
//
// No MPM grid and no domain walls. The kernels are MPM_HD functors run through Exec's
// forEach; forces are gathered per node from a precomputed incidence list (no atomics,
// the same order on every backend).
#include <algorithm>
#include <chrono>
#include <functional>
#include <vector>

#include "system/exec_array.h"
#include "system/shape_set.h"
#include "system/sim_backend.h"
#include "core/constitutive.h"
#include "transfer/particle_check.h"

namespace mpm {

/// MTLED's arrays in Exec memory, F(role, type, name) for member name_: the nodes' motion
/// (state, with saveStateAndSort()'s copy), the model prepare() builds from the nodes' reference
/// positions, the integration cells and the materials (rebuilt, not stored, by
/// checkpoints: BackendState), and scratch each substep rewrites.
#define MPM_MTLED_ARRAYS(F)                                                                   \
  F(State, Vec3f, x) F(State, Vec3f, v) F(State, Vec3f, xSaved) F(State, Vec3f, vSaved)       \
  F(Model, Vec3f, X) F(Model, float, mass) F(Model, float, volumes) F(Model, uint32_t, carrier) \
  F(Model, uint32_t, termStart) F(Model, uint32_t, support) F(Model, uint32_t, pointObject)   \
  F(Model, uint32_t, forceStart) F(Model, uint32_t, forceTerms) F(Model, Vec3f, gradients)    \
  F(Model, MaterialParams, materials)                                                         \
  F(Scratch, Vec3f, forces) F(Scratch, ContactSums, nodeSums)

/// The static model MTLED precomputes from the nodes and integration cells (host side).
struct MtledModel {
  int supportNodes = 0;                ///< n
  /// Point p's terms are [termStart[p], termStart[p + 1]): the nodes its strain depends on
  /// (its n nearest, or with smoothed strain those of its cell's surface points).
  std::vector<uint32_t> termStart;
  std::vector<uint32_t> support;       ///< [term]: node index
  std::vector<Vec3f> shapeGradients;   ///< [term]: d phi / d X of that node at the point [1/m]
  std::vector<float> volumes;          ///< per point [m^3]
  std::vector<uint32_t> pointObject;   ///< per point: object slot (its material)
  std::vector<float> nodeMass;         ///< lumped: each point's mass split evenly over its n nearest nodes [kg]
  std::vector<float> nodeVolume;       ///< likewise, the volume [m^3]
  /// Per node: itself, or for a node dropped for lying in fewer than two support domains
  /// the nearest kept node, whose displacement it follows.
  std::vector<uint32_t> carrier;
  /// Incidence list: node i's force terms are forceTerms[forceStart[i] .. forceStart[i+1]),
  /// each a term index.
  std::vector<uint32_t> forceStart, forceTerms;
  float criticalTimeStep = 0;  ///< eq. 37 over all points [s]
  size_t droppedNodes = 0;
};

/// Builds the model (Joldes et al., section 2.1, preprocessing steps 3-4, and section 3.3):
/// n nearest nodes (support domains) and shape-function derivatives per point, lumped
/// masses, removal of nodes in fewer than two support domains (repeated until none is
/// left), the critical step. Throws Error if a moment matrix is singular.
MtledModel buildMtledModel(const MtledSettings& settings, const std::vector<Vec3f>& X,
                           const std::vector<uint32_t>& nodeObject, const IntegrationCells& cells,
                           const std::vector<uint32_t>& pointObject, const std::vector<MaterialParams>& materials);

/// Deformation gradient at each node, for the nodes at x (X in the reference): the
/// volume-weighted mean of the F of the integration points whose strain depends on the node
/// (those whose terms name it: the points around it), each F as the internal-force kernel
/// forms it. A dropped node takes its carrier's. `perPoint(p, F_p)`, if given, sees each
/// point's F on the way (the step check holds the points' volume ratio with the nodes').
std::vector<Mat3f> nodeDeformationGradients(const MtledModel& model, const std::vector<Vec3f>& x,
                                            const std::vector<Vec3f>& X,
                                            const std::function<void(size_t, const Mat3f&)>& perPoint = {});

/// Integration cells over the box [lo, hi] (cells of about `cellSize`, fitted to the box),
/// from 4^3 voxels per cell each inside or not per `inside` at its centre: each cell that
/// holds material gives one point, at the centroid of its inside voxels, with their volume
/// (cells cut by a curved surface keep the volume they hold instead of all or nothing),
/// and the surface of those voxels as quadrature points.
IntegrationCells integrationCells(const std::function<bool(Vec3f)>& inside, Vec3f lo, Vec3f hi,
                                  float cellSize);

namespace kernels {

/// F = I + sum (x - X) grad phi over point p's terms (nodes now at x, at X in the reference).
MPM_HD Mat3f pointDeformationGradient(size_t p, const Vec3f* x, const Vec3f* X, const uint32_t* termStart,
                                      const uint32_t* support, const Vec3f* gradients) {
  Mat3f F = Mat3f::identity();
  for (uint32_t t = termStart[p]; t < termStart[p + 1]; ++t) F = F + outer(x[support[t]] - X[support[t]], gradients[t]);
  return F;
}

/// Per integration point: deformation gradient from the nodal displacements, stress, and
/// the internal force V P grad phi on each of its terms' nodes.
struct MtledInternalForce {
  const Vec3f* x;
  const Vec3f* X;
  const uint32_t* termStart;
  const uint32_t* support;
  const Vec3f* gradients;
  const float* volumes;
  const uint32_t* pointObject;
  const MaterialParams* materials;
  Vec3f* forces;
  MPM_HD void operator()(size_t p) const {
    const Mat3f F = pointDeformationGradient(p, x, X, termStart, support, gradients);
    const Mat3f tau = kirchhoffStress(materials[pointObject[p]], F);
    const Mat3f P = tau * transpose(inverse(F));  // first Piola-Kirchhoff
    for (uint32_t t = termStart[p]; t < termStart[p + 1]; ++t) forces[t] = volumes[p] * (P * gradients[t]);
  }
};

/// Per node: velocity at t + dt/2 from the internal forces and gravity (central difference).
struct MtledAccelerate {
  Vec3f* v;
  const float* mass;
  const uint32_t* carrier;
  const uint32_t* forceStart;
  const uint32_t* forceTerms;
  const Vec3f* forces;
  Vec3f gravity;
  float dt;
  MPM_HD void operator()(size_t i) const {
    if (carrier[i] != i) return;
    Vec3f f{0.f, 0.f, 0.f};
    for (uint32_t t = forceStart[i]; t < forceStart[i + 1]; ++t) f += forces[forceTerms[t]];
    v[i] += dt * (gravity - (1.f / mass[i]) * f);
  }
};

/// Per node: contact with every part (the grid contact law of contact/contact_law.h, the node's
/// own position standing for its material), the momentum exchanged kept per node and body.
struct MtledContact {
  const Vec3f* x;
  Vec3f* v;
  const float* mass;
  const uint32_t* carrier;
  const PartView* parts;
  int nParts;
  const BodyView* bodies;
  int nBodies;
  ContactSums* nodeSums;  ///< [node * nBodies + body]
  int pass;
  MPM_HD void operator()(size_t i) const {
    ContactSums* sums = nodeSums + i * nBodies;
    for (int b = 0; b < nBodies; ++b) sums[b] = ContactSums{};
    if (carrier[i] != i) return;
    for (int p = 0; p < nParts; ++p) {
      if (!parts[p].mayTouch(x[i], x[i])) continue;
      contactNodePart(x[i], mass[i], v[i], x[i], 0.f, parts, nParts, p, bodies, sums[parts[p].body], pass);
    }
  }
};

/// Per body: the sum of its nodes' exchanges, in node order (the same on every backend).
struct MtledSumContacts {
  const ContactSums* nodeSums;
  size_t nNodes;
  int nBodies;
  ContactSums* out;
  MPM_HD void operator()(size_t b) const {
    ContactSums s{};
    for (size_t i = 0; i < nNodes; ++i) {
      const float* src = &nodeSums[i * nBodies + b].impulse[0];
      float* dst = &s.impulse[0];
      for (int k = 0; k < kContactSumFloats; ++k) dst[k] += src[k];
    }
    out[b] = s;
  }
};

/// Per node: x(t + dt) = x(t) + dt v(t + dt/2).
struct MtledMove {
  Vec3f* x;
  const Vec3f* v;
  const uint32_t* carrier;
  float dt;
  MPM_HD void operator()(size_t i) const {
    if (carrier[i] == i) x[i] += dt * v[i];
  }
};

/// Per dropped node: the displacement and velocity of its carrier.
struct MtledFollow {
  Vec3f* x;
  Vec3f* v;
  const Vec3f* X;
  const uint32_t* carrier;
  MPM_HD void operator()(size_t i) const {
    const uint32_t c = carrier[i];
    if (c == i) return;
    x[i] = X[i] + (x[c] - X[c]);
    v[i] = v[c];
  }
};

}  // namespace kernels

template <class Exec>
class MtledSystem final : private ExecOwner<Exec>, public ShapeBackend<Exec> {
  using ExecOwner<Exec>::exec_;
  using ShapeBackend<Exec>::shapes_;
  using ShapeBackend<Exec>::timings;

 public:
  template <class... Args>
  explicit MtledSystem(const MtledSettings& settings, Args&&... execArgs)
      : ExecOwner<Exec>(std::forward<Args>(execArgs)...), ShapeBackend<Exec>(this->exec_), settings_(settings) {
#define MPM_BIND(role, type, name) name##_.bind(&exec_);
    MPM_MTLED_ARRAYS(MPM_BIND)
#undef MPM_BIND
  }

  /// Objects never share a support domain: the new object's model alone tells whether
  /// the whole can be built. Its build is repeated by the next prepare() (a second build of
  /// that object, paid once when it is added).
  void checkObject(uint32_t slot, const HostParticles& add, const IntegrationCells& cells,
                   const std::vector<MaterialParams>& materials) const override {
    buildMtledModel(settings_, add.x, add.object, cells, std::vector<uint32_t>(cells.size(), slot), materials);
  }

  void append(const HostParticles& add) override {
    syncToHost();
#define MPM_APPEND(type, name) nodes_.name.insert(nodes_.name.end(), add.name.begin(), add.name.end());
    MPM_PARTICLE_FIELDS(MPM_APPEND)
#undef MPM_APPEND
    reference_.insert(reference_.end(), add.x.begin(), add.x.end());  // X: the configuration at creation
    dirty_ = true;
  }

  void appendIntegrationCells(uint32_t slot, const IntegrationCells& cells) override {
    for (size_t p = 0; p < cells.size(); ++p) cells_.appendCell(cells, p);
    pointSlot_.insert(pointSlot_.end(), cells.size(), slot);
    dirty_ = true;
  }

  void removeObjects(const std::vector<uint8_t>& keep) override {
    syncToHost();
    HostParticles kept;
    std::vector<Vec3f> keptX;
    for (size_t i = 0; i < nodes_.size(); ++i) {
      if (!keep[nodes_.object[i]]) continue;
#define MPM_KEEP(type, name) kept.name.push_back(nodes_.name[i]);
      MPM_PARTICLE_FIELDS(MPM_KEEP)
#undef MPM_KEEP
      keptX.push_back(reference_[i]);
    }
    nodes_ = std::move(kept);
    reference_ = std::move(keptX);
    IntegrationCells keptCells;
    std::vector<uint32_t> keptObject;
    for (size_t p = 0; p < cells_.size(); ++p) {
      if (!keep[pointSlot_[p]]) continue;
      keptCells.appendCell(cells_, p);
      keptObject.push_back(pointSlot_[p]);
    }
    cells_ = std::move(keptCells);
    pointSlot_ = std::move(keptObject);
    dirty_ = true;
  }

  void exportState(BackendState& out) const override {
    download(out.particles);
    out.reference = reference_;
    out.cells = cells_;
    out.cellSlot = pointSlot_;
  }
  void importState(const BackendState& in) override {
    nodes_ = in.particles;
    reference_ = in.reference;
    cells_ = in.cells;
    pointSlot_ = in.cellSlot;
    onDevice_ = false;
    dirty_ = true;  // the model is rebuilt from the same reference, cells and materials
  }

  void setMaterials(const std::vector<MaterialParams>& m) override {
    syncToHost();
    materialTable_ = m;
    materials_.resizeDiscard(m.size());
    exec_.copyToDevice(materials_.data(), m.data(), m.size() * sizeof(MaterialParams));
    dirty_ = true;  // the critical step depends on the wave speeds
  }

  /// The nodes' motion, on the device (the model is built first, so there is motion to
  /// copy); nothing to sort: the nodes' order is the model's.
  void saveStateAndSort() override {
    prepare();
    copy(xSaved_, x_);
    copy(vSaved_, v_);
  }
  void restoreState() override {
    copy(x_, xSaved_);
    copy(v_, vSaved_);
  }

  float stableTimeStep() override {
    prepare();
    return settings_.timeStepSafety * model_.criticalTimeStep;
  }

  /// The model's critical step (eq. 37) and the nodes it dropped, for reports and tests.
  const MtledModel& model() {
    prepare();
    return model_;
  }

  void substep(const SubstepParams& s) override {
    prepare();
    const size_t nNodes = nodes_.size(), nPoints = cells_.size();
    if (nNodes == 0) return;
    auto t0 = Clock::now();
    shapes_.place(0.f);  // nodes are tested at their own positions: no cell margin
    timings.contact += seconds(t0);

    t0 = Clock::now();
    exec_.forEach(nPoints, kernels::MtledInternalForce{x_.data(), X_.data(), termStart_.data(), support_.data(),
                                                        gradients_.data(), volumes_.data(), pointObject_.data(),
                                                        materials_.data(), forces_.data()});
    timings.p2g += seconds(t0);
    t0 = Clock::now();
    exec_.forEach(nNodes, kernels::MtledAccelerate{v_.data(), mass_.data(), carrier_.data(), forceStart_.data(),
                                                    forceTerms_.data(), forces_.data(), s.gravity, s.dt});
    timings.gridUpdate += seconds(t0);

    t0 = Clock::now();
    if (shapes_.partCount() > 0) shapes_.exchange(s.dt, s.dt, [&](int pass) { contactPass(pass); });
    shapes_.move(s.dt);
    timings.contact += seconds(t0);

    t0 = Clock::now();
    exec_.forEach(nNodes, kernels::MtledMove{x_.data(), v_.data(), carrier_.data(), s.dt});
    if (model_.droppedNodes > 0)
      exec_.forEach(nNodes, kernels::MtledFollow{x_.data(), v_.data(), X_.data(), carrier_.data()});
    timings.g2p += seconds(t0);
    timings.substeps += 1;
  }

  /// Read once per advance: the nodes' state is checked where it is, on the host copy.
  StepCheck takeCheck() override {
    StepCheck c;
    if (nodes_.size() == 0 || dirty_) return c;
    std::vector<Vec3f> x(nodes_.size()), v(nodes_.size());
    exec_.copyToHost(x.data(), x_.data(), x.size() * sizeof(Vec3f));
    exec_.copyToHost(v.data(), v_.data(), v.size() * sizeof(Vec3f));
    for (size_t i = 0; i < x.size(); ++i) {
      const bool finite = isFinite(x[i].x) && isFinite(x[i].y) && isFinite(x[i].z) && isFinite(v[i].x) &&
                          isFinite(v[i].y) && isFinite(v[i].z);
      if (!finite) {
        if (c.firstBadParticle == 0xffffffffu) c.firstBadParticle = (uint32_t)i;
        continue;
      }
      c.maxSpeed2 = std::max(c.maxSpeed2, dot(v[i], v[i]));
    }
    c.peakSpeed2 = c.maxSpeed2;
    // the volume ratio where F lives, at the integration points (a point out of bounds
    // flags the first node its strain depends on), and at the nodes as readDeformationGradients
    // gives it, their points' mean: points each sound but turned against each other can
    // average to an inverted node (SceneSettings.divergenceCheck)
    if (c.firstBadParticle != 0xffffffffu) return c;
    uint32_t badPoint = 0xffffffffu;
    const std::vector<Mat3f> nodeF = nodeDeformationGradients(model_, x, reference_, [&](size_t p, const Mat3f& F) {
      if (badPoint == 0xffffffffu && !volumeRatioSound(&F.m[0][0])) badPoint = (uint32_t)p;
    });
    if (badPoint != 0xffffffffu) {
      c.firstBadParticle = model_.support[model_.termStart[badPoint]];
      return c;
    }
    for (size_t i = 0; i < nodeF.size(); ++i)
      if (!volumeRatioSound(&nodeF[i].m[0][0])) {
        c.firstBadParticle = (uint32_t)i;
        break;
      }
    return c;
  }


  /// The nodes, with F at each node from the integration points around it
  /// (nodeDeformationGradients).
  void download(HostParticles& out) const override {
    out = nodes_;
    if (onDevice_) downloadMotion(out);
  }

  /// sum over points V_p W(F_p), F_p from the nodes' displacements as the internal force
  /// kernel forms it: the energy whose gradient the forces are (energy balance, section 4.7).
  double integrationPointEnergy(const HostParticles& state) const override {
    if (dirty_) return 0.0;  // no model to measure with (never in a step: saveStateAndSort() builds it)
    double energy = 0;
    for (size_t p = 0; p < model_.volumes.size(); ++p) {
      const Mat3f F = kernels::pointDeformationGradient(p, state.x.data(), reference_.data(), model_.termStart.data(),
                                                        model_.support.data(), model_.shapeGradients.data());
      energy += (double)model_.volumes[p] * strainEnergyDensity(materialTable_[model_.pointObject[p]], F);
    }
    return energy;
  }

  void setCpuThreads(int threads) override { this->setExecThreads(threads); }
  size_t particleCount() const override { return nodes_.size(); }
  size_t activeBlocks() const override { return 0; }  // no grid
  size_t memoryBytes() const override {
    size_t b = shapes_.memoryBytes();
#define MPM_BYTES(role, type, name) b += name##_.bytes();
    MPM_MTLED_ARRAYS(MPM_BYTES)
#undef MPM_BYTES
    return b;
  }

 private:
  using Clock = std::chrono::steady_clock;
  static double seconds(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
  }

  template <class T>
  void upload(ExecArray<T, Exec>& a, const std::vector<T>& host) {
    a.resizeDiscard(host.size());
    exec_.copyToDevice(a.data(), host.data(), host.size() * sizeof(T));
  }

  template <class T>
  void copy(ExecArray<T, Exec>& to, const ExecArray<T, Exec>& from) {
    to.resizeDiscard(from.size());
    exec_.copyOnDevice(to.data(), from.data(), from.size() * sizeof(T));
  }

  /// The device's x, v into `out` (sized as nodes_), and F at the nodes from the model.
  void downloadMotion(HostParticles& out) const {
    exec_.copyToHost(out.x.data(), x_.data(), out.x.size() * sizeof(Vec3f));
    exec_.copyToHost(out.v.data(), v_.data(), out.v.size() * sizeof(Vec3f));
    out.F = nodeDeformationGradients(model_, out.x, reference_);
  }

  /// Brings the host copy of the nodes' motion up to date before the nodes, cells or
  /// materials change (the model is rebuilt from it), while the model still matches it.
  void syncToHost() {
    if (!onDevice_) return;
    downloadMotion(nodes_);
    onDevice_ = false;
  }

  /// Builds the model and uploads it, once after the nodes, cells or materials changed.
  void prepare() {
    if (!dirty_) return;
    const auto t0 = Clock::now();
    model_ = buildMtledModel(settings_, reference_, nodes_.object, cells_, pointSlot_, materialTable_);
    // the lumped masses replace the lattice's, so summaries report the mass MTLED moves
    nodes_.mass = model_.nodeMass;
    nodes_.volume0 = model_.nodeVolume;
    upload(x_, nodes_.x);
    upload(v_, nodes_.v);
    upload(X_, reference_);
    upload(mass_, model_.nodeMass);
    upload(carrier_, model_.carrier);
    upload(termStart_, model_.termStart);
    upload(support_, model_.support);
    upload(gradients_, model_.shapeGradients);
    upload(volumes_, model_.volumes);
    upload(pointObject_, model_.pointObject);
    upload(forceStart_, model_.forceStart);
    upload(forceTerms_, model_.forceTerms);
    forces_.resizeDiscard(model_.support.size());
    dirty_ = false;
    onDevice_ = true;
    timings.sort += seconds(t0);
  }

  void contactPass(int pass) {
    const size_t nNodes = nodes_.size();
    const int nBodies = shapes_.bodyCount();
    nodeSums_.reserveDiscard(nNodes * nBodies);
    exec_.forEach(nNodes, kernels::MtledContact{x_.data(), v_.data(), mass_.data(), carrier_.data(), shapes_.parts(),
                                                 shapes_.partCount(), shapes_.bodies(), nBodies, nodeSums_.data(),
                                                 pass});
    exec_.forEach(nBodies, kernels::MtledSumContacts{nodeSums_.data(), nNodes, nBodies, shapes_.stepSums()});
  }

  MtledSettings settings_;
  // host side: the nodes as added (motion current while !onDevice_), reference
  // positions, integration cells, materials; the model built from them
  HostParticles nodes_;
  std::vector<Vec3f> reference_;
  IntegrationCells cells_;
  std::vector<uint32_t> pointSlot_;
  std::vector<MaterialParams> materialTable_;
  MtledModel model_;
  bool dirty_ = false;     ///< the model no longer matches the nodes, cells or materials
  bool onDevice_ = false;  ///< the nodes' motion is newer on the device than in nodes_
  // Exec side: the arrays the kernels read and write (MPM_MTLED_ARRAYS)
#define MPM_MEMBER(role, type, name) ExecArray<type, Exec> name##_;
  MPM_MTLED_ARRAYS(MPM_MEMBER)
#undef MPM_MEMBER
};

}  // namespace mpm
