#pragma once
// The step check of an advance: what SimulationDiverged says about the particle where the
// step went wrong, and why.
#include <cstdint>
#include <string>

#include "system/sim_backend.h"

namespace mpm {

/// "particle 3 of object 0 is at (x) with velocity (v) and volume ratio J = 1 at t = 2 s"
std::string describeParticle(const HostParticles& all, uint32_t particle, double time);

/// Throws SimulationDiverged, naming the particle, its object and the cause, when the
/// advance that ended at scene time `time` [s] with substeps of `substepDt` [s] left a
/// particle not finite, off the grid, or (settings.divergenceCheck) with its volume ratio
/// out of bounds, or moved a particle further in a substep than the check allows. `check`:
/// what the backend's kernels found (StepCheck); the particles are read back only when it
/// flags one.
void checkParticles(const SimBackend& backend, const StepCheck& check, const SceneSettings& settings,
                    const GridGeometry& geo, float substepDt, double time);

}  // namespace mpm
