// Scene: the public calls, tied together by SceneImpl. Each concern has its own file under
// scene/: the handle tables (slot_table.h), particle seeding, the substep policy, the
// energy account, the shapes' exchange with the backend and the step worker. The particle
// and grid work is the backend's.
#include "mpm/scene.h"

#include <algorithm>
#include <cmath>
#include <tuple>
#include <utility>

#include "backend/sim_backend.h"
#include "core/per_process.h"
#include "core/validate.h"
#include "scene/divergence.h"
#include "scene/energy_account.h"
#include "scene/particle_seeding.h"
#include "scene/shape_exchange.h"
#include "scene/slot_table.h"
#include "scene/step_worker.h"
#include "scene/substep_policy.h"
#include "shapes/shape_builder.h"
#include "solvers/cut_transfer.h"
#include "solvers/solver_list.h"
#include "state/scene_checkpoint.h"

namespace mpm {

namespace {

GridGeometry gridGeometry(const SceneSettings& s) {
  GridGeometry g;
  g.lower = s.domain.lower;
  g.dx = s.dx;
  g.invDx = 1.f / s.dx;
  for (int a = 0; a < 3; ++a) {
    // the grid covers the domain with whole cells (it may reach slightly past `upper`)
    g.cells[a] = (int)std::ceil((s.domain.upper[a] - s.domain.lower[a]) / s.dx - 1e-4f);
    g.blocks[a] = (g.cells[a] + 1 + kBlockSize - 1) / kBlockSize;
  }
  return g;
}

}  // namespace

class SceneImpl {
 public:
  explicit SceneImpl(const SceneSettings& s) : settings(s) {
    validate::sceneSettings(s);
    geo = gridGeometry(s);
    const bool haveCuda = cudaDeviceAvailable();
    if (s.backend == Backend::Cuda && !haveCuda)
      throw BackendUnavailable(
          "SceneSettings.backend = Cuda: no usable CUDA device in this process"
#ifndef MPM_WITH_CUDA
          " (the library was built without the CUDA backend)"
#endif
          "; use Backend::Cpu or Backend::Auto");
    if (s.backend == Backend::Cuda || (s.backend == Backend::Auto && haveCuda)) {
      backend = makeCudaBackend(s, geo);
      resolved = Backend::Cuda;
    } else {
      backend = makeCpuBackend(s, geo);
      resolved = Backend::Cpu;
    }
  }

  ~SceneImpl() {
    if (!stepping || worker.inherited()) return;
    try {
      worker.get().wait();
    } catch (...) {  // an error nobody fetched: the scene goes anyway
    }
  }

  void requireIdle(const char* call) const {
    if (stepping)
      throw Error(std::string(call) + ": a step is running; call fetchResults() first");
  }

  /// The record `id` names in `table` (shapes, slicers), between steps.
  template <class Table, class Id>
  auto& idleRecord(Table& table, Id id, const char* call) {
    requireIdle(call);
    return table.lookup(id, call);
  }
  /// Sets a shape's or slicer's pose and velocities (validated) before an advance.
  template <class Table, class Id>
  void setMotion(Table& table, Id id, const ShapeState& s, const char* call) {
    auto& r = idleRecord(table, id, call);
    validateShapeState(s);
    checkSpeed("ShapeState", r, s, settings);
    r.state = s;
  }

  ParticleObjectId add(const ParticleObjectDesc& d) {
    requireIdle("addParticleObject");
    const SeededObject o = seedParticleObject(d, objects, settings, geo, *backend);
    const ParticleObjectId id = objects.add(o.record);
    maxParticleSpeed = std::max(maxParticleSpeed, o.record.maxInitialSpeed);
    uploadMaterials();
    account.started = false;  // the energy account starts again with the new object
    backend->append(o.particles);
    if (solverTraits(settings.solver).meshless) backend->appendIntegrationCells(id.index, o.cells);
    return id;
  }

