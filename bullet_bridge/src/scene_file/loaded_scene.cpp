// LoadedScene: reads a scene file part by part into what it owns, and steps it.
#include <cmath>
#include <fstream>
#include <sstream>

#include "scene_file/readers.h"

namespace mpm::bullet {

using namespace scene_file;

namespace {

btVector3 bt(Vec3f v) { return btVector3(v.x, v.y, v.z); }

/// Where the parser is in the document, as a key path ("objects[1].material"): the
/// parser's events, followed, so that a value it refuses is named at its key.
class KeyPath {
 public:
  bool follow(Json::parse_event_t event, const Json& parsed) {
    using E = Json::parse_event_t;
    if ((event == E::object_start || event == E::array_start || event == E::value) && !frames_.empty() &&
        frames_.back().array)
      ++frames_.back().index;  // the start of an element
    if (event == E::object_start || event == E::array_start) frames_.push_back({event == E::array_start, {}, -1});
    if (event == E::object_end || event == E::array_end) frames_.pop_back();
    if (event == E::key) frames_.back().key = parsed.get<std::string>();
    return true;
  }
  /// The path of the value the parser reads next.
  std::string next() const {
    std::string path;
    for (const Frame& f : frames_)
      path = f.array ? element(path, (size_t)f.index + (&f == &frames_.back())) : child(path, f.key);
    return path;
  }

