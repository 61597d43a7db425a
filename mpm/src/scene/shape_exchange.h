#pragma once
// The rigid shapes between advances: the scene's records, handed to the backend as bodies
// and parts before an advance and read back from it after.
#include <vector>

#include "backend/sim_backend.h"
#include "scene/slot_table.h"

namespace mpm {

/// A rigid shape as the scene keeps it.
struct ShapeRecord {
  ShapeDesc desc;
  ShapeState state;
  ShapeImpulse lastImpulse;
};
using ShapeTable = SlotTable<ShapeRecord, ShapeId>;

/// Hands the live shapes to the backend (bodies in shape-slot order, then parts); returns
/// the body index of each shape slot in the backend, or -1.
std::vector<int> uploadShapes(const ShapeTable& shapes, const SceneSettings& settings, SimBackend& backend);

/// Reads the shapes' motion and impulses back after an advance (`bodyOfShape` from
/// uploadShapes).
void downloadShapes(ShapeTable& shapes, const std::vector<int>& bodyOfShape, SimBackend& backend);

}  // namespace mpm
