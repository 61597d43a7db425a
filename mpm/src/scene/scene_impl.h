#pragma once
// SceneImpl: what a Scene holds and does, behind its public calls (scene.cpp). An advance
// excludes every other call: see `gate` and `stepping` below.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <new>
#include <shared_mutex>
#include <string>
#include <tuple>
#include <utility>

#include "system/sim_backend.h"
#include "core/per_process.h"
#include "core/validate.h"
#include "mpm/scene.h"
#include "scene/divergence.h"
#include "scene/energy_account.h"
#include "scene/particle_seeding.h"
#include "scene/shape_exchange.h"
#include "scene/slot_table.h"
#include "scene/step_worker.h"
#include "scene/substep_policy.h"
#include "shapes/shape_builder.h"
#include "tools/tool_builder.h"
#include "transfer/cut.h"
#include "solvers/solver_list.h"
#include "state/scene_checkpoint.h"

namespace mpm {

inline GridGeometry gridGeometry(const SceneSettings& s) {
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
    if (!stepping.load() || worker.inherited()) return;
    try {
      worker.get().wait();
    } catch (...) {  // an error nobody fetched: the scene goes anyway
    }
  }

  void requireIdle(const char* call) const {
    if (stepping.load())
      throw StepInProgress(std::string(call) + ": a step is running; call fetchResults() first");
  }
  /// Held by a public call for as long as it reads the scene (`reading`) or changes it
  /// (`changing`); either refuses while an advance runs. Calls from any thread then see a
  /// whole state or StepInProgress, never one an advance is halfway through writing.
  using Reading = std::shared_lock<std::shared_mutex>;
  using Changing = std::unique_lock<std::shared_mutex>;
  Reading reading(const char* call) const {
    Reading lock(gate);
    requireIdle(call);
    return lock;
  }
  Changing changing(const char* call) {
    Changing lock(gate);
    requireIdle(call);
    return lock;
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
    for (int s = 0; s < substeps; ++s) {
      if (cancelRequested.load(std::memory_order_relaxed))
        throw AdvanceCancelled("advance cancelled after " + std::to_string(s) + " of " +
                               std::to_string(substeps) + " substeps; the scene is as it was before the advance");
      backend->substep(p);
    }
    time += dt;
    const StepCheck c = backend->takeCheck();
    maxParticleSpeed = std::sqrt(c.maxSpeed2);
    checkParticles(*backend, c, settings, geo, report.substepDt, time);
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
        } catch (const std::bad_alloc&) {  // a container's growth: the library's allocations say more
          if (saved) backend->restoreState();
          restore(rollback);
          throw OutOfMemory("the advance's working memory (particle bins, grid blocks, contact lists)", 0);
        } catch (...) {
          if (saved) backend->restoreState();
          restore(rollback);
          throw;
        }
      }
    };
  }

  void advance(float dt) {
    Changing lock(gate);
    auto job = startStep(dt, "advance", "Scene::advance dt");
    cancelRequested.store(false);
    stepping.store(true);
    worker.get().submit(std::move(job));
  }

  /// advance and fetch in one, on the calling thread. Why: a coupler steps the tissue once
  /// per Bullet tick (the suturing demo 9600 times a simulated second), and each hand-off to
  /// the worker and back was two thread wake-ups; a SceneBatch of 16 scenes on 2 threads,
  /// its runners handing every scene to that scene's worker, kept 1.54 of its 2 cores busy
  /// (2.00 stepping on the runners).
  StepReport step(float dt) {
    auto job = [&] {
      Changing lock(gate);
      auto j = startStep(dt, "step", "Scene::step dt");
      cancelRequested.store(false);
      stepping.store(true);
      return j;
    }();
    struct Finished {  // however the step ends
      SceneImpl& s;
      ~Finished() {
        Changing lock(s.gate);
        s.stepping.store(false);
      }
    } finished{*this};
    return job();
  }

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
    if (!stepping.load()) return {};
    if (worker.inherited()) {  // its step ran on a thread of the parent's: half done, here
      Changing lock(gate);
      stepping.store(false);
      throw Error("fetchResults: the process was forked while a step was running; the scene's state is "
                  "undefined in the child (fork between fetchResults and the next advance)");
    }
    // the step is over only once the worker is: other threads' calls are refused until then
    std::exception_ptr error;
    StepReport report;
    try {
      report = worker.get().wait();
    } catch (...) {
      error = std::current_exception();
    }
    {
      Changing lock(gate);
      stepping.store(false);
    }
    if (error) std::rethrow_exception(error);
    return report;
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
  /// An advance was submitted and its result not yet fetched (or step() runs): set and
  /// cleared under `gate` held exclusively, read by every call under it.
  std::atomic<bool> stepping{false};
  mutable std::shared_mutex gate;
  /// Scene::cancel() asked the running advance to stop at its next substep boundary.
  std::atomic<bool> cancelRequested{false};
  PerProcess<StepWorker> worker;  // after everything its jobs touch, so it stops first
};

}  // namespace mpm