 private:
  struct Frame {
    bool array;
    std::string key;
    long index;
  };
  std::vector<Frame> frames_;
};

Json parseJson(const std::string& text, const std::string& what) {
  KeyPath at;
  try {
    return Json::parse(text, [&at](int, Json::parse_event_t event, Json& parsed) { return at.follow(event, parsed); });
  } catch (const Json::out_of_range& e) {
    // a number beyond a double (4e400): nlohmann's message quotes its text
    const std::string m = e.what(), open = "parsing '";
    const size_t from = m.find(open), to = from == std::string::npos ? from : m.find('\'', from + open.size());
    const std::string path = at.next();
    if (to != std::string::npos && !path.empty())
      throw InvalidArgument(path, m.substr(from + open.size(), to - from - open.size()),
                            "is beyond the range of a number (a double, about 1.8e308)");
    throw InvalidArgument(what, "(not JSON)", e.what());
  } catch (const Json::exception& e) {
    throw InvalidArgument(what, "(not JSON)", e.what());
  }
}

/// RFC 7386 merge patch, but for a top-level array ("objects", "bodies", "threads") whose
/// elements in the patch all name an element of the file's array: those elements are
/// patched, each by its own merge patch, and the rest left as they are. So a test names the
/// one block it changes instead of restating the whole array.
void mergeOverride(Json& root, const Json& patch) {
  if (!patch.is_object() || !root.is_object()) {
    root.merge_patch(patch);
    return;
  }
  Json rest = patch;
  for (auto it = patch.begin(); it != patch.end(); ++it) {
    const Json& items = it.value();
    if (!items.is_array() || items.empty() || !root.contains(it.key()) || !root[it.key()].is_array()) continue;
    Json& target = root[it.key()];
    std::vector<Json*> named;
    for (const Json& item : items) {
      Json* found = nullptr;
      if (item.is_object() && item.contains("name"))
        for (Json& t : target)
          if (t.is_object() && t.contains("name") && t["name"] == item["name"]) found = &t;
      if (!found) break;
      named.push_back(found);
    }
    if (named.size() != items.size()) continue;  // not all named: the array is replaced
    for (size_t i = 0; i < items.size(); ++i) named[i]->merge_patch(items[i]);
    rest.erase(it.key());
  }
  root.merge_patch(rest);
}

std::unique_ptr<LoadedScene::Impl> build(const Json& root, const std::string& baseDir) {
  auto s = std::make_unique<LoadedScene::Impl>();
  s->baseDir = baseDir;
  Node n(root, "");
  std::string description;
  n.read("description", description);  // for the reader of the file only

  const SceneSettings settings = readSettings(n.get("settings"));
  {
    std::optional<Node> world;
    if (n.has("world")) world.emplace(n.object("world"));
    readWorld(world ? &*world : nullptr, *s);
  }
  try {
    s->scene = std::make_unique<Scene>(settings);
  } catch (const InvalidArgument& e) {
    rethrowAt(e, "SceneSettings", "settings");
  }
  readObjects(n.array("objects"), *s);
  s->coupler = std::make_unique<Coupler>(s->world.get(), *s->scene);
  readBodies(n.array("bodies"), *s);
  readSlicers(n.array("slicers"), *s);
  readNeedles(n.array("needles"), *s);
  readThreads(n.array("threads"), *s);
  {
    std::optional<Node> output;
    if (n.has("output")) output.emplace(n.object("output"));
    readOutput(output ? &*output : nullptr, *s);
  }
  n.finish();
  // a frame ends where an interval does: the scene and Bullet agree on the time there, and a
  // checkpoint between frames is never inside an interval
  const int ticks = std::max(1, (int)std::lround(s->output.frameTime / s->tick));
  if (ticks % s->tissueInterval != 0)
    fail("world.tissueInterval", s->tissueInterval,
         "must divide the frame's " + std::to_string(ticks) + " Bullet ticks (output.frameTime / world.tick)");
  s->coupler->setTissueInterval(s->tissueInterval);
  s->hookTicks();
  return s;
}

}  // namespace

namespace scene_file {

void readWorld(Node* n, LoadedScene::Impl& s) {
  s.config = std::make_unique<btDefaultCollisionConfiguration>();
  s.dispatcher = std::make_unique<btCollisionDispatcher>(s.config.get());
  s.broadphase = std::make_unique<btDbvtBroadphase>();
  s.solver = std::make_unique<btMultiBodyConstraintSolver>();
  // always a multibody world: threads need one, rigid bodies step in it as in a discrete one
  s.world = std::make_unique<btMultiBodyDynamicsWorld>(s.dispatcher.get(), s.broadphase.get(), s.solver.get(),
                                                       s.config.get());
  Vec3f gravity{0.f, -9.81f, 0.f};
  if (!n) {
    s.world->setGravity(bt(gravity));
    return;
  }
  n->read("gravity", gravity);
  s.world->setGravity(bt(gravity));
  if (n->read("tick", s.tick) && !(s.tick > 0.f && s.tick <= 1.f)) fail(n->at("tick"), s.tick, "must lie in (0, 1] s");
  int iterations = s.world->getSolverInfo().m_numIterations;
  if (n->read("solverIterations", iterations) && iterations < 1) fail(n->at("solverIterations"), iterations, "must be >= 1");
  s.world->getSolverInfo().m_numIterations = iterations;
  if (n->read("tissueInterval", s.tissueInterval) && !(s.tissueInterval >= 1 && s.tissueInterval <= 1000))
    fail(n->at("tissueInterval"), s.tissueInterval, "must lie in [1, 1000] ticks");
  n->finish();
}

std::string resolveFile(const LoadedScene::Impl& s, const Json& name, const std::string& path) {
  return resolveFile(s.baseDir, name, path);
}

std::string resolveFile(const std::string& baseDir, const Json& name, const std::string& path) {
  std::string file;
  parse(name, path, file);
  if (!file.empty() && file[0] != '/') file = baseDir + "/" + file;
  if (!std::ifstream(file).good()) fail(path, name, "no such file (" + file + ")");
  return file;
}

}  // namespace scene_file

LoadedScene::Impl::~Impl() {
  coupler.reset();  // unhooks the world first
  for (Thread& t : threads) destroySutureThread(world.get(), t.multibody);  // with its pins
  for (auto& b : bodies) {
    b->driver.reset();
    world->removeRigidBody(b->body.get());
  }
  bodies.clear();
  scene.reset();
  world.reset();
}

Body* LoadedScene::Impl::findBody(const std::string& name) const {
  for (const auto& b : bodies)
    if (b->name == name) return b.get();
  return nullptr;
}

void LoadedScene::Impl::hookTicks() {
  coupler->setPreTickCallback([this](float dt) {
    for (auto& b : bodies) {
      if (!b->driver) continue;
      const double t = b->heldAt.value_or(bulletTime + dt);  // where the body should be after this tick
      btVector3 v(0, 0, 0), w(0, 0, 0);
      if (!b->heldAt) b->script->velocity(t, v, w);
      b->driver->setTarget(b->script->pose(t), v, w);
      b->driver->tick(dt);
    }
    if (preTickCallback) preTickCallback(dt);
  });
  coupler->setUserTickCallback([this](float dt) {
    bulletTime += dt;
    if (coupler->tissueAdvanced()) {  // an advance's impulses cover its whole interval
      auto add = [](Body* b, const ShapeImpulse& J) { b->frameImpulse += bt(J.linear); };
      for (auto& b : bodies)
        if (b->coupled) add(b.get(), scene->shapeImpulse(coupler->shapeOf(b->body.get())));
      for (Slicer& sl : slicers) add(sl.body, scene->slicerImpulse(sl.id));
      for (Needle& n : needles) add(n.body, scene->curveImpulse(n.curve));
    }
    if (tickCallback) tickCallback(dt);
  });
}

LoadedScene::LoadedScene(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
LoadedScene::~LoadedScene() = default;

std::unique_ptr<LoadedScene> LoadedScene::fromString(const std::string& json, const std::string& baseDir,
                                                     const std::vector<std::string>& overrides) {
  Json root = parseJson(json, "(scene)");
  for (const std::string& patch : overrides)
    if (!patch.empty()) mergeOverride(root, parseJson(patch, "(overrides)"));
  return std::unique_ptr<LoadedScene>(new LoadedScene(build(root, baseDir)));
}

std::unique_ptr<LoadedScene> LoadedScene::fromString(const std::string& json, const std::string& baseDir,
                                                     const std::string& overrides) {
  return fromString(json, baseDir, std::vector<std::string>{overrides});
}

std::unique_ptr<LoadedScene> LoadedScene::fromFile(const std::string& path, const std::vector<std::string>& overrides) {
  std::ifstream in(path);
  if (!in) throw InvalidArgument("(scene file)", path, "cannot be opened");
  std::stringstream text;
  text << in.rdbuf();
  const size_t slash = path.rfind('/');
  return fromString(text.str(), slash == std::string::npos ? "." : path.substr(0, slash), overrides);
}

std::unique_ptr<LoadedScene> LoadedScene::fromFile(const std::string& path, const std::string& overrides) {
  return fromFile(path, std::vector<std::string>{overrides});
}

Scene& LoadedScene::scene() { return *impl_->scene; }
Coupler& LoadedScene::coupler() { return *impl_->coupler; }
btMultiBodyDynamicsWorld& LoadedScene::world() { return *impl_->world; }

btRigidBody* LoadedScene::body(const std::string& name) const {
  if (Body* b = impl_->findBody(name)) return b->body.get();
  throw InvalidArgument("LoadedScene::body", name, "no body of this name");
}
ParticleObjectId LoadedScene::object(const std::string& name) const {
  for (const Object& o : impl_->objects)
    if (o.name == name) return o.id;
  throw InvalidArgument("LoadedScene::object", name, "no object of this name");
}
const Material& LoadedScene::material(const std::string& object) const {
  for (const Object& o : impl_->objects)
    if (o.name == object) return o.material;
  throw InvalidArgument("LoadedScene::material", object, "no object of this name");
}
btMultiBody* LoadedScene::thread(const std::string& name) const {
  for (const Thread& t : impl_->threads)
    if (t.name == name) return t.multibody;
  throw InvalidArgument("LoadedScene::thread", name, "no thread of this name");
}

btMultiBodyPoint2Point* LoadedScene::threadPin(const std::string& thread, int point) const {
  for (const Thread& t : impl_->threads)
    if (t.name == thread) {
      for (const auto& [p, pin] : t.pins)
        if (p == point) return pin;
      throw InvalidArgument("LoadedScene::threadPin", std::to_string(point), "thread \"" + thread + "\" has no pin at this point");
    }
  throw InvalidArgument("LoadedScene::threadPin", thread, "no thread of this name");
}

void LoadedScene::holdBody(const std::string& name) {
  Body* b = impl_->findBody(name);
  if (!b || !b->driver) throw InvalidArgument("LoadedScene::holdBody", name, "no driven body of this name");
  if (!b->heldAt) b->heldAt = impl_->bulletTime;
}

bool LoadedScene::held(const std::string& name) const {
  const Body* b = impl_->findBody(name);
  return b && b->heldAt.has_value();
}

btVector3 LoadedScene::bodyForce(const std::string& name) const {
  const Body* b = impl_->findBody(name);
  if (!b) throw InvalidArgument("LoadedScene::bodyForce", name, "no body of this name");
  const int ticks = std::max(1, (int)std::lround(impl_->output.frameTime / impl_->tick));
  return b->frameImpulse / (ticks * impl_->tick);
}

double LoadedScene::bulletTime() const { return impl_->bulletTime; }
float LoadedScene::tick() const { return impl_->tick; }
void LoadedScene::setTickCallback(std::function<void(float dt)> callback) { impl_->tickCallback = std::move(callback); }
void LoadedScene::setPreTickCallback(std::function<void(float dt)> callback) {
  impl_->preTickCallback = std::move(callback);
}

int LoadedScene::frameCount() const { return impl_->output.frames; }
float LoadedScene::frameTime() const { return impl_->output.frameTime; }
int LoadedScene::frame() const { return (int)std::lround(impl_->scene->time() / impl_->output.frameTime); }

void LoadedScene::advanceFrame() {
  for (auto& b : impl_->bodies) b->frameImpulse = btVector3(0, 0, 0);
  const int ticks = std::max(1, (int)std::lround(impl_->output.frameTime / impl_->tick));
  impl_->world->stepSimulation(ticks * impl_->tick, ticks + 1, impl_->tick);
  impl_->coupler->rethrowError();  // an error inside Bullet's tick surfaces here
}

void LoadedScene::saveCheckpoint(const std::string& path) const { impl_->coupler->save(path); }
void LoadedScene::loadCheckpoint(const std::string& path) {
  impl_->coupler->load(path);
  impl_->bulletTime = impl_->scene->time();  // saved between intervals: the clocks agreed
}

}  // namespace mpm::bullet
