// Mesh files through assimp, and Bullet shapes that own the triangles they collide with.
// Before assimp reads a file, its bytes pass the format pre-checks of mesh_format_checks.cpp.
#include "mpm_bullet/mesh_import.h"

#include <assimp/IOSystem.hpp>
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <BulletCollision/CollisionShapes/btBvhTriangleMeshShape.h>
#include <BulletCollision/CollisionShapes/btConvexHullShape.h>
#include <BulletCollision/CollisionShapes/btTriangleIndexVertexArray.h>
#include <BulletCollision/Gimpact/btGImpactShape.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "mesh_format_checks.h"
#include "mpm/error.h"

namespace mpm::bullet {
namespace {

std::string show(float v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", v);
  return text;
}

// ------------------------------------------------------------------ assimp import

// Joins vertices at bit-identical positions across all meshes of a file (assimp's own
// JoinIdenticalVertices works per mesh and only when normals and UVs agree too).
class VertexWelder {
 public:
  explicit VertexWelder(mpm::TriangleMesh& mesh) : mesh_(mesh) {}
  uint32_t add(mpm::Vec3f p) {
    // +0.f turns -0 into 0, so the two zeros join
    p = {p.x + 0.f, p.y + 0.f, p.z + 0.f};
    Key key;
    std::memcpy(key.bits, &p.x, sizeof(float));
    std::memcpy(key.bits + 1, &p.y, sizeof(float));
    std::memcpy(key.bits + 2, &p.z, sizeof(float));
    const auto found = index_.find(key);
    if (found != index_.end()) return found->second;
    const uint32_t index = static_cast<uint32_t>(mesh_.vertices.size());
    mesh_.vertices.push_back(p);
    index_.emplace(key, index);
    return index;
  }

 private:
  struct Key {
    uint32_t bits[3];
    bool operator==(const Key& o) const { return bits[0] == o.bits[0] && bits[1] == o.bits[1] && bits[2] == o.bits[2]; }
  };
  struct KeyHash {
    size_t operator()(const Key& k) const {
      uint64_t h = 1469598103934665603ull;  // FNV-1a over the three words
      for (uint32_t b : k.bits) h = (h ^ b) * 1099511628211ull;
      return static_cast<size_t>(h);
    }
  };
  mpm::TriangleMesh& mesh_;
  std::unordered_map<Key, uint32_t, KeyHash> index_;
};

void appendNode(const aiScene& scene, const aiNode& node, const aiMatrix4x4& parent, float scale,
                VertexWelder& welder, mpm::TriangleMesh& out) {
  const aiMatrix4x4 transform = parent * node.mTransformation;
  // a mirroring transform turns counter-clockwise into clockwise: swap two corners back
  const bool mirrored = transform.Determinant() < 0;
  for (unsigned m = 0; m < node.mNumMeshes; ++m) {
    const aiMesh& mesh = *scene.mMeshes[node.mMeshes[m]];
    std::vector<uint32_t> welded(mesh.mNumVertices);
    for (unsigned v = 0; v < mesh.mNumVertices; ++v) {
      const aiVector3D p = transform * mesh.mVertices[v];
      welded[v] = welder.add({scale * p.x, scale * p.y, scale * p.z});
    }
    for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
      const aiFace& face = mesh.mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines have no inside
      const uint32_t a = welded[face.mIndices[0]];
      const uint32_t b = welded[face.mIndices[mirrored ? 2 : 1]];
      const uint32_t c = welded[face.mIndices[mirrored ? 1 : 2]];
      out.indices.insert(out.indices.end(), {a, b, c});
    }
  }
  for (unsigned child = 0; child < node.mNumChildren; ++child)
    appendNode(scene, *node.mChildren[child], transform, scale, welder, out);
}

// What assimp's reader made is validated (ValidateDataStructure) and checked here
// (checkFaces) before any post-processing step: its readers pass on what a file says, and
// its steps trust it. fuzz_mesh_import found a PLY face naming vertex 100000000 of 3 (the
// steps read past the vertex array: a segmentation fault) and PLY faces of no vertices
// (Triangulate's assertion aborted the program); such files are refused with the reason.
constexpr unsigned kReadSteps = aiProcess_ValidateDataStructure;
constexpr unsigned kPostSteps =
    aiProcess_RemoveComponent | aiProcess_Triangulate | aiProcess_JoinIdenticalVertices | aiProcess_SortByPType;

void checkScale(float scale) {
  if (!std::isfinite(scale) || !(scale > 0.f))
    throw mpm::InvalidArgument("scale", show(scale), "must be a finite number > 0");
}

void configure(Assimp::Importer& importer) {
  // drop everything but positions before joining, so vertices that differ only in normal
  // or texture coordinate (every corner of an STL box) join too
  importer.SetPropertyInteger(AI_CONFIG_PP_RVC_FLAGS,
                              aiComponent_NORMALS | aiComponent_TANGENTS_AND_BITANGENTS | aiComponent_COLORS |
                                  aiComponent_TEXCOORDS | aiComponent_BONEWEIGHTS | aiComponent_ANIMATIONS |
                                  aiComponent_TEXTURES | aiComponent_LIGHTS | aiComponent_CAMERAS);
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
}

/// The read scene post-processed (kPostSteps) once its faces are checked: a face of no
/// vertices is refused (assimp validates it only when the reader set the mesh's primitive
/// types). Null when reading failed (collectTriangles says why).
const aiScene* postProcessed(Assimp::Importer& importer, const aiScene* scene, const std::string& what) {
  if (scene == nullptr) return nullptr;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m)
    for (unsigned f = 0; f < scene->mMeshes[m]->mNumFaces; ++f)
      if (scene->mMeshes[m]->mFaces[f].mNumIndices == 0)
        throw mpm::Error("loadTriangleMesh: " + what + ": face " + std::to_string(f) + " of mesh " + std::to_string(m) +
                         " has no vertices");
  return importer.ApplyPostProcessing(kPostSteps);
}

