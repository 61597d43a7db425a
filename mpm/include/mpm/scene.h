#pragma once
/// The Scene: owns the particles, the grid and the solver, and advances them in time.
///
///   mpm::SceneSettings s;  s.domain = {{-1,0,-1},{1,2,1}};  s.dx = 0.05f;
///   mpm::Scene scene(s);
///   mpm::ParticleObjectDesc block;  block.center = {0, 0.5f, 0};
///   auto id = scene.addParticleObject(block);
///   scene.advance(1.f / 60);  /* other work */  scene.fetchResults();
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "mpm/curves.h"
#include "mpm/error.h"
#include "mpm/settings.h"
#include "mpm/shapes.h"
#include "mpm/slicers.h"

namespace mpm {

/// Wall-clock seconds spent in each named stage of the step, summed since the last
/// resetTimings(). The stage names match the code and the benchmark table.
struct StageTimings {
  double sort = 0;        ///< binning particles by grid block, activating grid blocks
  /// particle-to-grid transfer; without mirror planes also what runs in its pass: the grid
  /// update, and on the CPU PB-MPM's G2P of the cycles before its last
  double p2g = 0;
  double gridUpdate = 0;  ///< grid velocity update, gravity, walls: where mirror planes are set (else in p2g)
  double contact = 0;     ///< grid contact with rigid shapes, shape motion
  double g2p = 0;         ///< grid-to-particle transfer, F update, push-out from shapes
  long long substeps = 0; ///< substeps these times cover
};

/// The particles' energy account since the start (or since particle objects last changed),
/// kept when SceneSettings::energyCheck is enabled (see there for what is measured) [J].
struct EnergyBalance {
  double kinetic = 0;   ///< sum 1/2 m v^2 now
  double strain = 0;    ///< stored elastic energy now: sum V0 W(F) of the particles (MTLED: of its integration points; PB-MPM: 0, not measured)
  double released = 0;  ///< potential energy gravity has released: -sum m g . (x - x_start)
  double start = 0;     ///< kinetic + strain at the start
  double work = 0;      ///< work of the shapes on the material (their impulses times velocities)
  double supplied = 0;  ///< start + positive work + largest release + noise floor
  /// Energy not accounted for by the start, the work and gravity; > 0 is energy growth.
  double excess() const { return kinetic + strain - start - released - work; }
};

/// What the last advance() did.
struct StepReport {
  int substeps = 0;        ///< substeps taken
  float substepDt = 0;     ///< length of each [s]
  size_t activeBlocks = 0; ///< grid blocks (4^3 nodes each) touched in the last substep
  EnergyBalance energy;    ///< with SceneSettings::energyCheck enabled, else zeros
  /// With SceneSettings::recovery: how often this advance diverged and was taken again
  /// with half the substep (substeps and substepDt are those of the attempt that held).
  int halvings = 0;
};

/// Per-object summary read back from the solver (double precision sums).
struct ObjectSummary {
  size_t particles = 0;
  double mass = 0;                  ///< [kg]
  double centerOfMass[3] = {0, 0, 0};  ///< [m]
  double momentum[3] = {0, 0, 0};      ///< linear momentum [kg m/s]
  double angularMomentum[3] = {0, 0, 0}; ///< about the centre of mass, incl. APIC spin [kg m^2/s]
  double kineticEnergy = 0;         ///< [J], particle velocities only
};

class SceneImpl;

/// A simulation world of MPM material. Not copyable; movable.
class Scene {
 public:
  /// Validates `settings` (throws InvalidArgument naming the field; a grid of more than
  /// 2^28 blocks of 4^3 nodes over the domain is refused on SceneSettings.dx with the memory
  /// its tables would take) and picks the backend
  /// (throws BackendUnavailable if CUDA is requested without a device).
  explicit Scene(const SceneSettings& settings);
  ~Scene();
  Scene(Scene&&) noexcept;
  Scene& operator=(Scene&&) noexcept;

  /// Adds a body of particles. Throws InvalidArgument (and changes nothing) on bad input,
  /// including particles that would lie outside the domain's interior, more than 1e8
  /// particles in the scene, or (SolverType::Mtled) an object its model cannot be built
  /// for (too few nodes for a support domain, coplanar supports). Objects already in the
  /// scene keep their state.
  ParticleObjectId addParticleObject(const ParticleObjectDesc& desc);
  /// Removes an object; its handle becomes stale.
  void removeParticleObject(ParticleObjectId id);
  /// True while `id` names a live object.
  bool isValid(ParticleObjectId id) const;
  /// Handles of every particle object in the scene, in slot order.
  std::vector<ParticleObjectId> particleObjects() const;

