#pragma once
// What a scene's checkpoint holds, section by section, in the checkpoint container
// (mpm/checkpoint_io.h): the settings (through their field list), the backend's particles
// (through MPM_PARTICLE_FIELDS) and meshless model inputs, the handle tables of objects and
// of rigid shapes with their mesh grids. The Scene adds time and its energy account.
#include <memory>
#include <vector>

#include "system/sim_backend.h"
#include "mpm/shapes.h"
#include "scene/particle_seeding.h"
#include "scene/shape_exchange.h"
#include "mpm/checkpoint_io.h"

namespace mpm::checkpoint {

/// Every settings field, by name.
void writeSettings(Writer& w, const SceneSettings& s);
/// Reads the settings a checkpoint was written with and refuses it (OtherScene, naming the
/// first field that differs and both values) unless its model fields equal `current`'s.
void checkSettings(Reader& r, const SceneSettings& current);

void writeBackendState(Writer& w, const BackendState& s);
void readBackendState(Reader& r, BackendState& s);

/// The handle tables, slot by slot (handles stay valid across a save and load).
void writeObjects(Writer& w, const ObjectTable& objects);
void readObjects(Reader& r, ObjectTable& objects);
void writeShapes(Writer& w, const ShapeTable& shapes);
void readShapes(Reader& r, ShapeTable& shapes);
/// The slicers' table (their cuts are in the particles).
void writeSlicers(Writer& w, const SlicerTable& slicers);
void readSlicers(Reader& r, SlicerTable& slicers);
void writeCurves(Writer& w, const CurveTable& curves);
void readCurves(Reader& r, CurveTable& curves);

/// Refuses (Truncated: the file is inconsistent) particles that name no live object, or
/// objects whose particle count differs from their particles', or a meshless backend
/// state without a reference position per node.
/// `grid`: a grid solver's grid, whose stencils every particle must lie inside (checked
/// in floats first: a position far outside would overflow the grid's integer index);
/// null for a meshless solver.
void checkParticles(const BackendState& s, const ObjectTable& objects, bool meshless, const GridGeometry* grid);

/// Shape descriptions; mesh grids shared by several parts or shapes are written once.
class ShapeWriter {
 public:
  void write(Writer& w, const ShapeDesc& d);

 private:
  std::vector<const SignedDistanceGrid*> written_;
};
class ShapeReader {
 public:
  ShapeDesc read(Reader& r);

 private:
  std::vector<std::shared_ptr<const SignedDistanceGrid>> read_;
};

}  // namespace mpm::checkpoint
