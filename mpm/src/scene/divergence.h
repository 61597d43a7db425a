#pragma once
// What a SimulationDiverged report says about the particle where the step went wrong.
#include <cstdint>
#include <string>

#include "backend/sim_backend.h"

namespace mpm {

/// "particle 3 of object 0 is at (x) with velocity (v) and volume ratio J = 1 at t = 2 s"
std::string describeParticle(const HostParticles& all, uint32_t particle, double time);

/// Throws SimulationDiverged for `particle`, whose state is not finite or which left the
/// grid (StepCheck::firstBadParticle) at scene time `time` [s].
[[noreturn]] void reportDivergence(const SimBackend& backend, uint32_t particle, double time);

}  // namespace mpm