  void remove(ParticleObjectId id) {
    requireIdle("removeParticleObject");
    objects.lookup(id, "removeParticleObject");
    std::vector<uint8_t> keep(objects.size());
    for (size_t i = 0; i < objects.size(); ++i) keep[i] = objects.alive(i) && i != id.index;
    backend->removeObjects(keep);
    account.started = false;
    objects.remove(id);
  }

  void uploadMaterials() { backend->setMaterials(materialTable(objects)); }

  SubstepBounds substepBounds() { return {settings, objects, shapes, slicers, curves, maxParticleSpeed, *backend}; }

  StepReport run(float dt, int substeps) {
    StepReport report;
    report.substeps = substeps;
    report.substepDt = dt / substeps;
    const SubstepParams p = substepParams(settings, report.substepDt);
    for (int s = 0; s < substeps; ++s) backend->substep(p);
    time += dt;
    const StepCheck c = backend->takeCheck();
    maxParticleSpeed = std::sqrt(c.maxSpeed2);
    if (c.firstBadParticle != 0xffffffffu) reportDivergence(*backend, c.firstBadParticle, time);
    report.activeBlocks = backend->activeBlocks();
    return report;
  }

  ShapeId addShape(const ShapeDesc& d) {
    requireIdle("addShape");
    validateShapeDesc(d);
    ShapeRecord r{d, {d.pose, d.linearVelocity, d.angularVelocity}, {}};
    checkSpeed("ShapeDesc", r, r.state, settings);
    return shapes.add(r);
  }

  void removeShape(ShapeId id) {
    requireIdle("removeShape");
    shapes.lookup(id, "removeShape");
    shapes.remove(id);  // drops its mesh
  }

  /// The checks every addSlicer makes first: between steps, and a solver that can cut.
  void requireCuttingSolver() const {
    requireIdle("addSlicer");
    if (solverTraits(settings.solver).meshless)
      throw InvalidArgument("SceneSettings.solver", "Mtled",
                            "cannot cut: slicers need a grid solver (MlsMpm, StandardMpm or PbMpm)");
  }

  SlicerId addSlicer(const QuadSlicerDesc& d) {
    requireCuttingSolver();
    validateSlicerDesc(d);
    SlicerRecord r{d, {d.pose, d.linearVelocity, d.angularVelocity}, {}, nullptr};
    checkSpeed("QuadSlicerDesc", r, r.state, settings);
    return slicers.add(r);
  }

  SlicerId addSlicer(const MeshSlicerDesc& d) {
    requireCuttingSolver();
    validateSlicerDesc(d);
    auto curved = std::make_shared<CurvedBlade>();
    // sampled as far as a particle can be recorded (maxStencilReach, which also covers the
    // faces' band and resting reach, 1.15 dx) beyond the blade's own thickness
    const float spacing = d.sampleSpacing > 0.f ? d.sampleSpacing : 0.25f * settings.dx;
    curved->grid = std::make_shared<const SignedDistanceGrid>(
        buildBladeGrid(d.blade, spacing, d.halfThickness + maxStencilReach(settings.dx)));
    curved->spineFrom = d.spineFrom;
    curved->spineTo = d.spineTo;
    SlicerRecord r{commonFields(d), {d.pose, d.linearVelocity, d.angularVelocity}, {}, std::move(curved)};
    checkSpeed("MeshSlicerDesc", r, r.state, settings);
    return slicers.add(r);
  }

  /// The checks every addCurve makes first: between steps, and a grid solver.
  void requireCurveSolver() const {
    requireIdle("addCurve");
    if (solverTraits(settings.solver).meshless)
      throw InvalidArgument("SceneSettings.solver", "Mtled",
                            "has no curves: needles and threads need a grid solver (MlsMpm, StandardMpm or PbMpm)");
  }

  CurveId addCurve(const ArcDesc& d) {
    requireCurveSolver();
    validateCurveDesc(d);
    CurveRecord c;
    c.needle = true;
    c.arc = d;
    c.state = {d.pose, d.linearVelocity, d.angularVelocity};
    checkSpeed("ArcDesc", c, c.state, settings);
    c.impulses.resize(c.bodyCount());
    return curves.add(c);
  }

