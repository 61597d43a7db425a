// Scene: host-side bookkeeping (objects, handles, materials), input validation, the
// substep policy and the asynchronous step. The particle and grid work is the backend's.
#include "mpm/scene.h"

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <functional>
#include <exception>
#include <limits>
#include <mutex>
#include <sstream>
#include <thread>
#include <tuple>
#include <utility>

#include "backend/sim_backend.h"
#include "core/validate.h"
#include "shapes/shape_builder.h"
#include "solvers/solver_list.h"

namespace mpm {

namespace {

MaterialParams materialParams(const Material& m) {
  MaterialParams p;
  p.model = m.model == MaterialModel::NeoHookeanDecoupled ? kNeoHookeanDecoupled : kFixedCorotated;
  const float E = m.youngsModulus, nu = m.poissonRatio;
  p.mu = E / (2.f * (1.f + nu));
  p.lambda = E * nu / ((1.f + nu) * (1.f - 2.f * nu));
  p.bulk = p.lambda + 2.f * p.mu / 3.f;
  p.density = m.density;
  return p;
}

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

Mat3f skew(Vec3f w) {
  Mat3f m;
  m.m[0][1] = -w.z; m.m[0][2] = w.y;
  m.m[1][0] = w.z;  m.m[1][2] = -w.x;
  m.m[2][0] = -w.y; m.m[2][1] = w.x;
  return m;
}

}  // namespace

/// The one thread that runs a scene's steps. It lives as long as the scene: a new thread per
/// advance() would also make OpenMP build a new thread team every frame (measured: binning
/// on 2 threads took 10 ms per frame at 8k particles against 1.4 ms on 1).
///
/// The result is handed over under the worker's mutex, and the worker lets go of the job and
/// of any exception it threw before that: the job's captures are destroyed on the worker,
/// the exception on the caller's thread. (With std::packaged_task the worker held the
/// shared state, and so the exception, until after the caller had seen it; whichever
/// thread dropped the last reference destroyed it, ordered only by libstdc++'s
/// uninstrumented reference count, which ThreadSanitizer reported as a race.)
class StepWorker {
 public:
  StepWorker() : thread_([this] { loop(); }) {}
  ~StepWorker() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    thread_.join();
  }
  /// Starts `job`; the previous job's result must have been taken by wait().
  void submit(std::function<StepReport()> job) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      job_ = std::move(job);
      queued_ = true;
      done_ = false;
    }
    wake_.notify_all();
  }
  /// Waits for the submitted job; returns its report or rethrows what it threw.
  StepReport wait() {
    std::exception_ptr error;
    StepReport report;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      finished_.wait(lock, [this] { return done_; });
      done_ = false;
      error = std::move(error_);
      report = std::move(report_);
    }
    if (error) std::rethrow_exception(std::move(error));
    return report;
  }

 private:
  void loop() {
    for (;;) {
      std::function<StepReport()> job;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [this] { return stop_ || queued_; });
        if (!queued_) return;
        job = std::move(job_);
        queued_ = false;
      }
      StepReport report;
      std::exception_ptr error;
      try {
        report = job();
      } catch (...) {
        error = std::current_exception();  // rethrown by wait(), i.e. fetchResults()
      }
      job = nullptr;  // its captures go here, before the caller can see the result
      {
        std::lock_guard<std::mutex> lock(mutex_);
        report_ = std::move(report);
        error_ = std::move(error);  // the worker keeps no reference to it
        done_ = true;
      }
      finished_.notify_all();
    }
  }

  std::mutex mutex_;
  std::condition_variable wake_, finished_;
  std::function<StepReport()> job_;
  StepReport report_;
  std::exception_ptr error_;
  bool queued_ = false, done_ = false, stop_ = false;
  std::thread thread_;  // last: starts after the members it uses exist
};

struct ObjectRecord {
  uint32_t generation = 0;
  bool alive = false;
  size_t particles = 0;
  MaterialParams material;
  float youngsModulus = 0;  ///< as given (for messages)
  float maxInitialSpeed = 0;
};

