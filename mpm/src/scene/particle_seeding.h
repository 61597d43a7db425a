#pragma once
// From a ParticleObjectDesc to the particles (and, for meshless solvers, the integration
// cells) of a new object, checked before the scene takes any of it.
#include <cstddef>
#include <vector>

#include "system/sim_backend.h"
#include "scene/slot_table.h"

namespace mpm {

/// A particle object as the scene keeps it.
struct ObjectRecord {
  size_t particles = 0;
  MaterialParams material;
  float youngsModulus = 0;  ///< as given (for messages)
  float maxInitialSpeed = 0;
};
using ObjectTable = SlotTable<ObjectRecord, ParticleObjectId>;

/// Materials by object slot.
std::vector<MaterialParams> materialTable(const ObjectTable& objects);

/// A new object, not yet in the scene: its record, its particles (carrying the slot it
/// will take, objects.nextSlot()) and, meshless, its integration cells.
struct SeededObject {
  ObjectRecord record;
  HostParticles particles;
  IntegrationCells cells;
};

/// Seeds `desc` (validated here) beside `objects`. Throws InvalidArgument naming the field
/// for a spacing over dx, a particle outside the domain's interior, no particle at all,
/// more than kMaxParticles in the scene, or (meshless) an object the backend's solver
/// cannot model; the scene and the backend are left unchanged either way.
SeededObject seedParticleObject(const ParticleObjectDesc& desc, const ObjectTable& objects,
                                const SceneSettings& settings, const GridGeometry& geo, const SimBackend& backend);

}  // namespace mpm
