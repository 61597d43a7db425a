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
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "mpm/scene.h"
#include "mpm_bullet/coupler.h"

class btMultiBody;
class btMultiBodyPoint2Point;
class btVector3;
class btMultiBodyDynamicsWorld;
class btRigidBody;

namespace mpm::bullet {

class LoadedScene {
 public:
  /// Reads and builds the scene in `path`. `overrides` is a JSON merge patch (RFC 7386)
  /// applied to the file before it is read, e.g. `{"settings": {"dx": 0.02}}` for a coarse
  /// run; empty: none. One departure: a top-level array whose elements in the patch all
  /// carry a "name" of the file's array patches those elements only, e.g.
  /// `{"objects": [{"name": "left", "halfExtents": [0.01, 0.01, 0.01]}]}` (any other array
  /// replaces the file's). Relative file names in the scene are relative to its folder.
  static std::unique_ptr<LoadedScene> fromFile(const std::string& path, const std::string& overrides = "");
  /// The same with several merge patches, applied in their order (a command line's options).
  static std::unique_ptr<LoadedScene> fromFile(const std::string& path, const std::vector<std::string>& overrides);
  /// The same from JSON text; file names are relative to `baseDir`.
  static std::unique_ptr<LoadedScene> fromString(const std::string& json, const std::string& baseDir = ".",
                                                 const std::string& overrides = "");
  static std::unique_ptr<LoadedScene> fromString(const std::string& json, const std::string& baseDir,
                                                 const std::vector<std::string>& overrides);
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
  /// The material the file gave the named particle object.
  const Material& material(const std::string& object) const;

  /// The pin the file put on `point` of `thread` (its force: pinForce); throws
  /// InvalidArgument when there is none.
  btMultiBodyPoint2Point* threadPin(const std::string& thread, int point) const;
  /// Stops a driven body's script where it is now: from the next tick its driver holds the
  /// pose the script gave for Bullet's present time, at rest (a hand that stops pulling).
  /// Throws InvalidArgument for a name that is no driven body.
  void holdBody(const std::string& name);
  bool held(const std::string& name) const;
  /// The mean force the tissue put on the body over the last frame [N] (coupled shape,
  /// slicer and needle together).
  btVector3 bodyForce(const std::string& name) const;
  /// Bullet's clock [s] (the scene's runs ahead inside a tissue interval) and its tick.
  double bulletTime() const;
  float tick() const;
  /// Called at the end of every Bullet tick with its length, after the frame's sums.
  void setTickCallback(std::function<void(float dt)> callback);
  /// Called at the start of every Bullet tick, after the drivers have pushed their bodies:
  /// the velocities the tick's tissue advance will see.
  void setPreTickCallback(std::function<void(float dt)> callback);

  /// output.frames and output.frameTime [s].
  int frameCount() const;
  float frameTime() const;
  /// Output frames done: round(scene time / frameTime).
  int frame() const;
  /// Steps Bullet (and with it the tissue) by one output frame: round(frameTime / tick)
  /// internal ticks of world.tick. Rethrows an error a tick raised (Coupler::rethrowError).
  void advanceFrame();

  /// Coupler::save / load, and the frame count and the bodies' scripts follow the scene's
  /// time. Load into a scene built from the same file and overrides.
  void saveCheckpoint(const std::string& path) const;
  void loadCheckpoint(const std::string& path);

  /// Whether this frame is one output.pngEvery asks a picture of.
  bool pngDue() const;
  /// Renders the particle objects (and needles, threads) with output.camera to a PNG.
  void writePng(const std::string& path) const;
  /// Whether this frame's PLY files are due: a picture's frame, unless output.ply is false.
  bool plyDue() const;
  /// Writes the frame as binary PLY for ParaView and Blender: every tissue particle in its
  /// object's colour to `tissuePath` (objects in the file's order, none cut away), and,
  /// unless `toolsPath` is empty, the needles and threads as polylines, the slicers' blades
  /// and coloured bodies as points to `toolsPath` (not written when the scene has none).
  void writePly(const std::string& tissuePath, const std::string& toolsPath = "") const;
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
