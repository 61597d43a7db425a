#pragma once
// The energy account of SceneSettings::energyCheck: the particles' kinetic and stored
// energy against what the start, the shapes' work and gravity supplied.
#include <vector>

#include "system/sim_backend.h"
#include "scene/particle_seeding.h"
#include "scene/shape_exchange.h"

namespace mpm {

/// The energy account of SceneSettings::energyCheck, restarted when objects change.
struct EnergyAccount {
  bool started = false;
  double potentialStart = 0, positiveWork = 0, mostReleased = 0;
  EnergyBalance balance;

  /// Starts the account at the particles' energy now.
  void start(const SimBackend& backend, const SceneSettings& settings, const ObjectTable& objects);

  /// Books the advance just taken (shapes' work from their impulses and the mean of their
  /// velocities `before` and after it: exact for a body that only the material pushes) and
  /// throws SimulationDiverged when the energy grew beyond the check's tolerance, naming
  /// the particle with the most energy per unit mass at scene time `time` [s].
  EnergyBalance checkAdvance(const SimBackend& backend, const SceneSettings& settings, const ObjectTable& objects,
                             const ShapeTable& shapes, const std::vector<ShapeState>& before, double time);
};

}  // namespace mpm
