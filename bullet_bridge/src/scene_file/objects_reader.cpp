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

/// A mesh given inline: "vertices" ([[x, y, z], ...]) and "triangles" ([[i, j, k], ...],
/// indices into the vertices).
TriangleMesh readInlineMesh(Node& n) {
  TriangleMesh mesh;
  const Json& vertices = n.require("vertices");
  if (!vertices.is_array() || vertices.empty()) fail(n.at("vertices"), vertices, "must be a non-empty array of [x, y, z]");
  mesh.vertices.resize(vertices.size());
  for (size_t i = 0; i < vertices.size(); ++i) parse(vertices[i], element(n.at("vertices"), i), mesh.vertices[i]);
  const Json& triangles = n.require("triangles");
  if (!triangles.is_array() || triangles.empty())
    fail(n.at("triangles"), triangles, "must be a non-empty array of [i, j, k]");
  for (size_t t = 0; t < triangles.size(); ++t) {
    const std::string at = element(n.at("triangles"), t);
    if (!triangles[t].is_array() || triangles[t].size() != 3) fail(at, triangles[t], "must be an array of 3 indices");
    for (size_t c = 0; c < 3; ++c) {
      int index = 0;
      parse(triangles[t][c], element(at, c), index);
      if (index < 0 || (size_t)index >= mesh.vertices.size())
        fail(element(at, c), triangles[t][c],
             "must index the vertices (0 to " + std::to_string(mesh.vertices.size() - 1) + ")");
      mesh.indices.push_back((uint32_t)index);
    }
  }
  return mesh;
}

/// The inside of a closed mesh, from a file or given inline (readInlineMesh), as a signed
/// distance grid of `cellSize` (default dx / 2).
std::shared_ptr<const SignedDistanceGrid> readMesh(Node n, const std::string& baseDir, float dx) {
  float scale = 1.f, cellSize = 0.5f * dx;
  n.read("scale", scale);
  n.read("cellSize", cellSize);
  if (!(scale > 0.f)) fail(n.at("scale"), scale, "must be > 0");
  if (!(cellSize > 0.f)) fail(n.at("cellSize"), cellSize, "must be > 0");
  const bool given = n.has("vertices") || n.has("triangles");
  if (given && n.has("file"))
    fail(n.at("file"), n.require("file"), "give either a file or vertices and triangles, not both");
  TriangleMesh mesh;
  if (given) {
    mesh = readInlineMesh(n);
    n.finish();
    for (Vec3f& v : mesh.vertices) v = scale * v;
  } else {
    const std::string file = resolveFile(baseDir, n.require("file"), n.at("file"));
    n.finish();  // an unknown key before the file is read
    try {
      mesh = loadTriangleMesh(file, scale);
    } catch (const Error& e) {  // unreadable, no triangles
      throw InvalidArgument(n.at("file"), show(n.require("file")), e.what());
    }
  }
  return std::make_shared<const SignedDistanceGrid>(buildSignedDistanceGrid(mesh, cellSize));
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
    o.material = e.desc.material;
    s.objects.push_back(o);
  }
}

}  // namespace mpm::bullet::scene_file