  CurveId addCurve(const LineSegmentsDesc& d) {
    requireCurveSolver();
    validateCurveDesc(d);
    validateThreadSpeeds(d.velocities, SubstepBounds::maxShapeSpeed(settings));
    CurveRecord c;
    c.needle = false;
    c.thread = d;
    c.impulses.resize(c.bodyCount());
    return curves.add(c);
  }

  /// A curve of the kind `needle` asks for, between steps.
  CurveRecord& curveOfKind(CurveId id, bool needle, const char* call) {
    CurveRecord& c = idleRecord(curves, id, call);
    if (c.needle != needle)
      throw InvalidArgument(std::string(call) + " id", std::to_string(id.index),
                            needle ? "is a thread (LineSegmentsDesc): set its points with setCurvePoints"
                                   : "is a needle (ArcDesc): move it with setCurveState");
    return c;
  }

  /// Checks and uploads what an advance of dt needs; returns the step itself, to run on the
  /// worker (advance) or here (step).
  auto startStep(float dt, const char* call, const char* dtField) {
    requireIdle(call);
    validate::positive(dtField, dt);
    const int n = substepBounds().substepCount(dt);
    bodies = uploadShapes(shapes, slicers, curves, objects, settings, *backend);
    const bool energy = settings.energyCheck.enabled;
    std::vector<ShapeState> before;
    if (energy)
      for (size_t i = 0; i < shapes.size(); ++i) before.push_back(shapes[i].state);
    return [this, dt, n, energy, before = std::move(before)] {
      // a failed advance is undone: what it changes is kept first (the particles' copy is
      // the pass that sorts them, see the backends' saveStateAndSort; a retry starts from
      // the copy put back, so keeping it again keeps the same state)
      const Rollback rollback = keep();
      for (int halvings = 0;; ++halvings) {
        bool saved = false;
        try {
          if (halvings > 0)  // moved by the failed attempt
            bodies = uploadShapes(shapes, slicers, curves, objects, settings, *backend);
          if (energy && !account.started) account.start(*backend, settings, objects);
          backend->saveStateAndSort();
          saved = true;
          StepReport r = run(dt, n << halvings);
          downloadShapes(shapes, slicers, curves, bodies, dt, *backend);
          if (energy) r.energy = account.checkAdvance(*backend, settings, objects, shapes, before, time);
          r.halvings = halvings;
          return r;
        } catch (const SimulationDiverged&) {
          if (saved) backend->restoreState();
          restore(rollback);
          if (!retryWithHalfSubstep(n, halvings)) throw;
        } catch (...) {
          if (saved) backend->restoreState();
          restore(rollback);
          throw;
        }
      }
    };
  }

  void advance(float dt) {
    worker.get().submit(startStep(dt, "advance", "Scene::advance dt"));
    stepping = true;
  }

  /// advance and fetch in one, on the calling thread. Why: a coupler steps the tissue once
  /// per Bullet tick (the suturing demo 9600 times a simulated second), and each hand-off to
  /// the worker and back was two thread wake-ups; a SceneBatch of 16 scenes on 2 threads,
  /// its runners handing every scene to that scene's worker, kept 1.54 of its 2 cores busy
  /// (2.00 stepping on the runners).
  StepReport step(float dt) { return startStep(dt, "step", "Scene::step dt")(); }

  /// Whether a diverged advance of n substeps, halved `halvings` times so far, is taken
  /// again with half the substep (SceneSettings::recovery).
  bool retryWithHalfSubstep(int n, int halvings) const {
    return settings.recovery.enabled && halvings < settings.recovery.maxHalvings &&
           (float)n * (float)(2 << halvings) <= SubstepBounds::kMaxSubsteps;
  }

