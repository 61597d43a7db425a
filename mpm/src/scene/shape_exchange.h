#pragma once
// The rigid shapes between advances: the scene's records, handed to the backend as bodies
// and parts before an advance and read back from it after.
#include <memory>
#include <vector>

#include "backend/sim_backend.h"
#include "scene/slot_table.h"
#include "shapes/shape_builder.h"

namespace mpm {

/// A rigid shape as the scene keeps it.
struct ShapeRecord {
  ShapeDesc desc;
  ShapeState state;
  ShapeImpulse lastImpulse;
};
using ShapeTable = SlotTable<ShapeRecord, ShapeId>;

/// A slicer as the scene keeps it (kinematic: its state is the caller's). A curved one has
/// its geometry in `curved` and the common fields in `desc`.
struct SlicerRecord {
  QuadSlicerDesc desc;
  ShapeState state;
  ShapeImpulse lastImpulse;
  std::shared_ptr<const CurvedBlade> curved;
};
using SlicerTable = SlotTable<SlicerRecord, SlicerId>;

/// Where the scene's shapes and slicers are among the backend's bodies (-1: not there).
/// A slicer is two bodies, its faces at the index given and its spine after them.
struct BodyMap {
  std::vector<int> shapes, slicers;
};

/// Hands the live shapes, then the live slicers, to the backend (bodies in slot order,
/// then parts); returns where each slot's bodies are.
BodyMap uploadShapes(const ShapeTable& shapes, const SlicerTable& slicers, const SceneSettings& settings,
                     SimBackend& backend);

/// Reads the shapes' motion and the shapes' and slicers' impulses back after an advance
/// (`map` from uploadShapes).
void downloadShapes(ShapeTable& shapes, SlicerTable& slicers, const BodyMap& map, SimBackend& backend);

}  // namespace mpm