  /// Adds a rigid shape (validated; throws InvalidArgument naming the field).
  ShapeId addShape(const ShapeDesc& desc);
  void removeShape(ShapeId id);
  bool isValid(ShapeId id) const;
  /// Sets a shape's pose and velocities (e.g. from its Bullet body) before an advance.
  /// Within the advance the shape moves on with its velocity.
  void setShapeState(ShapeId id, const ShapeState& state);
  /// Pose and velocities after the last advance.
  ShapeState shapeState(ShapeId id) const;
  /// Momentum the grid gave the shape during the last advance.
  ShapeImpulse shapeImpulse(ShapeId id) const;

  /// Adds a blade that cuts the material it passes (mpm/slicers.h), moved like a
  /// kinematic shape. Cuts stay in the material after the slicer has gone (they are part of
  /// the particle state and of checkpoints). Grid solvers only: with SolverType::Mtled it
  /// throws InvalidArgument on SceneSettings.solver; a bad field throws naming it.
  SlicerId addSlicer(const QuadSlicerDesc& desc);
  /// A curved blade from an open mesh; its sided distance is sampled here (refused, naming
  /// the field, for a mesh that is empty or not consistently oriented).
  SlicerId addSlicer(const MeshSlicerDesc& desc);
  /// Removes a slicer; the cuts it made stay.
  void removeSlicer(SlicerId id);
  bool isValid(SlicerId id) const;
  /// Sets a slicer's pose and velocities before an advance (within it, it moves on with
  /// its velocity); the velocity is that of its frame's origin.
  void setSlicerState(SlicerId id, const ShapeState& state);
  /// Pose and velocities after the last advance.
  ShapeState slicerState(SlicerId id) const;
  /// Momentum the material gave the slicer during the last advance (faces and spine),
  /// about its frame's origin.
  ShapeImpulse slicerImpulse(SlicerId id) const;

  /// Adds a curve (mpm/curves.h): a needle or a thread. Grid solvers only (with
  /// SolverType::Mtled it throws InvalidArgument on SceneSettings.solver); a bad field
  /// throws naming it.
  CurveId addCurve(const ArcDesc& desc);
  CurveId addCurve(const LineSegmentsDesc& desc);
  void removeCurve(CurveId id);
  bool isValid(CurveId id) const;
  /// A needle's pose and velocities before an advance (of its frame's origin); within the
  /// advance it moves on with them. Throws InvalidArgument for a thread.
  void setCurveState(CurveId id, const ShapeState& state);
  /// A needle's pose and velocities after the last advance.
  ShapeState curveState(CurveId id) const;
  /// A thread's points and their velocities (one per point; empty: at rest) before an
  /// advance; the number of points is the thread's. Throws InvalidArgument for a needle.
  void setCurvePoints(CurveId id, const std::vector<Vec3f>& points, const std::vector<Vec3f>& velocities = {});
  /// Momentum the material gave the curve during the last advance: a needle's (shaft,
  /// tip, the resistance to its tip and the friction on its shaft) about its frame's
  /// origin; a thread's summed over its segments, about the first point.
  ShapeImpulse curveImpulse(CurveId id) const;
  /// A thread's impulse per segment, each about its segment's midpoint (a needle: one).
  std::vector<ShapeImpulse> segmentImpulses(CurveId id) const;
  /// Per segment of a thread (a needle: its wire and its tip), the mean mass of the grid
  /// nodes held by it over the last advance [kg]: the tissue that moves with it across
  /// itself (Coupler's added-mass thread coupling). Zeros before the first advance.
  std::vector<float> segmentContactMasses(CurveId id) const;
  /// Whether a needle's tip is inside the material (broke in and has not come out since).
  bool tipInside(CurveId id) const;

  /// Starts advancing the scene by `dt` seconds (> 0) on a worker thread. The scene must
  /// not be changed until fetchResults() returns. Throws InvalidArgument, changing
  /// nothing, if dt needs more than 1e7 substeps of maxSubstep() (a material far too stiff
  /// for dx, naming its youngsModulus).
  void advance(float dt);
  /// Waits for the step started by advance(); rethrows any error it raised (for instance
  /// SimulationDiverged, OutOfMemory, AdvanceCancelled). Returns immediately if no step is
  /// running.
  /// With SceneSettings::recovery, a diverging advance is first retried with halved
  /// substeps (StepReport::halvings); it throws once those are spent.
  /// After a failed step the scene is as it was before that advance(): time, particles
  /// (positions, velocities, F, C, their order), the shapes' states and last impulses and
  /// the energy account are put back (each advance keeps a copy of the particle state for
  /// this: one pass over it, and its size again in memory); only timings() keep the work.
  /// The same advance with the same settings fails again: change the scene (remove or
  /// replace the object named in the error, move a shape) or advance by less.
  StepReport fetchResults();
  /// advance(dt) followed by fetchResults(), run on the calling thread (no hand-off to the
  /// scene's worker thread and back): the same results, errors and recovery.
  StepReport step(float dt);
  /// Asks the advance that is running (advance() or step()) to stop at its next substep
  /// boundary: its fetchResults() (or step()) then throws AdvanceCancelled and the scene is
  /// as it was before that advance, as after any failed advance. Callable from any thread
  /// at any time; with no advance running it does nothing (the next advance starts anew).
  void cancel();