/// The triangles of what assimp read (`scene`, null when it failed), welded and scaled;
/// `what` names the source in errors.
mpm::TriangleMesh collectTriangles(const Assimp::Importer& importer, const aiScene* scene, const std::string& what,
                                   float scale) {
  if (scene == nullptr || scene->mRootNode == nullptr)
    throw mpm::Error("loadTriangleMesh: cannot read " + what + ": " + importer.GetErrorString());
  if ((scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE) != 0)
    throw mpm::Error("loadTriangleMesh: " + what + " was read only in part: " + importer.GetErrorString());
  mpm::TriangleMesh mesh;
  VertexWelder welder(mesh);
  appendNode(*scene, *scene->mRootNode, aiMatrix4x4(), scale, welder, mesh);
  if (mesh.indices.empty()) throw mpm::Error("loadTriangleMesh: " + what + " holds no triangles");
  for (const mpm::Vec3f& v : mesh.vertices)
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
      throw mpm::Error("loadTriangleMesh: " + what + " has a vertex that is not a finite number");
  return mesh;
}

/// An assimp file system with no files in it: reading from memory, the bytes given are the
/// whole input, and nothing else on the disk is read on their say.
class NoFiles : public Assimp::IOSystem {
 public:
  bool Exists(const char*) const override { return false; }
  char getOsSeparator() const override { return '/'; }
  Assimp::IOStream* Open(const char*, const char*) override { return nullptr; }
  void Close(Assimp::IOStream*) override {}
};

// ------------------------------------------------------------------ Bullet shapes