struct ShapeRecord {
  uint32_t generation = 0;
  bool alive = false;
  ShapeDesc desc;
  ShapeState state;
  ShapeImpulse lastImpulse;
};

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
    if (!stepping) return;
    try {
      worker.wait();
    } catch (...) {  // an error nobody fetched: the scene goes anyway
    }
  }

  void requireIdle(const char* call) const {
    if (stepping)
      throw Error(std::string(call) + ": a step is running; call fetchResults() first");
  }

  const ObjectRecord& record(ParticleObjectId id, const char* call) const {
    if (!isValid(id)) {
      std::ostringstream s;
      s << id.index << "/" << id.generation;
      throw InvalidArgument(std::string(call) + ": ParticleObjectId", s.str(),
                            "does not name a live particle object");
    }
    return objects[id.index];
  }

  bool isValid(ParticleObjectId id) const {
    return id.index < objects.size() && objects[id.index].alive &&
           objects[id.index].generation == id.generation;
  }

  ParticleObjectId add(const ParticleObjectDesc& d) {
    requireIdle("addParticleObject");
    validate::particleObjectDesc(d);
    const float h = d.particleSpacing > 0.f ? d.particleSpacing : settings.dx / d.particlesPerCellAxis;
    if (h > settings.dx)
      throw InvalidArgument("ParticleObjectDesc.particleSpacing", validate::show(h),
                            "must not exceed the cell size dx = " + validate::show(settings.dx) +
                                " (fewer than one particle per cell leaves holes in the grid)");
    // lattice over the object's bounds, relative to its centre
    Vec3f lo, hi;
    if (d.primitive == PrimitiveType::Box) {
      lo = -d.halfExtents;
      hi = d.halfExtents;
    } else if (d.primitive == PrimitiveType::Sphere) {
      lo = {-d.radius, -d.radius, -d.radius};
      hi = {d.radius, d.radius, d.radius};
    } else if (d.primitive == PrimitiveType::Cylinder) {
      lo = {-d.radius, -d.halfExtents.y, -d.radius};
      hi = {d.radius, d.halfExtents.y, d.radius};
    } else {
      lo = d.mesh->lower;
      hi = d.mesh->upper();
    }
    // the object's material, relative to its centre (a box fills its bounds)
    const auto inObject = [&d](Vec3f r) {
      switch (d.primitive) {
        case PrimitiveType::Sphere: return dot(r, r) <= d.radius * d.radius;
        case PrimitiveType::Cylinder: return r.x * r.x + r.z * r.z <= d.radius * d.radius;
        case PrimitiveType::Mesh: return d.mesh->sample(r) < 0.f;
        case PrimitiveType::Box: break;
      }
      return true;
    };
    // MPM particles sit at the centres of lattice cells of spacing h; meshless nodes on the
    // cells' corners, so the outermost ones lie on the bounds (the faces where boundary
    // conditions act), the spacing stretched to fit the bounds exactly
    const bool meshless = solverTraits(settings.solver).meshless;
    checkParticleBudget(d, h, hi - lo, meshless);
    int n[3];
    Vec3f step;
    for (int a = 0; a < 3; ++a) {
      n[a] = (int)std::lround((hi[a] - lo[a]) / h);
      if (n[a] < 1)
        throw InvalidArgument(d.primitive == PrimitiveType::Box ? "ParticleObjectDesc.halfExtents"
                                                                : "ParticleObjectDesc.radius",
                              validate::show(0.5f * (hi[a] - lo[a])),
                              "is smaller than half the particle spacing " + validate::show(h));
      step[a] = meshless ? (hi[a] - lo[a]) / n[a] : h;
      if (meshless) n[a] += 1;
    }
    // the slot the new object will take (not claimed until every check has passed)
    uint32_t slot = 0;
    while (slot < objects.size() && objects[slot].alive) ++slot;

    HostParticles add;
    const MaterialParams mat = materialParams(d.material);
    const float vol = h * h * h;
    const float lowWall = settings.domain.walls ? (float)settings.domain.wallThickness : 0.f;
    float maxSpeed = 0.f;
    for (int i = 0; i < n[0]; ++i)
      for (int j = 0; j < n[1]; ++j)
        for (int k = 0; k < n[2]; ++k) {
          // lattice centred in the bounds, so a box of whole spacings is filled exactly
          const Vec3f r{0.5f * (lo.x + hi.x) + (i + 0.5f - 0.5f * n[0]) * step.x,
                        0.5f * (lo.y + hi.y) + (j + 0.5f - 0.5f * n[1]) * step.y,
                        0.5f * (lo.z + hi.z) + (k + 0.5f - 0.5f * n[2]) * step.z};
          // a node on a curved surface may miss it by rounding: keep it
          if (!inObject(r) && !(meshless && inObject((1.f - 1e-5f) * r))) continue;
          const Vec3f x = d.center + r;
          bool inDomain = geo.stencilInside(x);
          for (int a = 0; a < 3 && inDomain; ++a) {
            const float g = (x[a] - geo.lower[a]) * geo.invDx;
            const float low = settings.domain.mirrorLower[a] ? (float)settings.domain.wallThickness : lowWall;
            inDomain = g >= low && g <= geo.cells[a] - lowWall;
          }
          if (!inDomain)
            throw InvalidArgument(
                "ParticleObjectDesc.center", validate::show(d.center),
                "puts a particle at " + validate::show(x) +
                    " outside the domain interior (domain minus walls and the B-spline stencil)");
          const Vec3f v = d.velocity + cross(d.angularVelocity, r);
          maxSpeed = std::max(maxSpeed, norm(v));
          add.x.push_back(x);
          add.v.push_back(v);
          add.C.push_back(skew(d.angularVelocity));  // velocity gradient of the rigid motion
          add.F.push_back(Mat3f::identity());
          add.mass.push_back(d.material.density * vol);
          add.volume0.push_back(vol);
          add.object.push_back(slot);
          add.local.push_back((uint32_t)add.x.size() - 1);
          add.touch.push_back(0.f);
        }
    if (add.size() == 0)
      throw InvalidArgument(d.primitive == PrimitiveType::Mesh ? "ParticleObjectDesc.mesh" : "ParticleObjectDesc.radius",
                            d.primitive == PrimitiveType::Mesh ? "grid" : validate::show(d.radius),
                            "holds no particle at spacing " + validate::show(h));
    IntegrationCells cells;
    if (meshless) {
      const float cellSize = h / settings.mtled.integrationCellsPerSpacing;
      cells = integrationCells([&](Vec3f x) { return inObject(x - d.center); }, d.center + lo, d.center + hi, cellSize);
      // the solver's model of the object (MTLED: support domains, moment matrices) is
      // checked now, so its errors come from here and not from the next advance
      std::vector<MaterialParams> table = materialTable();
      table.resize(std::max<size_t>(table.size(), slot + 1));
      table[slot] = mat;
      try {
        backend->checkObject(slot, add, cells, table);
      } catch (const Error& e) {
        const auto [field, value] = spacingField(d);
        throw InvalidArgument(field, value, std::string("cannot be modelled: ") + e.what());
      }
    }

    if (slot == objects.size()) objects.emplace_back();
    ObjectRecord& rec = objects[slot];
    rec.alive = true;
    rec.particles = add.size();
    rec.material = mat;
    rec.youngsModulus = d.material.youngsModulus;
    rec.maxInitialSpeed = maxSpeed;
    maxParticleSpeed = std::max(maxParticleSpeed, maxSpeed);
    uploadMaterials();
    account.started = false;  // the energy account starts again with the new object
    backend->append(add);
    if (meshless) backend->appendIntegrationCells(slot, cells);
    return {slot, rec.generation};
  }

  /// Most particles a scene holds: 11 GB of particle state (kParticleStateBytes each) on
  /// the device and as much again on the host while they are made; their indices are 32-bit.
  static constexpr double kMaxParticles = 1e8;

  /// Refuses, before any particle is made, an object whose lattice of spacing h over its
  /// bounds `size` (and, meshless, its integration cells) would pass kMaxParticles.
  void checkParticleBudget(const ParticleObjectDesc& d, float h, Vec3f size, bool meshless) const {
    double lattice = 1;
    for (int a = 0; a < 3; ++a) lattice *= std::round((double)size[a] / h) + (meshless ? 1 : 0);
    const double cells = meshless ? lattice * std::pow((double)settings.mtled.integrationCellsPerSpacing, 3) : 0;
    const double total = (double)backend->particleCount() + std::max(lattice, cells);
    if (total <= kMaxParticles) return;
    std::ostringstream why;
    why.precision(3);
    why << "gives a particle spacing of " << h << " m: about " << lattice << " particles in the object's bounds";
    if (meshless) why << " and " << cells << " integration cells";
    why << ", " << lattice * kParticleStateBytes / 1e9 << " GB of particle state; a scene holds at most "
        << kMaxParticles << " (it has " << backend->particleCount() << ")";
    const auto [field, value] = spacingField(d);
    throw InvalidArgument(field, value, why.str());
  }

  /// The field that sets an object's particle spacing, and its value.
  static std::pair<std::string, std::string> spacingField(const ParticleObjectDesc& d) {
    if (d.particleSpacing > 0.f) return {"ParticleObjectDesc.particleSpacing", validate::show(d.particleSpacing)};
    return {"ParticleObjectDesc.particlesPerCellAxis", std::to_string(d.particlesPerCellAxis)};
  }

  void remove(ParticleObjectId id) {
    requireIdle("removeParticleObject");
    record(id, "removeParticleObject");
    std::vector<uint8_t> keep(objects.size());
    for (size_t i = 0; i < objects.size(); ++i) keep[i] = objects[i].alive && i != id.index;
    backend->removeObjects(keep);
    account.started = false;
    objects[id.index].alive = false;
    objects[id.index].generation++;
    objects[id.index].particles = 0;
  }

  /// Materials by object slot.
  std::vector<MaterialParams> materialTable() const {
    std::vector<MaterialParams> table(objects.size());
    for (size_t i = 0; i < objects.size(); ++i) table[i] = objects[i].material;
    return table;
  }
  void uploadMaterials() { backend->setMaterials(materialTable()); }

  /// Longest substep: the CFL bound on the fastest elastic wave plus the fastest particle
  /// or shape, and the solver's own stable step.
  float maxSubstep() {
    float wave = 0.f;
    if (solverTraits(settings.solver).elasticCfl)
      for (const auto& o : objects)
        if (o.alive) wave = std::max(wave, pWaveSpeed(o.material));
    // a moving shape pushes material along at its own speed
    float shapeSpeed = 0.f;
    for (const auto& sh : shapes)
      if (sh.alive) shapeSpeed = std::max(shapeSpeed, norm(sh.state.linearVelocity));
    const float speed = wave + std::max(maxParticleSpeed, shapeSpeed);
    float dtMax = backend->stableTimeStep();
    if (speed > 0.f) dtMax = std::min(dtMax, settings.substeps.cflNumber * settings.dx / speed);
    return dtMax;
  }

  /// Most substeps one advance takes: a day of substeps at 10 ms each. More means a
  /// material, speed or spacing far from what the scene can step (E = 1e30 Pa asks for
  /// 2.4e12 substeps in a millisecond); an int count would also overflow.
  static constexpr float kMaxSubsteps = 1e7f;

  /// Substep count for an advance of dt, unless the user fixed the count. Throws
  /// InvalidArgument, before anything changes, when that passes kMaxSubsteps.
  int substepCount(float dt) {
    if (settings.substeps.fixedSubsteps > 0) return settings.substeps.fixedSubsteps;
    const float dtMax = maxSubstep();
    if (dtMax == std::numeric_limits<float>::infinity()) return 1;
    const float n = dt / dtMax;  // NaN or infinite for a zero or NaN bound: refused
    if (!(n <= kMaxSubsteps)) refuseSubsteps(dt, dtMax);
    return std::max(1, (int)std::ceil(n - 1e-5f));
  }

  /// Names what bounds the substep: the stiffest material, the solver's own step, speeds.
  [[noreturn]] void refuseSubsteps(float dt, float dtMax) {
    std::ostringstream s;
    s.precision(3);
    s << "needs " << (double)dt / dtMax << " substeps of at most " << dtMax << " s, more than the limit of "
      << kMaxSubsteps << " an advance takes:";
    size_t stiffest = objects.size();
    for (size_t i = 0; i < objects.size(); ++i)
      if (objects[i].alive && (stiffest == objects.size() ||
                               pWaveSpeed(objects[i].material) > pWaveSpeed(objects[stiffest].material)))
        stiffest = i;
    if (stiffest < objects.size())
      s << " object " << stiffest << "'s material (youngsModulus = " << validate::show(objects[stiffest].youngsModulus)
        << " Pa, density = " << objects[stiffest].material.density << " kg/m^3) carries elastic waves at "
        << pWaveSpeed(objects[stiffest].material) << " m/s;";
    const float own = backend->stableTimeStep();
    if (own < std::numeric_limits<float>::infinity()) s << " the solver's own stable step is " << own << " s;";
    s << " the fastest particle moves at " << maxParticleSpeed << " m/s (SceneSettings.substeps.cflNumber = "
      << settings.substeps.cflNumber << ", dx = " << settings.dx
      << " m). Use a softer material or a larger dx, or advance by less at a time";
    throw InvalidArgument("Scene::advance dt", validate::show(dt), s.str());
  }

  StepReport run(float dt, int substeps) {
    StepReport report;
    report.substeps = substeps;
    report.substepDt = dt / substeps;
    SubstepParams p;
    p.dt = report.substepDt;
    p.gravity = settings.gravity;
    p.walls.enabled = settings.domain.walls ? 1 : 0;
    p.walls.mode = static_cast<int>(settings.domain.wallMode);
    p.walls.thickness = settings.domain.wallThickness;
    for (int a = 0; a < 3; ++a) p.walls.mirror |= settings.domain.mirrorLower[a] ? 1 << a : 0;
    p.solver.flipBlend = settings.standardMpm.flipBlend;
    p.solver.iterations = settings.pbMpm.iterations;
    p.solver.relaxation = settings.pbMpm.relaxation;
    p.solver.rigidity = settings.pbMpm.rigidity;
    backend->sortParticles();
    for (int s = 0; s < substeps; ++s) backend->substep(p);
    time += dt;
    const StepCheck c = backend->takeCheck();
    maxParticleSpeed = std::sqrt(c.maxSpeed2);
    if (c.firstBadParticle != 0xffffffffu) reportDivergence(c.firstBadParticle);
    report.activeBlocks = backend->activeBlocks();
    return report;
  }

  /// "particle 3 of object 0 is at (x) with velocity (v) and volume ratio J = 1 at t = 2 s"
  std::string describeParticle(const HostParticles& all, uint32_t particle) const {
    std::ostringstream s;
    s << "particle " << all.local[particle] << " of object " << all.object[particle]
      << " is at " << validate::show(all.x[particle]) << " with velocity "
      << validate::show(all.v[particle]) << " and volume ratio J = det F = "
      << determinant(all.F[particle]) << " at t = " << time << " s";
    return s.str();
  }

  [[noreturn]] void reportDivergence(uint32_t particle) {
    HostParticles all;
    backend->download(all);
    throw SimulationDiverged(describeParticle(all, particle) + ": its state is not finite or it left the grid");
  }

  /// The particles' energy sums, and the particle holding the most energy per unit mass
  /// (where a blow-up grows fastest).
  struct EnergySums {
    double kinetic = 0, strain = 0, potential = 0, mass = 0;  // potential: -sum m g . x
    uint32_t hottest = 0;
  };

  EnergySums measureEnergy(const HostParticles& all) const {
    // W(F) of the particles is the stored energy only where F and E drive the forces (the
    // grid's elastic CFL solvers); MTLED holds it at its integration points; PB-MPM's is
    // not measured, so there kinetic + potential is a lower bound
    const bool strain = solverTraits(settings.solver).elasticCfl;
    EnergySums e;
    const double pointEnergy = backend->integrationPointEnergy(all);
    if (std::isfinite(pointEnergy)) e.strain = pointEnergy;
    double hottest = -1;
    for (size_t i = 0; i < all.size(); ++i) {
      const double m = all.mass[i];
      const Vec3f v = all.v[i], x = all.x[i];
      const double kinetic = 0.5 * m * dot(v, v);
      const double stored =
          strain ? (double)all.volume0[i] * strainEnergyDensity(objects[all.object[i]].material, all.F[i]) : 0.0;
      e.kinetic += kinetic;
      e.strain += stored;
      e.potential -= m * dot(settings.gravity, x);
      e.mass += m;
      const double specific = (kinetic + stored) / m;
      if (!(specific <= hottest)) {  // a NaN is the hottest of all
        hottest = specific;
        e.hottest = (uint32_t)i;
      }
    }
    return e;
  }

  /// The energy account of SceneSettings::energyCheck, restarted when objects change.
  struct EnergyAccount {
    bool started = false;
    double potentialStart = 0, positiveWork = 0, mostReleased = 0;
    EnergyBalance balance;
  } account;

  void startEnergyAccount() {
    HostParticles all;
    backend->download(all);
    const EnergySums e = measureEnergy(all);
    account = EnergyAccount{};
    account.started = true;
    account.potentialStart = e.potential;
    account.balance.start = e.kinetic + e.strain;
  }

  /// Books the advance just taken (shapes' work from their impulses and the mean of their
  /// velocities before and after it: exact for a body that only the material pushes) and
  /// throws SimulationDiverged when the energy grew beyond the check's tolerance.
  EnergyBalance checkEnergy(const std::vector<ShapeState>& before) {
    EnergyAccount& a = account;
    for (size_t i = 0; i < shapes.size() && i < before.size(); ++i) {
      if (!shapes[i].alive) continue;
      const ShapeState& now = shapes[i].state;
      const ShapeImpulse& J = shapes[i].lastImpulse;  // what the material gave the shape
      const double work = -0.5 * (dot(J.linear, before[i].linearVelocity + now.linearVelocity) +
                                  dot(J.angular, before[i].angularVelocity + now.angularVelocity));
      a.balance.work += work;
      a.positiveWork += std::max(work, 0.0);
    }
    HostParticles all;
    backend->download(all);
    const EnergySums e = measureEnergy(all);
    const EnergyCheck& check = settings.energyCheck;
    EnergyBalance& b = a.balance;
    b.kinetic = e.kinetic;
    b.strain = e.strain;
    b.released = a.potentialStart - e.potential;
    a.mostReleased = std::max(a.mostReleased, b.released);
    b.supplied = b.start + a.positiveWork + a.mostReleased + 0.5 * e.mass * check.noiseSpeed * check.noiseSpeed;
    if (!(b.excess() <= check.tolerance * b.supplied)) {
      std::ostringstream s;
      s << "energy grew without a source: the particles hold " << b.kinetic + b.strain << " J (kinetic "
        << b.kinetic << ", strain " << b.strain << ") against " << b.start << " J at the start, "
        << b.work << " J of shape work and " << b.released << " J released by gravity: an excess of "
        << b.excess() << " J, above SceneSettings.energyCheck.tolerance = " << check.tolerance << " times the "
        << b.supplied << " J supplied. The most energetic per unit mass, "
        << describeParticle(all, e.hottest);
      throw SimulationDiverged(s.str());
    }
    return b;
  }

  ShapeRecord& shape(ShapeId id, const char* call) {
    if (!isValid(id)) {
      std::ostringstream s;
      s << id.index << "/" << id.generation;
      throw InvalidArgument(std::string(call) + ": ShapeId", s.str(), "does not name a live shape");
    }
    return shapes[id.index];
  }
  const ShapeRecord& shape(ShapeId id, const char* call) const {
    return const_cast<SceneImpl*>(this)->shape(id, call);
  }
  bool isValid(ShapeId id) const {
    return id.index < shapes.size() && shapes[id.index].alive && shapes[id.index].generation == id.generation;
  }

  ShapeId addShape(const ShapeDesc& d) {
    requireIdle("addShape");
    validateShapeDesc(d);
    uint32_t slot = 0;
    while (slot < shapes.size() && shapes[slot].alive) ++slot;
    if (slot == shapes.size()) shapes.emplace_back();
    ShapeRecord& r = shapes[slot];
    r.alive = true;
    r.desc = d;
    r.state = {d.pose, d.linearVelocity, d.angularVelocity};
    r.lastImpulse = {};
    return {slot, r.generation};
  }

  void removeShape(ShapeId id) {
    requireIdle("removeShape");
    ShapeRecord& r = shape(id, "removeShape");
    r.alive = false;
    r.generation++;
    r.desc = ShapeDesc{};  // drops its mesh
  }

  /// Least contact band of a Bonded shape: half a cell on a grid, so the node layer
  /// nearest its face always follows it (with band 0 the layer just outside the face is
  /// free: a bonded plate let go of a cylinder it pulled once it had moved about a cell,
  /// and a compressed one measured 23 % soft at H = 10 dx). MTLED's nodes are tested at
  /// their own positions: its band is the shape's own.
  float bondedBand() const { return solverTraits(settings.solver).meshless ? 0.f : 0.5f * settings.dx; }
  /// Least half-thickness of a part on a grid, 0.75 dx: a thinner rod, plate or sphere
  /// gets the band that makes up the difference (PartView::band). MTLED: none.
  float thinPartHalfThickness() const { return solverTraits(settings.solver).meshless ? 0.f : 0.75f * settings.dx; }

  /// Where the parts are anchored (PartView): the domain's centre.
  Vec3f domainCentre() const { return 0.5f * (settings.domain.lower + settings.domain.upper); }
  static bool moved(const BodyView& b) {
    bool any = false;
    for (int i = 0; i < 3; ++i) {
      any = any || b.travel[i] != 0.0;
      for (int j = 0; j < 3; ++j) any = any || b.turn[i][j] != 0.0;
    }
    return any;
  }

  /// Hands the live shapes to the backend (bodies in shape-slot order, then parts).
  void uploadShapes() {
    std::vector<BodyView> bodies;
    std::vector<PartView> parts;
    std::vector<const SignedDistanceGrid*> meshes;
    bodyOfShape.assign(shapes.size(), -1);
    for (size_t i = 0; i < shapes.size(); ++i) {
      if (!shapes[i].alive) continue;
      const int b = (int)bodies.size();
      bodyOfShape[i] = b;
      bodies.push_back(makeBody(shapes[i].desc, shapes[i].state, bondedBand()));
      appendParts(shapes[i].desc, shapes[i].state, b, thinPartHalfThickness(), domainCentre(),
                  [&](const std::shared_ptr<const SignedDistanceGrid>& g) {
        meshes.push_back(g.get());
        return backend->meshValues(g);
      }, parts);
    }
    backend->releaseMeshesExcept(meshes);
    backend->setShapes(bodies, parts);
  }

  /// Reads the shapes' motion and impulses back after an advance.
  void downloadShapes() {
    std::vector<BodyView> bodies;
    backend->readBodies(bodies);
    const std::vector<ContactSums> impulses = backend->takeImpulses();
    for (size_t i = 0; i < shapes.size(); ++i) {
      const int b = i < bodyOfShape.size() ? bodyOfShape[i] : -1;
      if (!shapes[i].alive || b < 0) continue;
      ShapeState& st = shapes[i].state;
      // a body the substeps did not move keeps its pose as given: read back from the
      // float matrix and origin it would drift by their rounding every advance
      if (moved(bodies[b])) {
        st.pose.position = bodies[b].shapeOrigin;
        st.pose.rotation = quaternionFromMatrix(bodies[b].rotation);
      }
      st.linearVelocity = bodies[b].linearVelocity;
      st.angularVelocity = bodies[b].angularVelocity;
      const ContactSums& c = impulses[b];
      shapes[i].lastImpulse = {{c.impulse[0], c.impulse[1], c.impulse[2]}, {c.angular[0], c.angular[1], c.angular[2]}};
    }
  }

  void advance(float dt) {
    requireIdle("advance");
    validate::positive("Scene::advance dt", dt);
    const int n = substepCount(dt);
    uploadShapes();
    const bool energy = settings.energyCheck.enabled;
    std::vector<ShapeState> before;
    if (energy)
      for (const ShapeRecord& r : shapes) before.push_back(r.state);
    worker.submit([this, dt, n, energy, before = std::move(before)] {
      // a failed advance is undone: what it changes is kept first (the particles' copy
      // costs a pass over their memory, see the backends' saveState)
      const Rollback rollback = keep();
      backend->saveState();
      try {
        if (energy && !account.started) startEnergyAccount();
        StepReport r = run(dt, n);
        downloadShapes();
        if (energy) r.energy = checkEnergy(before);
        return r;
      } catch (...) {
        backend->restoreState();
        restore(rollback);
        throw;
      }
    });
    stepping = true;
  }

  /// What an advance changes on the host.
  struct Rollback {
    double time;
    float maxParticleSpeed;
    EnergyAccount account;
    std::vector<std::pair<ShapeState, ShapeImpulse>> shapes;
  };
  Rollback keep() const {
    Rollback r{time, maxParticleSpeed, account, {}};
    for (const ShapeRecord& s : shapes) r.shapes.push_back({s.state, s.lastImpulse});
    return r;
  }
  void restore(const Rollback& r) {
    time = r.time;
    maxParticleSpeed = r.maxParticleSpeed;
    account = r.account;
    for (size_t i = 0; i < shapes.size(); ++i) std::tie(shapes[i].state, shapes[i].lastImpulse) = r.shapes[i];
  }

  StepReport fetch() {
    if (!stepping) return {};
    stepping = false;
    return worker.wait();
  }

  SceneSettings settings;
  GridGeometry geo;
  Backend resolved = Backend::Cpu;
  std::unique_ptr<SimBackend> backend;
  std::vector<ObjectRecord> objects;
  std::vector<ShapeRecord> shapes;
  std::vector<int> bodyOfShape;  ///< shape slot -> body index in the backend, or -1
  float maxParticleSpeed = 0.f;
  double time = 0.0;
  bool stepping = false;  ///< an advance was submitted and its result not yet fetched
  StepWorker worker;  // after everything its jobs touch, so it stops first
};

