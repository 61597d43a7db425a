#pragma once
// What a scene's checkpoint holds, section by section, in the checkpoint container
// (checkpoint_format.h): the settings (through their field list), the backend's particles
// (through MPM_PARTICLE_FIELDS) and meshless model inputs, and rigid shapes with their mesh
// grids. The Scene adds its own records (time, handles, energy account) around these.
#include <memory>
#include <vector>

#include "backend/sim_backend.h"
#include "mpm/shapes.h"
#include "state/checkpoint_format.h"

namespace mpm::checkpoint {

/// Every settings field, by name.
void writeSettings(Writer& w, const SceneSettings& s);
/// Reads the settings a checkpoint was written with and refuses it (OtherScene, naming the
/// first field that differs and both values) unless its model fields equal `current`'s.
void checkSettings(Reader& r, const SceneSettings& current);

void writeBackendState(Writer& w, const BackendState& s);
void readBackendState(Reader& r, BackendState& s);

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