void validateForBullet(const mpm::TriangleMesh& mesh, float margin) {
  if (mesh.triangleCount() == 0 || mesh.indices.size() % 3 != 0)
    throw mpm::InvalidArgument("TriangleMesh.indices", std::to_string(mesh.indices.size()) + " indices",
                               "a shape needs at least one triangle and three indices per triangle");
  for (size_t i = 0; i < mesh.indices.size(); ++i)
    if (mesh.indices[i] >= mesh.vertices.size())
      throw mpm::InvalidArgument("TriangleMesh.indices[" + std::to_string(i) + "]", std::to_string(mesh.indices[i]),
                                 "must be < the vertex count " + std::to_string(mesh.vertices.size()));
  if (mesh.vertices.size() > size_t(std::numeric_limits<int>::max()) ||
      mesh.indices.size() > size_t(std::numeric_limits<int>::max()))
    throw mpm::InvalidArgument("TriangleMesh.vertices", std::to_string(mesh.vertices.size()) + " vertices",
                               "too many for Bullet's int indices");
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    const mpm::Vec3f v = mesh.vertices[i];
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
      throw mpm::InvalidArgument("TriangleMesh.vertices[" + std::to_string(i) + "]",
                                 "(" + show(v.x) + ", " + show(v.y) + ", " + show(v.z) + ")",
                                 "every component must be a finite number");
  }
  if (!std::isfinite(margin) || margin < 0.f)
    throw mpm::InvalidArgument("margin", show(margin), "must be a finite number >= 0");
}

/// A btStridingMeshInterface that owns its triangles: copies of the mesh's vertices and
/// indices, which the base class's btIndexedMesh points into. The vectors are filled once
/// and never resized, so those pointers stay valid for the object's life.
class OwnedTriangleArray : public btTriangleIndexVertexArray {
 public:
  explicit OwnedTriangleArray(const mpm::TriangleMesh& mesh) {
    vertices_.reserve(3 * mesh.vertices.size());
    for (const mpm::Vec3f& v : mesh.vertices) vertices_.insert(vertices_.end(), {btScalar(v.x), btScalar(v.y), btScalar(v.z)});
    indices_.assign(mesh.indices.begin(), mesh.indices.end());
    btIndexedMesh part;
    part.m_numTriangles = static_cast<int>(mesh.triangleCount());
    part.m_triangleIndexBase = reinterpret_cast<const unsigned char*>(indices_.data());
    part.m_triangleIndexStride = 3 * sizeof(int);
    part.m_numVertices = static_cast<int>(mesh.vertices.size());
    part.m_vertexBase = reinterpret_cast<const unsigned char*>(vertices_.data());
    part.m_vertexStride = 3 * sizeof(btScalar);  // m_vertexType defaults to btScalar's type
    addIndexedMesh(part, PHY_INTEGER);
  }
  OwnedTriangleArray(const OwnedTriangleArray&) = delete;
  OwnedTriangleArray& operator=(const OwnedTriangleArray&) = delete;

 private:
  std::vector<btScalar> vertices_;
  std::vector<int> indices_;
};

// Base-from-member: a base listed before the Bullet shape is built before it and destroyed
// after it, so the triangle data outlives everything the shape does with it.
struct OwnedTriangleArrayHolder {
  std::unique_ptr<OwnedTriangleArray> triangles;
};

class OwningBvhTriangleMeshShape : private OwnedTriangleArrayHolder, public btBvhTriangleMeshShape {
 public:
  explicit OwningBvhTriangleMeshShape(std::unique_ptr<OwnedTriangleArray> data)
      : OwnedTriangleArrayHolder{std::move(data)},
        btBvhTriangleMeshShape(triangles.get(), /*useQuantizedAabbCompression=*/true, /*buildBvh=*/true) {}
};

class OwningGImpactMeshShape : private OwnedTriangleArrayHolder, public btGImpactMeshShape {
 public:
  explicit OwningGImpactMeshShape(std::unique_ptr<OwnedTriangleArray> data)
      : OwnedTriangleArrayHolder{std::move(data)}, btGImpactMeshShape(triangles.get()) {}
};

}  // namespace

