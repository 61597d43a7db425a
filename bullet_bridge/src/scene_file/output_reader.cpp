// "output": frames, pictures (camera, ground, cutaway) and the CSV's columns.
#include "scene_file/readers.h"

namespace mpm::bullet::scene_file {

namespace {

Output::Column readColumn(const Json& j, const std::string& path, const LoadedScene::Impl& s) {
  // "bodies.NAME.position|velocity|force" or "objects.NAME.centerOfMass"
  std::string text;
  parse(j, path, text);
  const size_t a = text.find('.'), b = text.rfind('.');
  const std::string group = text.substr(0, a), what = b == std::string::npos ? "" : text.substr(b + 1);
  const std::string name = a == std::string::npos || b <= a ? "" : text.substr(a + 1, b - a - 1);
  Output::Column c;
  c.kind = Output::Column::Position;
  c.name = text;
  if (group == "bodies" && (what == "position" || what == "velocity" || what == "force")) {
    c.kind = what == "position" ? Output::Column::Position
                                : what == "velocity" ? Output::Column::Velocity : Output::Column::Force;
    c.body = s.findBody(name);
    if (!c.body) fail(path, j, "no body named \"" + name + "\"");
    return c;
  }
  if (group == "objects" && what == "centerOfMass") {
    c.kind = Output::Column::CenterOfMass;
    for (const Object& o : s.objects)
      if (o.name == name) {
        c.object = o.id;
        return c;
      }
    fail(path, j, "no object named \"" + name + "\"");
  }
  fail(path, j, "must be bodies.NAME.position, bodies.NAME.velocity, bodies.NAME.force or objects.NAME.centerOfMass");
}

}  // namespace

void readOutput(Node* n, LoadedScene::Impl& s) {
  Output& o = s.output;
  if (!n) return;
  if (n->read("frames", o.frames) && o.frames < 1) fail(n->at("frames"), o.frames, "must be >= 1");
  if (n->read("frameTime", o.frameTime) && !(o.frameTime > 0.f)) fail(n->at("frameTime"), o.frameTime, "must be > 0");
  // a frame is a whole number of Bullet ticks (at least one); a bound keeps the count an int
  if (!(o.frameTime / s.tick <= 1e6f))
    fail(n->at("frameTime"), o.frameTime, "more than 1e6 Bullet ticks (world.tick) per frame");
  if (n->read("pngEvery", o.pngEvery) && o.pngEvery < 0) fail(n->at("pngEvery"), o.pngEvery, "must be >= 0 (0: none)");
  n->read("ply", o.ply);
  if (n->has("camera")) {
    Node c = n->object("camera");
    c.read("eye", o.camera.eye);
    c.read("target", o.camera.target);
    c.read("up", o.camera.up);
    c.read("fovYDegrees", o.camera.fovYDegrees);
    c.read("width", o.camera.width);
    c.read("height", o.camera.height);
    c.finish();
  }
  // the renderer checks the camera and the ground: here, so a bad one is a bad file
  try {
    io::SplatRenderer renderer(o.camera);
  } catch (const InvalidArgument& e) {
    rethrowAt(e, "Camera", n->at("camera"));
  }
  if (n->has("ground")) {
    Node g = n->object("ground");
    std::pair<float, float> ground{0.f, 1.f};
    g.read("height", ground.first);
    g.read("halfSize", ground.second);
    g.finish();
    try {
      io::SplatRenderer(o.camera).setGround(ground.first, ground.second);
    } catch (const InvalidArgument& e) {
      rethrowAt(e, "setGround", g.path());
    }
    o.ground = ground;
  }
  if (n->read("particleRadius", o.particleRadius) && !(o.particleRadius >= 0.f))
    fail(n->at("particleRadius"), o.particleRadius, "must be >= 0 (0: 0.3 dx)");
  if (n->read("wireRadius", o.wireRadius) && !(o.wireRadius >= 0.f))
    fail(n->at("wireRadius"), o.wireRadius, "must be >= 0 (0: 0.2 particleRadius)");
  if (n->has("cutaway")) {
    Node c = n->object("cutaway");
    std::pair<Vec3f, float> cut{{0.f, 0.f, 1.f}, 0.f};
    c.readRequired("normal", cut.first);
    c.read("offset", cut.second);
    c.finish();
    o.cutaway = cut;
  }
  const Json& columns = n->array("csv");
  for (size_t i = 0; i < columns.size(); ++i) o.columns.push_back(readColumn(columns[i], element(n->at("csv"), i), s));
  n->finish();
}

}  // namespace mpm::bullet::scene_file
