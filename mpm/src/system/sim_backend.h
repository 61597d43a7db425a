#pragma once
// The interface between the Scene (host bookkeeping, validation, substep policy) and a
// backend that owns particle and grid memory and runs the kernels. The implementations,
// ParticleGridSystem<Exec, Method> (the MPM solvers) and MtledSystem<Exec> (meshless),
// are compiled once per backend (CPU in a .cpp, CUDA in a .cu).
#include <cstddef>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <vector>

#include "core/constitutive.h"
#include "core/substep.h"
#include "core/particle_state.h"
#include "grid/block_grid.h"
#include "grid/grid_update.h"
#include "contact/contact_law.h"
#include "contact/push_out.h"
#include "mpm/scene.h"
#include "mpm/sdf_grid.h"

namespace mpm {

/// Particle arrays on the host, used to add, read back and remove particles.
struct HostParticles {
#define MPM_DECLARE_HOST_FIELD(type, name) std::vector<type> name;
  MPM_PARTICLE_FIELDS(MPM_DECLARE_HOST_FIELD)
#undef MPM_DECLARE_HOST_FIELD
  size_t size() const { return x.size(); }
};

/// Background integration cells (meshless solvers): a point in each cell that holds
/// material and the volume of material it stands for [m^3], and the closed surface of
/// that material as quadrature points for the divergence theorem: cell p's are
/// [surfaceStart[p], surfaceStart[p + 1]), each at surfacePoints[] with its area times the
/// outward unit normal surfaceAreas[] [m^2]. A face two cells share is the same point in
/// both, with opposite normals.
struct IntegrationCells {
  std::vector<Vec3f> points;
  std::vector<float> volumes;
  std::vector<uint32_t> surfaceStart{0};
  std::vector<Vec3f> surfacePoints, surfaceAreas;

  size_t size() const { return points.size(); }
  /// Appends cell p of `from` after these cells.
  void appendCell(const IntegrationCells& from, size_t p) {
    points.push_back(from.points[p]);
    volumes.push_back(from.volumes[p]);
    for (uint32_t q = from.surfaceStart[p]; q < from.surfaceStart[p + 1]; ++q) {
      surfacePoints.push_back(from.surfacePoints[q]);
      surfaceAreas.push_back(from.surfaceAreas[q]);
    }
    surfaceStart.push_back((uint32_t)surfacePoints.size());
  }
};

/// What a backend holds of a scene beyond the Scene's own records, for checkpoints: every
/// particle field, and for a meshless solver the reference positions of its nodes and its
/// integration cells with their object slots (its model is rebuilt from these).
struct BackendState {
  HostParticles particles;
  std::vector<Vec3f> reference;
  IntegrationCells cells;
  std::vector<uint32_t> cellSlot;
};

class SimBackend {
 public:
  virtual ~SimBackend() = default;
  /// Appends particles (all fields filled) at the end of the state.
  virtual void append(const HostParticles& particles) = 0;
  /// The integration cells of the object in `slot` (appended just before); solvers
  /// without integration cells ignore them.
  virtual void appendIntegrationCells(uint32_t /*slot*/, const IntegrationCells& /*cells*/) {}
  /// Throws Error if the solver cannot model an object of these particles and cells with
  /// this material in `slot` (called before append(), so a refused object changes nothing).
  virtual void checkObject(uint32_t /*slot*/, const HostParticles& /*particles*/, const IntegrationCells& /*cells*/,
                           const std::vector<MaterialParams>& /*materials*/) const {}
  /// Keeps a copy of the state an advance changes (the particles) and orders particle
  /// memory by grid block, so the transfers walk memory in order (the copy keeps the
  /// order before); restoreState puts the copy back: a failed advance is undone with these.
  virtual void saveStateAndSort() = 0;
  virtual void restoreState() = 0;
  /// Keeps only the particles whose object slot has keep[slot] != 0.
  virtual void removeObjects(const std::vector<uint8_t>& keep) = 0;
  /// Material table indexed by object slot.
  virtual void setMaterials(const std::vector<MaterialParams>& materials) = 0;
  /// One substep of the scene's solver. Particles whose state is not finite or whose stencil left the
  /// grid are skipped by the transfers (never written out of bounds) and recorded.
  virtual void substep(const SubstepParams& params) = 0;
  /// Longest substep the solver's own stability allows [s]; infinity when the Scene's CFL
  /// bound is all it needs (the MPM solvers). Not const: a solver may finish a setup
  /// deferred since particles last changed to know it.
  virtual float stableTimeStep() { return std::numeric_limits<float>::infinity(); }
  /// The checks of the substeps since the last call (read once per advance, so the GPU
  /// is not waited on inside the substep loop), then cleared.
  virtual StepCheck takeCheck() = 0;
  /// Replaces the rigid shapes: bodies (motion, contact model) and their parts.
  virtual void setShapes(const std::vector<BodyView>& bodies, const std::vector<PartView>& parts) = 0;
  /// Device copy of a mesh grid's signed distance values, uploaded once; the cache holds
  /// the grid, so its address cannot be reused by another while cached. Entries whose
  /// grid is not in `live` are released.
  virtual const float* meshValues(const std::shared_ptr<const SignedDistanceGrid>& grid) = 0;
  virtual void releaseMeshesExcept(const std::vector<const SignedDistanceGrid*>& live) = 0;
  /// Bodies as they are now (poses and velocities advanced by the substeps).
  virtual void readBodies(std::vector<BodyView>& out) const = 0;
  /// Momentum each body received from the grid since the last call, then cleared.
  virtual std::vector<ContactSums> takeImpulses() = 0;
  /// Copies the whole particle state to the host.
  virtual void download(HostParticles& out) const = 0;
  /// The state a checkpoint keeps (BackendState), and its restoration, replacing every
  /// particle; the Scene sets the materials and shapes around it.
  virtual void exportState(BackendState& out) const { download(out.particles); }
  virtual void importState(const BackendState& in) = 0;
  /// Elastic energy held at the solver's own integration points [J], for the node
  /// positions in `state` (as download() gives them); NaN for solvers whose particles hold
  /// it as sum V0 W(F) (the grid solvers) or that store no elastic energy (PB-MPM).
  virtual double integrationPointEnergy(const HostParticles& /*state*/) const {
    return std::numeric_limits<double>::quiet_NaN();
  }
  /// The number of threads the CPU loops run on from the next call (0: all hardware
  /// threads); a SceneBatch gives each of its scenes a share. The CUDA backend ignores it.
  virtual void setCpuThreads(int threads) = 0;
  virtual size_t particleCount() const = 0;
  virtual size_t activeBlocks() const = 0;
  virtual size_t memoryBytes() const = 0;
  StageTimings timings;
};

/// The backend of `settings.solver` (its parameters from `settings`).
std::unique_ptr<SimBackend> makeCpuBackend(const SceneSettings& settings, const GridGeometry& geo);
/// Throws BackendUnavailable when built without CUDA or no device is present.
std::unique_ptr<SimBackend> makeCudaBackend(const SceneSettings& settings, const GridGeometry& geo);

}  // namespace mpm