  /// What an advance changes on the host.
  struct Rollback {
    double time;
    float maxParticleSpeed;
    EnergyAccount account;
    std::vector<std::pair<ShapeState, ShapeImpulse>> shapes, slicers;
    std::vector<CurveRecord> curves;
  };
  Rollback keep() const {
    Rollback r{time, maxParticleSpeed, account, {}, {}, {}};
    for (size_t i = 0; i < curves.size(); ++i) r.curves.push_back(curves[i]);
    for (size_t i = 0; i < shapes.size(); ++i) r.shapes.push_back({shapes[i].state, shapes[i].lastImpulse});
    for (size_t i = 0; i < slicers.size(); ++i) r.slicers.push_back({slicers[i].state, slicers[i].lastImpulse});
    return r;
  }
  void restore(const Rollback& r) {
    time = r.time;
    maxParticleSpeed = r.maxParticleSpeed;
    account = r.account;
    for (size_t i = 0; i < shapes.size(); ++i) std::tie(shapes[i].state, shapes[i].lastImpulse) = r.shapes[i];
    for (size_t i = 0; i < slicers.size(); ++i) std::tie(slicers[i].state, slicers[i].lastImpulse) = r.slicers[i];
    for (size_t i = 0; i < curves.size(); ++i) curves[i] = r.curves[i];
  }

  /// The whole scene as a checkpoint (state/scene_checkpoint.h), with the caller's bytes.
  std::vector<uint8_t> checkpoint(const std::vector<uint8_t>& attachment) const {
    checkpoint::Writer w;
    checkpoint::writeSettings(w, settings);
    w.section("scene");
    w.put(time);
    w.put(maxParticleSpeed);
    w.put(account);
    checkpoint::writeObjects(w, objects);
    checkpoint::writeShapes(w, shapes);
    checkpoint::writeSlicers(w, slicers);
    checkpoint::writeCurves(w, curves);
    BackendState state;
    backend->exportState(state);
    checkpoint::writeBackendState(w, state);
    w.section("attachment");
    w.putArray(attachment);
    return w.finish();
  }

  /// A checkpoint read whole and checked, not yet applied.
  struct Loaded {
    double time = 0;
    float maxParticleSpeed = 0;
    EnergyAccount account;
    ObjectTable objects{"ParticleObjectId", "particle object"};
    ShapeTable shapes{"ShapeId", "shape"};
    SlicerTable slicers{"SlicerId", "slicer"};
    CurveTable curves{"CurveId", "curve"};
    BackendState backend;
    std::vector<uint8_t> attachment;
  };
  Loaded read(const std::vector<uint8_t>& bytes) const {
    checkpoint::Reader r(bytes.data(), bytes.size());
    Loaded l;
    checkpoint::checkSettings(r, settings);
    r.section("scene");
    l.time = r.get<double>("the scene's time");
    l.maxParticleSpeed = r.get<float>("the fastest particle's speed");
    l.account = r.get<EnergyAccount>("the energy account");
    checkpoint::readObjects(r, l.objects);
    checkpoint::readShapes(r, l.shapes);
    checkpoint::readSlicers(r, l.slicers);
    checkpoint::readCurves(r, l.curves);
    checkpoint::readBackendState(r, l.backend);
    const bool meshless = solverTraits(settings.solver).meshless;
    const GridGeometry grid = gridGeometry(settings);
    checkpoint::checkParticles(l.backend, l.objects, meshless, meshless ? nullptr : &grid);
    r.section("attachment");
    r.getArray(l.attachment, "the attachment");
    r.finish();
    return l;
  }
  /// Replaces the scene with a checkpoint's (read() has refused a bad one by then).
  std::vector<uint8_t> load(const std::vector<uint8_t>& bytes) {
    requireIdle("load");
    Loaded l = read(bytes);
    time = l.time;
    maxParticleSpeed = l.maxParticleSpeed;
    account = l.account;
    objects = std::move(l.objects);
    shapes = std::move(l.shapes);
    slicers = std::move(l.slicers);
    curves = std::move(l.curves);
    bodies = BodyMap{};
    uploadMaterials();
    backend->importState(l.backend);
    return std::move(l.attachment);
  }