Scene::Scene(const SceneSettings& settings) : impl_(std::make_unique<SceneImpl>(settings)) {}
Scene::~Scene() = default;
Scene::Scene(Scene&&) noexcept = default;
Scene& Scene::operator=(Scene&&) noexcept = default;

ParticleObjectId Scene::addParticleObject(const ParticleObjectDesc& d) { return impl_->add(d); }
void Scene::removeParticleObject(ParticleObjectId id) { impl_->remove(id); }
bool Scene::isValid(ParticleObjectId id) const { return impl_->isValid(id); }
void Scene::advance(float dt) { impl_->advance(dt); }
StepReport Scene::fetchResults() { return impl_->fetch(); }
ShapeId Scene::addShape(const ShapeDesc& d) { return impl_->addShape(d); }
void Scene::removeShape(ShapeId id) { impl_->removeShape(id); }
bool Scene::isValid(ShapeId id) const { return impl_->isValid(id); }
void Scene::setShapeState(ShapeId id, const ShapeState& s) {
  impl_->requireIdle("setShapeState");
  ShapeRecord& r = impl_->shape(id, "setShapeState");
  validateShapeState(s);
  r.state = s;
}
ShapeState Scene::shapeState(ShapeId id) const {
  impl_->requireIdle("shapeState");
  return impl_->shape(id, "shapeState").state;
}
ShapeImpulse Scene::shapeImpulse(ShapeId id) const {
  impl_->requireIdle("shapeImpulse");
  return impl_->shape(id, "shapeImpulse").lastImpulse;
}
StepReport Scene::step(float dt) {
  advance(dt);
  return fetchResults();
}
float Scene::maxSubstep() {
  impl_->requireIdle("maxSubstep");
  return impl_->maxSubstep();
}
double Scene::time() const {
  impl_->requireIdle("time");
  return impl_->time;
}
Backend Scene::backend() const { return impl_->resolved; }
const SceneSettings& Scene::settings() const { return impl_->settings; }
size_t Scene::particleCount() const { return impl_->backend->particleCount(); }
size_t Scene::particleCount(ParticleObjectId id) const {
  return impl_->record(id, "particleCount").particles;
}

namespace {
/// Gathers one object's particles in their stable per-object order.
template <class T, class Pick>
void gatherObject(const SceneImpl& s, ParticleObjectId id, const char* call, Pick pick,
                  std::vector<T>& out) {
  s.requireIdle(call);
  const ObjectRecord& rec = s.record(id, call);
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
  impl_->record(id, "summary");
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
