#pragma once
// What a LoadedScene owns, and the readers that fill it, one per part of the file.
#include <BulletDynamics/Featherstone/btMultiBody.h>
#include <BulletDynamics/Featherstone/btMultiBodyConstraintSolver.h>
#include <BulletDynamics/Featherstone/btMultiBodyDynamicsWorld.h>
#include <BulletDynamics/Featherstone/btMultiBodyPoint2Point.h>
#include <btBulletDynamicsCommon.h>

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mpm/output.h"
#include "mpm/sdf_grid.h"
#include "mpm/scene.h"
#include "mpm_bullet/coupler.h"
#include "mpm_bullet/scene_file.h"
#include "mpm_bullet/suture.h"
#include "scene_file/entry_readers.h"
#include "scene_file/json_reader.h"
#include "scene_file/scripted_motion.h"

namespace mpm::bullet::scene_file {

struct Body {
  std::string name;
  std::unique_ptr<btCollisionShape> shape;
  std::unique_ptr<btMotionState> motionState;
  std::unique_ptr<btRigidBody> body;
  bool coupled = false;
  std::optional<Keyframes> script;
  std::unique_ptr<NeedleDriver> driver;  ///< a script applied through forces
  std::optional<io::Rgb> color;          ///< drawn in the pictures (every shape but a plane)
  TriangleMesh mesh;                     ///< a mesh shape's triangles, as the pictures draw it
  btVector3 frameImpulse{0, 0, 0};       ///< what the tissue gave it over the frame (shape, slicer, needle)
  std::optional<double> heldAt;          ///< Bullet's time its script was stopped at (LoadedScene::holdBody)
};

struct Object {
  std::string name;
  ParticleObjectId id;
  io::Rgb color{215, 110, 105};
  Material material;  ///< as the file gave it
};

struct Needle {
  Body* body;
  ArcDesc arc;
  CurveId curve;
};

struct Slicer {
  Body* body;
  QuadSlicerDesc blade;
  SlicerId id;
};

struct Thread {
  std::string name;
  btMultiBody* multibody = nullptr;  ///< destroySutureThread releases it
  std::vector<std::pair<int, btMultiBodyPoint2Point*>> pins;  ///< by point; released with the thread
};

struct Output {
  int frames = 60;
  float frameTime = 1.f / 60;
  int pngEvery = 0;  ///< 0: no pictures
  bool ply = true;   ///< PLY files beside each picture
  io::Camera camera;
  std::optional<std::pair<float, float>> ground;  ///< height, half size [m]
  float particleRadius = 0.f;                     ///< [m]; 0: 0.3 dx
  float wireRadius = 0.f;                         ///< [m] threads' splats (needles' 1.25 times); 0: 0.2 particleRadius
  std::optional<std::pair<Vec3f, float>> cutaway; ///< normal, offset: particles with n.x > offset are not drawn
  struct Column {
    enum Kind { Position, Velocity, Force, CenterOfMass } kind = Position;
    std::string name;  ///< as written
    Body* body = nullptr;
    ParticleObjectId object;
  };
  std::vector<Column> columns;
};

}  // namespace mpm::bullet::scene_file

namespace mpm::bullet {

/// Owns everything the file built; the destructor releases it in the reverse order, and
/// also a half-built scene whose loading failed.
struct LoadedScene::Impl {
  std::string baseDir;
  // the Bullet world
  std::unique_ptr<btDefaultCollisionConfiguration> config;
  std::unique_ptr<btCollisionDispatcher> dispatcher;
  std::unique_ptr<btDbvtBroadphase> broadphase;
  std::unique_ptr<btMultiBodyConstraintSolver> solver;
  std::unique_ptr<btMultiBodyDynamicsWorld> world;
  float tick = 1.f / 240;
  int tissueInterval = 1;  ///< Bullet ticks per tissue advance (Coupler::setTissueInterval)
  double bulletTime = 0;   ///< Bullet's clock: the scene's runs ahead inside a tissue interval
  // the tissue and the coupling
  std::unique_ptr<Scene> scene;
  std::unique_ptr<Coupler> coupler;
  std::vector<scene_file::Object> objects;
  std::vector<std::unique_ptr<scene_file::Body>> bodies;
  std::vector<scene_file::Needle> needles;
  std::vector<scene_file::Slicer> slicers;
  std::vector<scene_file::Thread> threads;
  scene_file::Output output;
  std::function<void(float)> tickCallback;     ///< LoadedScene::setTickCallback
  std::function<void(float)> preTickCallback;  ///< LoadedScene::setPreTickCallback

  ~Impl();
  scene_file::Body* findBody(const std::string& name) const;
  /// Hooks the scripted motions and the frame's impulse sums into the coupler's ticks.
  void hookTicks();
};

}  // namespace mpm::bullet

namespace mpm::bullet::scene_file {

void readWorld(Node* world, LoadedScene::Impl& s);
void readObjects(const Json& objects, LoadedScene::Impl& s);
void readBodies(const Json& bodies, LoadedScene::Impl& s);
void readSlicers(const Json& slicers, LoadedScene::Impl& s);
void readNeedles(const Json& needles, LoadedScene::Impl& s);
void readThreads(const Json& threads, LoadedScene::Impl& s);
void readOutput(Node* output, LoadedScene::Impl& s);
/// A file named in the scene, relative to its folder; refused naming `path` when missing.
std::string resolveFile(const LoadedScene::Impl& s, const Json& name, const std::string& path);

}  // namespace mpm::bullet::scene_file