  StepReport fetch() {
    if (!stepping) return {};
    stepping = false;
    if (worker.inherited())  // its step ran on a thread of the parent's: half done, here
      throw Error("fetchResults: the process was forked while a step was running; the scene's state is "
                  "undefined in the child (fork between fetchResults and the next advance)");
    return worker.get().wait();
  }

  SceneSettings settings;
  GridGeometry geo;
  Backend resolved = Backend::Cpu;
  std::unique_ptr<SimBackend> backend;
  // the handle tables: a new kind of handle adds its table here
  ObjectTable objects{"ParticleObjectId", "particle object"};
  ShapeTable shapes{"ShapeId", "shape"};
  SlicerTable slicers{"SlicerId", "slicer"};
  CurveTable curves{"CurveId", "curve"};
  BodyMap bodies;  ///< where the shapes and slicers are among the backend's bodies
  float maxParticleSpeed = 0.f;
  double time = 0.0;
  EnergyAccount account;
  bool stepping = false;  ///< an advance was submitted and its result not yet fetched
  PerProcess<StepWorker> worker;  // after everything its jobs touch, so it stops first
};

Scene::Scene(const SceneSettings& settings) : impl_(std::make_unique<SceneImpl>(settings)) {}
Scene::~Scene() = default;
Scene::Scene(Scene&&) noexcept = default;
Scene& Scene::operator=(Scene&&) noexcept = default;

ParticleObjectId Scene::addParticleObject(const ParticleObjectDesc& d) { return impl_->add(d); }
void Scene::removeParticleObject(ParticleObjectId id) { impl_->remove(id); }
bool Scene::isValid(ParticleObjectId id) const { return impl_->objects.isValid(id); }
std::vector<ParticleObjectId> Scene::particleObjects() const { return impl_->objects.liveIds(); }
void Scene::advance(float dt) { impl_->advance(dt); }
StepReport Scene::fetchResults() { return impl_->fetch(); }
ShapeId Scene::addShape(const ShapeDesc& d) { return impl_->addShape(d); }
void Scene::removeShape(ShapeId id) { impl_->removeShape(id); }
bool Scene::isValid(ShapeId id) const { return impl_->shapes.isValid(id); }
void Scene::setShapeState(ShapeId id, const ShapeState& s) { impl_->setMotion(impl_->shapes, id, s, "setShapeState"); }
ShapeState Scene::shapeState(ShapeId id) const { return impl_->idleRecord(impl_->shapes, id, "shapeState").state; }
ShapeImpulse Scene::shapeImpulse(ShapeId id) const {
  return impl_->idleRecord(impl_->shapes, id, "shapeImpulse").lastImpulse;
}
SlicerId Scene::addSlicer(const QuadSlicerDesc& d) { return impl_->addSlicer(d); }
SlicerId Scene::addSlicer(const MeshSlicerDesc& d) { return impl_->addSlicer(d); }
void Scene::removeSlicer(SlicerId id) {
  impl_->idleRecord(impl_->slicers, id, "removeSlicer");
  impl_->slicers.remove(id);  // its cuts stay in the particles
}
bool Scene::isValid(SlicerId id) const { return impl_->slicers.isValid(id); }
void Scene::setSlicerState(SlicerId id, const ShapeState& s) {
  impl_->setMotion(impl_->slicers, id, s, "setSlicerState");
}
ShapeState Scene::slicerState(SlicerId id) const { return impl_->idleRecord(impl_->slicers, id, "slicerState").state; }
ShapeImpulse Scene::slicerImpulse(SlicerId id) const {
  return impl_->idleRecord(impl_->slicers, id, "slicerImpulse").lastImpulse;
}
void Scene::setStepThreads(int threads) {
  impl_->requireIdle("setStepThreads");
  impl_->backend->setCpuThreads(threads > 0 ? threads : impl_->settings.cpuThreads);
}
bool Scene::stepping() const { return impl_->stepping; }
StepReport Scene::step(float dt) { return impl_->step(dt); }
float Scene::maxSubstep() {
  impl_->requireIdle("maxSubstep");
  return impl_->substepBounds().maxSubstep();
}
double Scene::time() const {
  impl_->requireIdle("time");
  return impl_->time;
}
Backend Scene::backend() const { return impl_->resolved; }
const SceneSettings& Scene::settings() const { return impl_->settings; }
size_t Scene::particleCount() const { return impl_->backend->particleCount(); }
size_t Scene::particleCount(ParticleObjectId id) const {
  return impl_->objects.lookup(id, "particleCount").particles;
}

namespace {
/// Gathers one object's particles in their stable per-object order.
template <class T, class Pick>
void gatherObject(const SceneImpl& s, ParticleObjectId id, const char* call, Pick pick,
                  std::vector<T>& out) {
  s.requireIdle(call);
  const ObjectRecord& rec = s.objects.lookup(id, call);
  HostParticles all;
  s.backend->download(all);
  out.resize(rec.particles);
  for (size_t i = 0; i < all.size(); ++i)
    if (all.object[i] == id.index) out[all.local[i]] = pick(all, i);
}
}  // namespace

void Scene::readPositions(ParticleObjectId id, std::vector<Vec3f>& out) const {
  gatherObject(*impl_, id, "readPositions", [](const HostParticles& a, size_t i) { return a.x[i]; }, out);
}
void Scene::readVelocities(ParticleObjectId id, std::vector<Vec3f>& out) const {
  gatherObject(*impl_, id, "readVelocities", [](const HostParticles& a, size_t i) { return a.v[i]; }, out);
}
void Scene::readDeformationGradients(ParticleObjectId id, std::vector<Mat3f>& out) const {
  gatherObject(*impl_, id, "readDeformationGradients",
               [](const HostParticles& a, size_t i) { return a.F[i]; }, out);
}

ObjectSummary Scene::summary(ParticleObjectId id) const {
  impl_->requireIdle("summary");
  impl_->objects.lookup(id, "summary");
  HostParticles all;
  impl_->backend->download(all);
  ObjectSummary s;
  // APIC carries spin in C: a particle's angular momentum about its own position is
  // m D eps : C^T with D = dx^2 / 4 for quadratic B-splines (Jiang et al. 2015).
  const double D =
      solverTraits(impl_->settings.solver).affine ? 0.25 * (double)impl_->settings.dx * impl_->settings.dx : 0.0;
  double lx = 0, ly = 0, lz = 0;
  for (size_t i = 0; i < all.size(); ++i) {
    if (all.object[i] != id.index) continue;
    const double m = all.mass[i];
    const Vec3f x = all.x[i], v = all.v[i];
    const Mat3f& C = all.C[i];
    s.particles++;
    s.mass += m;
    s.centerOfMass[0] += m * x.x; s.centerOfMass[1] += m * x.y; s.centerOfMass[2] += m * x.z;
    s.momentum[0] += m * v.x; s.momentum[1] += m * v.y; s.momentum[2] += m * v.z;
    lx += m * ((double)x.y * v.z - (double)x.z * v.y) + m * D * (C.m[2][1] - C.m[1][2]);
    ly += m * ((double)x.z * v.x - (double)x.x * v.z) + m * D * (C.m[0][2] - C.m[2][0]);
    lz += m * ((double)x.x * v.y - (double)x.y * v.x) + m * D * (C.m[1][0] - C.m[0][1]);
    s.kineticEnergy += 0.5 * m * ((double)v.x * v.x + (double)v.y * v.y + (double)v.z * v.z);
  }
  for (double& c : s.centerOfMass) c /= s.mass;
  // about the centre of mass: L - c x p
  const double* c = s.centerOfMass;
  const double* p = s.momentum;
  s.angularMomentum[0] = lx - (c[1] * p[2] - c[2] * p[1]);
  s.angularMomentum[1] = ly - (c[2] * p[0] - c[0] * p[2]);
  s.angularMomentum[2] = lz - (c[0] * p[1] - c[1] * p[0]);
  return s;
}

void Scene::save(const std::string& path, const std::vector<uint8_t>& attachment) const {
  impl_->requireIdle("save");
  checkpoint::writeFileAtomically(path, impl_->checkpoint(attachment));
}
std::vector<uint8_t> Scene::saveToMemory(const std::vector<uint8_t>& attachment) const {
  impl_->requireIdle("saveToMemory");
  return impl_->checkpoint(attachment);
}
std::vector<uint8_t> Scene::load(const std::string& path) {
  impl_->requireIdle("load");
  return impl_->load(checkpoint::readFile(path));
}
std::vector<uint8_t> Scene::loadFromMemory(const std::vector<uint8_t>& bytes) { return impl_->load(bytes); }
std::vector<uint8_t> Scene::attachmentOf(const std::vector<uint8_t>& bytes) const {
  impl_->requireIdle("attachmentOf");
  return impl_->read(bytes).attachment;
}

// the worker thread writes these during a step: read only between steps, like the rest
StageTimings Scene::timings() const {
  impl_->requireIdle("timings");
  return impl_->backend->timings;
}
void Scene::resetTimings() {
  impl_->requireIdle("resetTimings");
  impl_->backend->timings = StageTimings{};
}
size_t Scene::memoryBytes() const {
  impl_->requireIdle("memoryBytes");
  return impl_->backend->memoryBytes();
}

}  // namespace mpm

