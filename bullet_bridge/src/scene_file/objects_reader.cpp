// "objects": tissue, mpm::ParticleObjectDesc under the same key names; the scene validates
// them and its errors are renamed to the key path (ParticleObjectDesc.x -> objects[i].x).
#include "mpm_bullet/mesh_import.h"
#include "scene_file/readers.h"

namespace mpm::bullet::scene_file {

namespace {

void readMaterial(Node n, Material& m) {
  n.read("model", m.model);
  n.read("youngsModulus", m.youngsModulus);
  n.read("poissonRatio", m.poissonRatio);
  n.read("density", m.density);
  n.read("fractureToughness", m.fractureToughness);
  n.finish();
}

/// The inside of a mesh file as a signed distance grid of `cellSize` (default dx / 2).
std::shared_ptr<const SignedDistanceGrid> readMesh(Node n, const std::string& baseDir, float dx) {
  const std::string file = resolveFile(baseDir, n.require("file"), n.at("file"));
  float scale = 1.f, cellSize = 0.5f * dx;
  n.read("scale", scale);
  n.read("cellSize", cellSize);
  n.finish();
  if (!(scale > 0.f)) fail(n.at("scale"), scale, "must be > 0");
  if (!(cellSize > 0.f)) fail(n.at("cellSize"), cellSize, "must be > 0");
  try {
    return std::make_shared<const SignedDistanceGrid>(buildSignedDistanceGrid(loadTriangleMesh(file, scale), cellSize));
  } catch (const Error& e) {  // unreadable, no triangles
    throw InvalidArgument(n.at("file"), show(n.require("file")), e.what());
  }
}

}  // namespace

io::Rgb readColor(const Json& j, const std::string& path) {
  if (!j.is_array() || j.size() != 3) fail(path, j, "must be an array of 3 integers in [0, 255]");
  int c[3];
  for (size_t i = 0; i < 3; ++i) {
    parse(j[i], element(path, i), c[i]);
    if (c[i] < 0 || c[i] > 255) fail(element(path, i), j[i], "must lie in [0, 255]");
  }
  return {(uint8_t)c[0], (uint8_t)c[1], (uint8_t)c[2]};
}

ObjectEntry readObjectEntry(const Json& j, const std::string& path, const std::string& baseDir, float dx) {
  Node n(j, path);
  ObjectEntry o;
  if (const Json* name = n.get("name")) parse(*name, n.at("name"), o.name.emplace());
  ParticleObjectDesc& d = o.desc;
  n.read("primitive", d.primitive);
  n.read("center", d.center);
  n.read("halfExtents", d.halfExtents);
  n.read("radius", d.radius);
  if (n.has("mesh")) {
    if (d.primitive != PrimitiveType::Mesh) fail(n.at("mesh"), n.require("mesh"), "needs \"primitive\": \"Mesh\"");
    d.mesh = readMesh(n.object("mesh"), baseDir, dx);
  } else if (d.primitive == PrimitiveType::Mesh) {
    failMissing(n.at("mesh"), "required with \"primitive\": \"Mesh\"");
  }
  n.read("particlesPerCellAxis", d.particlesPerCellAxis);
  n.read("particleSpacing", d.particleSpacing);
  if (n.has("material")) readMaterial(n.object("material"), d.material);
  n.read("velocity", d.velocity);
  n.read("angularVelocity", d.angularVelocity);
  if (const Json* c = n.get("color")) o.color = readColor(*c, n.at("color"));
  n.finish();
  return o;
}

ParticleObjectId addObjectAt(Scene& scene, const ParticleObjectDesc& desc, const std::string& path) {
  try {
    return scene.addParticleObject(desc);
  } catch (const InvalidArgument& e) {
    rethrowAt(e, "ParticleObjectDesc", path);
  }
}

void readObjects(const Json& objects, LoadedScene::Impl& s) {
  for (size_t i = 0; i < objects.size(); ++i) {
    const std::string path = element("objects", i);
    ObjectEntry e = readObjectEntry(objects[i], path, s.baseDir, s.scene->settings().dx);
    Object o;
    o.name = e.name ? *e.name : "object" + std::to_string(i);
    for (const Object& other : s.objects)
      if (other.name == o.name) fail(child(path, "name"), o.name, "another object has this name");
    if (e.color) o.color = *e.color;
    o.id = addObjectAt(*s.scene, e.desc, path);
    s.objects.push_back(o);
  }
}

}  // namespace mpm::bullet::scene_file