mpm::TriangleMesh loadTriangleMesh(const std::string& path, float scale) {
  checkScale(scale);
  {
    std::ifstream in(path, std::ios::binary);
    const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const size_t dot = path.find_last_of('.'), slash = path.find_last_of("/\\");
    const bool dotted = dot != std::string::npos && (slash == std::string::npos || dot > slash);
    if (in || !bytes.empty()) detail::checkBeforeAssimp(bytes.data(), bytes.size(), dotted ? path.substr(dot + 1) : "", "'" + path + "'");
  }
  Assimp::Importer importer;
  configure(importer);
  const std::string what = "'" + path + "'";
  const aiScene* scene = postProcessed(importer, importer.ReadFile(path, kReadSteps), what);
  return collectTriangles(importer, scene, what, scale);
}

mpm::TriangleMesh loadTriangleMeshFromMemory(const void* data, size_t size, const std::string& formatHint,
                                             float scale, const std::string& name) {
  checkScale(scale);
  if (data == nullptr) throw mpm::InvalidArgument("data", "NULL", "must point to the file's bytes");
  if (size == 0) throw mpm::InvalidArgument("size", "0", "a mesh file is not empty");
  Assimp::Importer importer;
  // assimp picks the reader from the name's extension: a hint that names none, or a path,
  // would make it guess from the bytes or look elsewhere
  if (formatHint.empty() || formatHint.size() > 16 ||
      formatHint.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789") !=
          std::string::npos ||
      !importer.IsExtensionSupported("." + formatHint))
    throw mpm::InvalidArgument("formatHint", "'" + formatHint + "'",
                               "must be the extension of a mesh format assimp reads (obj, stl, ply, gltf, glb, ...)");
  const std::string what = name + " (" + formatHint + ")";
  detail::checkBeforeAssimp(static_cast<const uint8_t*>(data), size, formatHint, what);
  configure(importer);
  // the bytes are the whole file: a reference to another file finds nothing
  importer.SetIOHandler(new NoFiles);
  const aiScene* scene =
      postProcessed(importer, importer.ReadFileFromMemory(data, size, kReadSteps, formatHint.c_str()), what);
  return collectTriangles(importer, scene, what, scale);
}

std::unique_ptr<btCollisionShape> makeBvhTriangleMeshShape(const mpm::TriangleMesh& mesh, float margin) {
  validateForBullet(mesh, margin);
  auto shape = std::make_unique<OwningBvhTriangleMeshShape>(std::make_unique<OwnedTriangleArray>(mesh));
  shape->setMargin(margin);
  return shape;
}

std::unique_ptr<btCollisionShape> makeConvexHullShape(const mpm::TriangleMesh& mesh, float margin) {
  validateForBullet(mesh, margin);
  // only the vertices the triangles use
  std::vector<char> used(mesh.vertices.size(), 0);
  for (uint32_t index : mesh.indices) used[index] = 1;
  auto shape = std::make_unique<btConvexHullShape>();
  for (size_t i = 0; i < mesh.vertices.size(); ++i)
    if (used[i]) {
      const mpm::Vec3f v = mesh.vertices[i];
      shape->addPoint(btVector3(v.x, v.y, v.z), /*recalculateLocalAabb=*/false);
    }
  shape->optimizeConvexHull();
  shape->setMargin(margin);
  // the cached local box includes the margin: recompute it after changing the margin
  shape->recalcLocalAabb();
  return shape;
}

std::unique_ptr<btCollisionShape> makeGImpactMeshShape(const mpm::TriangleMesh& mesh, float margin) {
  validateForBullet(mesh, margin);
  auto shape = std::make_unique<OwningGImpactMeshShape>(std::make_unique<OwnedTriangleArray>(mesh));
  shape->setMargin(margin);
  shape->updateBound();
  return shape;
}

}  // namespace mpm::bullet