namespace mpm {

CurveId Scene::addCurve(const ArcDesc& d) { return impl_->addCurve(d); }
CurveId Scene::addCurve(const LineSegmentsDesc& d) { return impl_->addCurve(d); }
void Scene::removeCurve(CurveId id) {
  impl_->idleRecord(impl_->curves, id, "removeCurve");
  impl_->curves.remove(id);
}
bool Scene::isValid(CurveId id) const { return impl_->curves.isValid(id); }
void Scene::setCurveState(CurveId id, const ShapeState& s) {
  CurveRecord& c = impl_->curveOfKind(id, true, "setCurveState");
  validateShapeState(s);
  checkSpeed("ShapeState", c, s, impl_->settings);
  c.state = s;
}
ShapeState Scene::curveState(CurveId id) const { return impl_->curveOfKind(id, true, "curveState").state; }
void Scene::setCurvePoints(CurveId id, const std::vector<Vec3f>& points, const std::vector<Vec3f>& velocities) {
  CurveRecord& c = impl_->curveOfKind(id, false, "setCurvePoints");
  validateCurvePoints(points, velocities, c.thread.points.size());
  validateThreadSpeeds(velocities, SubstepBounds::maxShapeSpeed(impl_->settings));
  c.thread.points = points;
  c.thread.velocities = velocities;
}
ShapeImpulse Scene::curveImpulse(CurveId id) const {
  const CurveRecord& c = impl_->idleRecord(impl_->curves, id, "curveImpulse");
  ShapeImpulse sum;
  for (size_t k = 0; k < c.impulses.size(); ++k) {
    // a needle's bodies are both about its frame origin; a thread's segments about their midpoints
    const Vec3f lever = c.needle ? Vec3f{0.f, 0.f, 0.f}
                                 : 0.5f * (c.thread.points[k] + c.thread.points[k + 1]) - c.thread.points[0];
    sum.linear += c.impulses[k].linear;
    sum.angular += c.impulses[k].angular + cross(lever, c.impulses[k].linear);
  }
  return sum;
}
std::vector<ShapeImpulse> Scene::segmentImpulses(CurveId id) const {
  const CurveRecord& c = impl_->idleRecord(impl_->curves, id, "segmentImpulses");
  if (c.needle) return {curveImpulse(id)};
  return c.impulses;
}
std::vector<float> Scene::segmentContactMasses(CurveId id) const {
  const CurveRecord& c = impl_->idleRecord(impl_->curves, id, "segmentContactMasses");
  if (c.contactMasses.size() != c.bodyCount()) return std::vector<float>(c.bodyCount(), 0.f);
  return c.contactMasses;
}
bool Scene::tipInside(CurveId id) const { return impl_->curveOfKind(id, true, "tipInside").tipInside; }

}  // namespace mpm
