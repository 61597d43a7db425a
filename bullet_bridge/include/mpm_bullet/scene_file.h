#pragma once
/// Scene files: a whole coupled simulation (the MPM scene's settings, tissue objects, Bullet
/// bodies with scripted motions, slicers, needles, threads and the output wanted) read from
/// JSON, the format in assets/scenes/scene.schema.json. `mpm_run SCENE.json --out DIR` runs
/// one headless (demos/mpm_run).
///
///   auto loaded = mpm::bullet::LoadedScene::fromFile("assets/scenes/coupling.json");
///   for (int f = 0; f < loaded->frameCount(); ++f) loaded->advanceFrame();
///
/// Errors name the JSON key path in the library's form: an unknown key, a wrong type, a
/// missing key or file, or a value the library refuses throw mpm::InvalidArgument such as
/// `objects[1].material.poissonRatio = 0.7: must lie in (-1, 0.5)`. Whatever was built
/// before the error is released again: a LoadedScene owns its Bullet world, bodies,
/// shapes, threads, scene and coupler.
#include <memory>
#include <string>
#include <vector>

#include "mpm/scene.h"
#include "mpm_bullet/coupler.h"

class btMultiBody;
class btMultiBodyDynamicsWorld;
class btRigidBody;

namespace mpm::bullet {

class LoadedScene {
 public:
  /// Reads and builds the scene in `path`. `overrides` is a JSON merge patch (RFC 7386)
  /// applied to the file before it is read, e.g. `{"settings": {"dx": 0.02}}` for a coarse
  /// run; empty: none. Relative file names in the scene are relative to its folder.
  static std::unique_ptr<LoadedScene> fromFile(const std::string& path, const std::string& overrides = "");
  /// The same from JSON text; file names are relative to `baseDir`.
  static std::unique_ptr<LoadedScene> fromString(const std::string& json, const std::string& baseDir = ".",
                                                 const std::string& overrides = "");
  ~LoadedScene();
  LoadedScene(const LoadedScene&) = delete;
  LoadedScene& operator=(const LoadedScene&) = delete;

  Scene& scene();
  Coupler& coupler();
  btMultiBodyDynamicsWorld& world();
  /// The named body / particle object / thread of the file; throws InvalidArgument for a name
  /// it does not have.
  btRigidBody* body(const std::string& name) const;
  ParticleObjectId object(const std::string& name) const;
  btMultiBody* thread(const std::string& name) const;

  /// output.frames and output.frameTime [s].
  int frameCount() const;
  float frameTime() const;
  /// Output frames done: round(scene time / frameTime).
  int frame() const;
  /// Steps Bullet (and with it the tissue) by one output frame: round(frameTime / tick)
  /// internal ticks of world.tick. Rethrows an error a tick raised (Coupler::rethrowError).
  void advanceFrame();

  /// Coupler::save / load, and the frame count follows the scene's time. A coupler with
  /// needles or threads refuses both (CheckpointError).
  void saveCheckpoint(const std::string& path) const;
  void loadCheckpoint(const std::string& path);

  /// Whether this frame is one output.pngEvery asks a picture of.
  bool pngDue() const;
  /// Renders the particle objects (and needles, threads) with output.camera to a PNG.
  void writePng(const std::string& path) const;
  /// output.csv: the header line and the row for now (time and the listed columns; forces
  /// are the averages over the last frame).
  std::string csvHeader() const;
  std::string csvRow() const;

  struct Impl;

 private:
  explicit LoadedScene(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace mpm::bullet