  /// Longest substep the substep policy allows now [s]: cflNumber dx / (c_p + the fastest
  /// particle or shape) (SubstepPolicy::cflFor: the solver's default when cflNumber is 0),
  /// and with MTLED no more than timeStepSafety times its critical step (eq. 37); infinity
  /// when nothing bounds it. advance(dt) takes ceil(dt / this)
  /// substeps unless fixedSubsteps is set. Not during a step.
  float maxSubstep();

  /// Simulated time since creation [s]. Not during a step: from the advance() until its
  /// fetchResults() returns (or inside step()), every call that reads or changes what a
  /// step writes throws StepInProgress, changing nothing, whatever thread it comes from.
  /// Calls from other threads between steps each see one whole state: they hold the
  /// scene while they read, and an advance() waits for them to finish. advance,
  /// fetchResults and step themselves are made from one thread at a time.
  double time() const;
  /// The backend actually in use (never Auto).
  Backend backend() const;
  const SceneSettings& settings() const;

  /// Number of live particles in the scene / in one object.
  size_t particleCount() const;
  size_t particleCount(ParticleObjectId id) const;
  /// Copies positions [m] / velocities [m/s] / deformation gradients of one object's
  /// particles into `out` (resized). Order is stable for the object's lifetime. With
  /// SolverType::Mtled the particles are nodes and F lives at the integration points: a
  /// node's F is the volume-weighted mean of the F of the points whose strain depends on it.
  void readPositions(ParticleObjectId id, std::vector<Vec3f>& out) const;
  void readVelocities(ParticleObjectId id, std::vector<Vec3f>& out) const;
  void readDeformationGradients(ParticleObjectId id, std::vector<Mat3f>& out) const;
  /// Mass, centre of mass, momenta and kinetic energy of one object.
  ObjectSummary summary(ParticleObjectId id) const;

  /// Checkpoints. save() writes the whole scene (its model settings, objects and their
  /// materials, shapes with their mesh grids, slicers, every particle field (cuts too), time, the energy
  /// account) and `attachment`, the caller's own bytes kept with it (the Bullet coupler
  /// keeps its bodies there). Files are written whole or not at all: into `path`.tmp,
  /// flushed, then renamed, so a failed save (CheckpointError, Io) leaves the file that
  /// was there. Not during a step.
  void save(const std::string& path, const std::vector<uint8_t>& attachment = {}) const;
  std::vector<uint8_t> saveToMemory(const std::vector<uint8_t>& attachment = {}) const;
  /// Replaces this scene's objects, shapes, slicers, particles (with their cuts), time and energy account with a
  /// checkpoint's and returns its attachment. Handles issued before the save name the same
  /// objects and shapes again. Stepping on is bit for bit the run that was saved (CPU
  /// backend, same thread count). Refused with CheckpointError, changing nothing, when the
  /// bytes are not a checkpoint, of another format version, truncated, corrupted (CRC-32)
  /// or of a scene whose model settings differ (named with both values; the backend, the
  /// thread count and the run-time policies, energyCheck and recovery, may differ). A file
  /// is checked (a regular file, its size and header) before it is read. Not during a step.
  std::vector<uint8_t> load(const std::string& path);
  std::vector<uint8_t> loadFromMemory(const std::vector<uint8_t>& checkpoint);
  /// The attachment of a checkpoint this scene would load, checked as load() checks it,
  /// without loading it (so a caller can refuse its own part before anything changes).
  std::vector<uint8_t> attachmentOf(const std::vector<uint8_t>& checkpoint) const;

  /// Accumulated per-stage times, and resetting them. Not during a step.
  StageTimings timings() const;
  void resetTimings();
  /// Bytes of memory the scene holds for particles and grid (host or device). Not during a
  /// step.
  size_t memoryBytes() const;

 private:
  friend class SceneBatchImpl;  // mpm/scene_batch.h
  /// SceneBatch's share of the threads: the CPU backend's loops run on `threads` threads
  /// from the next advance (0: SceneSettings::cpuThreads again; CUDA ignores it). Results
  /// do not depend on it. Between steps.
  void setStepThreads(int threads);
  /// Whether an advance() waits for its fetchResults().
  bool stepping() const;

  std::unique_ptr<SceneImpl> impl_;
};

/// True if a CUDA device is usable from this process.
bool cudaDeviceAvailable();
/// The name of the CUDA device a Cuda scene runs on ("" if there is none), for reports.
std::string cudaDeviceName();

}  // namespace mpm
