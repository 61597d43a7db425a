// Mesh files through assimp (mpm_bullet/mesh_import.h) and the Bullet shapes built from
// them. Assets come from the repository's assets/ folder (made by assets/generate_assets.py, whose
// summary lists the counts and bounds checked here).
#include <gtest/gtest.h>

#include "test_paths.h"

#include <BulletCollision/CollisionDispatch/btCollisionObject.h>
#include <BulletCollision/CollisionDispatch/btCollisionWorld.h>
#include <BulletCollision/CollisionShapes/btBvhTriangleMeshShape.h>
#include <BulletCollision/CollisionShapes/btConvexHullShape.h>
#include <BulletCollision/Gimpact/btGImpactShape.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "mpm/error.h"
#include "mpm/sdf_grid.h"
#include "mpm_bullet/mesh_import.h"

namespace mpm::bullet {
namespace {

using mpm::TriangleMesh;
using mpm::Vec3f;

constexpr float kSphereRadius = 0.05f;  // [m]

using mpm::test::assetPath;

std::string tempPath(const std::string& name) { return ::testing::TempDir() + "mpm_mesh_import_" + name; }

struct Bounds {
  Vec3f lo, hi;
};
Bounds boundsOf(const TriangleMesh& mesh) {
  Bounds b{mesh.vertices.at(0), mesh.vertices.at(0)};
  for (const Vec3f& v : mesh.vertices)
    for (int a = 0; a < 3; ++a) {
      b.lo[a] = std::min(b.lo[a], v[a]);
      b.hi[a] = std::max(b.hi[a], v[a]);
    }
  return b;
}

void expectBounds(const TriangleMesh& mesh, Vec3f lo, Vec3f hi, float tolerance = 1e-6f) {
  const Bounds b = boundsOf(mesh);
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(b.lo[a], lo[a], tolerance) << "axis " << a;
    EXPECT_NEAR(b.hi[a], hi[a], tolerance) << "axis " << a;
  }
}

// Outward winding: the signed volume of a closed outward mesh is positive.
double signedVolume(const TriangleMesh& mesh) {
  double volume = 0;
  for (size_t t = 0; t < mesh.triangleCount(); ++t) {
    const Vec3f a = mesh.vertices[mesh.indices[3 * t]], b = mesh.vertices[mesh.indices[3 * t + 1]],
                c = mesh.vertices[mesh.indices[3 * t + 2]];
    volume += dot(a, cross(b, c)) / 6.0;
  }
  return volume;
}

// ---------------------------------------------------------------- one file per format

TEST(MeshImport, ObjSphere) {
  const TriangleMesh mesh = loadTriangleMesh(assetPath("sphere.obj"));
  EXPECT_EQ(mesh.vertices.size(), 642u);
  EXPECT_EQ(mesh.triangleCount(), 1280u);
  expectBounds(mesh, {-0.05f, -0.05f, -0.05f}, {0.05f, 0.05f, 0.05f});
  EXPECT_TRUE(mpm::checkWatertight(mesh).watertight) << mpm::checkWatertight(mesh).reason;
  for (const Vec3f& v : mesh.vertices) ASSERT_NEAR(norm(v), kSphereRadius, 1e-6f);
  EXPECT_GT(signedVolume(mesh), 0.0);
}

TEST(MeshImport, StlSlab) {
  // an STL repeats every corner per facet, each with its facet's normal: joined to 8
  const TriangleMesh mesh = loadTriangleMesh(assetPath("tissue_slab.stl"));
  EXPECT_EQ(mesh.vertices.size(), 8u);
  EXPECT_EQ(mesh.triangleCount(), 12u);
  expectBounds(mesh, {-0.1f, -0.02f, -0.1f}, {0.1f, 0.02f, 0.1f});
  EXPECT_TRUE(mpm::checkWatertight(mesh).watertight) << mpm::checkWatertight(mesh).reason;
  EXPECT_NEAR(signedVolume(mesh), 0.2 * 0.04 * 0.2, 1e-9);
}

TEST(MeshImport, GltfBox) {
  const TriangleMesh mesh = loadTriangleMesh(assetPath("box.gltf"));
  EXPECT_EQ(mesh.vertices.size(), 8u);
  EXPECT_EQ(mesh.triangleCount(), 12u);
  expectBounds(mesh, {-0.05f, -0.05f, -0.05f}, {0.05f, 0.05f, 0.05f});
  EXPECT_TRUE(mpm::checkWatertight(mesh).watertight) << mpm::checkWatertight(mesh).reason;
  EXPECT_NEAR(signedVolume(mesh), 0.1 * 0.1 * 0.1, 1e-9);
}

TEST(MeshImport, PlyOpenBowl) {
  const TriangleMesh mesh = loadTriangleMesh(assetPath("bowl_open.ply"));
  EXPECT_EQ(mesh.vertices.size(), 193u);
  EXPECT_EQ(mesh.triangleCount(), 360u);
  expectBounds(mesh, {-0.05f, -0.05f, -0.05f}, {0.05f, 0.f, 0.05f});
  const mpm::WatertightReport report = mpm::checkWatertight(mesh);
  EXPECT_FALSE(report.watertight);
  EXPECT_EQ(report.boundaryEdges, 24u);
}

TEST(MeshImport, ObjScalpel) {
  const TriangleMesh mesh = loadTriangleMesh(assetPath("scalpel.obj"));
  EXPECT_EQ(mesh.vertices.size(), 24u);
  EXPECT_EQ(mesh.triangleCount(), 44u);
  expectBounds(mesh, {0.f, -0.005f, -0.00025f}, {0.04f, 0.003f, 0.00025f});
  EXPECT_TRUE(mpm::checkWatertight(mesh).watertight) << mpm::checkWatertight(mesh).reason;
  EXPECT_GT(signedVolume(mesh), 0.0);
}

TEST(MeshImport, ScaleMultipliesPositions) {
  const TriangleMesh mesh = loadTriangleMesh(assetPath("box.gltf"), 1000.f);  // as if it were in mm
  expectBounds(mesh, {-50.f, -50.f, -50.f}, {50.f, 50.f, 50.f}, 1e-3f);
  for (float bad : {0.f, -1.f, std::nanf("")}) {
    try {
      loadTriangleMesh(assetPath("box.gltf"), bad);
      ADD_FAILURE() << "no error for scale " << bad;
    } catch (const mpm::InvalidArgument& e) {
      EXPECT_EQ(e.field(), "scale");
    }
  }
}

// The base64 data URI of box.gltf's buffer: 8 float positions, then 36 uint16 indices.
std::string boxBufferUri() {
  std::ifstream in(assetPath("box.gltf"));
  const std::string box((std::istreambuf_iterator<char>(in)), {});
  const size_t begin = box.find("data:application/octet-stream;base64,");
  EXPECT_NE(begin, std::string::npos);
  return begin == std::string::npos ? "" : box.substr(begin, box.find('"', begin) - begin);
}

// Two instances of one mesh under two nodes: one moved +1 m along x, one mirrored in x and
// moved -1 m. Both must arrive transformed, merged, and wound outward.
TEST(MeshImport, NodeTransformsAreAppliedAndMerged) {
  const std::string uri = boxBufferUri();
  const std::string gltf = R"({
  "asset": {"version": "2.0"},
  "scene": 0,
  "scenes": [{"nodes": [0]}],
  "nodes": [
    {"children": [1, 2]},
    {"mesh": 0, "translation": [1, 0, 0]},
    {"mesh": 0, "translation": [-1, 0, 0], "scale": [-1, 1, 1]}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "mode": 4}]}],
  "buffers": [{"byteLength": 168, "uri": ")" + uri + R"("}],
  "bufferViews": [
    {"buffer": 0, "byteOffset": 0, "byteLength": 96, "target": 34962},
    {"buffer": 0, "byteOffset": 96, "byteLength": 72, "target": 34963}],
  "accessors": [
    {"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3",
     "min": [-0.05, -0.05, -0.05], "max": [0.05, 0.05, 0.05]},
    {"bufferView": 1, "componentType": 5123, "count": 36, "type": "SCALAR"}]
})";
  const std::string path = tempPath("two_boxes.gltf");
  std::ofstream(path) << gltf;
  const TriangleMesh mesh = loadTriangleMesh(path);
  EXPECT_EQ(mesh.vertices.size(), 16u);
  EXPECT_EQ(mesh.triangleCount(), 24u);
  expectBounds(mesh, {-1.05f, -0.05f, -0.05f}, {1.05f, 0.05f, 0.05f});
  EXPECT_TRUE(mpm::checkWatertight(mesh).watertight) << mpm::checkWatertight(mesh).reason;
  // both boxes outward: twice 0.1^3 (an inside-out mirrored box would cancel the other)
  EXPECT_NEAR(signedVolume(mesh), 2 * 0.001, 1e-8);
  std::remove(path.c_str());
}

// The box as two primitives of six triangles each: assimp makes two meshes, whose shared
// corners must be joined across them for the box to come back closed.
TEST(MeshImport, VerticesJoinAcrossMeshes) {
  const std::string gltf = R"({
  "asset": {"version": "2.0"},
  "scene": 0,
  "scenes": [{"nodes": [0]}],
  "nodes": [{"mesh": 0}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "mode": 4},
                             {"attributes": {"POSITION": 0}, "indices": 2, "mode": 4}]}],
  "buffers": [{"byteLength": 168, "uri": ")" + boxBufferUri() + R"("}],
  "bufferViews": [
    {"buffer": 0, "byteOffset": 0, "byteLength": 96, "target": 34962},
    {"buffer": 0, "byteOffset": 96, "byteLength": 72, "target": 34963}],
  "accessors": [
    {"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3",
     "min": [-0.05, -0.05, -0.05], "max": [0.05, 0.05, 0.05]},
    {"bufferView": 1, "byteOffset": 0, "componentType": 5123, "count": 18, "type": "SCALAR"},
    {"bufferView": 1, "byteOffset": 36, "componentType": 5123, "count": 18, "type": "SCALAR"}]
})";
  const std::string path = tempPath("split_box.gltf");
  std::ofstream(path) << gltf;
  const TriangleMesh mesh = loadTriangleMesh(path);
  EXPECT_EQ(mesh.vertices.size(), 8u);
  EXPECT_EQ(mesh.triangleCount(), 12u);
  EXPECT_TRUE(mpm::checkWatertight(mesh).watertight) << mpm::checkWatertight(mesh).reason;
  std::remove(path.c_str());
}

TEST(MeshImport, MissingFileNamesThePath) {
  const std::string path = tempPath("no_such_mesh.obj");
  try {
    loadTriangleMesh(path);
    ADD_FAILURE() << "no error for a missing file";
  } catch (const mpm::Error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

TEST(MeshImport, FileWithoutTrianglesIsAnError) {
  const std::string points = tempPath("points_only.obj");
  std::ofstream(points) << "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  EXPECT_THROW(loadTriangleMesh(points), mpm::Error);
  const std::string garbage = tempPath("garbage.stl");
  std::ofstream(garbage) << "this is not a mesh";
  try {
    loadTriangleMesh(garbage);
    ADD_FAILURE() << "no error for garbage";
  } catch (const mpm::Error& e) {
    EXPECT_NE(std::string(e.what()).find(garbage), std::string::npos) << e.what();
  }
  std::remove(points.c_str());
  std::remove(garbage.c_str());
}

// ---------------------------------------------------------------- from memory

std::string fileBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

TEST(MeshImport, FromMemoryGivesWhatTheFileGives) {
  for (const char* name : {"sphere.obj", "tissue_slab.stl", "bowl_open.ply", "box.gltf", "scalpel.obj"}) {
    const std::string path = assetPath(name), bytes = fileBytes(path);
    const std::string hint = std::string(name).substr(std::string(name).rfind('.') + 1);
    const TriangleMesh fromFile = loadTriangleMesh(path, 2.f);
    const TriangleMesh fromMemory = loadTriangleMeshFromMemory(bytes.data(), bytes.size(), hint, 2.f);
    EXPECT_EQ(fromMemory.indices, fromFile.indices) << name;
    ASSERT_EQ(fromMemory.vertices.size(), fromFile.vertices.size()) << name;
    for (size_t i = 0; i < fromFile.vertices.size(); ++i)
      for (int a = 0; a < 3; ++a) ASSERT_EQ(fromMemory.vertices[i][a], fromFile.vertices[i][a]) << name << " vertex " << i;
  }
}

TEST(MeshImport, FromMemoryNamesWhatIsWrong) {
  const std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  EXPECT_EQ(loadTriangleMeshFromMemory(obj.data(), obj.size(), "obj").triangleCount(), 1u);
  auto message = [&](const void* data, size_t size, const std::string& hint) -> std::string {
    try {
      loadTriangleMeshFromMemory(data, size, hint, 1.f, "the test's bytes");
    } catch (const mpm::Error& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_NE(message(nullptr, 5, "obj").find("data"), std::string::npos);
  EXPECT_NE(message(obj.data(), 0, "obj").find("size"), std::string::npos);
  for (const char* hint : {"", "xyz", ".obj", "../obj", "a/b.obj"})
    EXPECT_NE(message(obj.data(), obj.size(), hint).find("formatHint = '" + std::string(hint) + "'"), std::string::npos)
        << hint << ": " << message(obj.data(), obj.size(), hint);
  const std::string garbage = "this is not a mesh";
  EXPECT_NE(message(garbage.data(), garbage.size(), "stl").find("the test's bytes (stl)"), std::string::npos)
      << message(garbage.data(), garbage.size(), "stl");
  // a .gltf whose buffer is another file: not read from memory (nothing is looked up on disk)
  const std::string gltf = fileBytes(assetPath("box.gltf"));
  const size_t uri = gltf.find("data:"), uriEnd = gltf.find('"', uri);
  ASSERT_NE(uri, std::string::npos);
  const std::string external = gltf.substr(0, uri) + "box.bin" + gltf.substr(uriEnd);
  EXPECT_NE(message(external.data(), external.size(), "gltf").find("the test's bytes (gltf)"), std::string::npos)
      << message(external.data(), external.size(), "gltf");
}

// fuzz_mesh_import found it: a PLY face naming a vertex the file does not have went through
// assimp's reader into its post-processing, which read past the vertex array (a segmentation
// fault); now refused with assimp's validation, from a file and from memory alike
TEST(MeshImport, FaceIndexOutOfRangeIsRefused) {
  const std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 100000000\n";
  const std::string path = tempPath("face_index_out_of_range.ply");
  std::ofstream(path) << ply;
  for (int fromMemory = 0; fromMemory < 2; ++fromMemory) {
    try {
      if (fromMemory) loadTriangleMeshFromMemory(ply.data(), ply.size(), "ply");
      else loadTriangleMesh(path);
      ADD_FAILURE() << "a face index beyond the vertices was taken";
    } catch (const mpm::Error& e) {
      EXPECT_NE(std::string(e.what()).find("out of range"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(fromMemory ? "memory (ply)" : path), std::string::npos) << e.what();
    }
  }
  std::remove(path.c_str());
}

// fuzz_mesh_import found it: assimp's binary PLY reader reads a face's vertices as its count
// byte promises (191 where the file had 3), past the end of the file (a segmentation
// fault). The body is now walked by the header first and a file that ends early is refused
// naming the element; the fuzzer's input (its format byte first) and a small one
TEST(MeshImport, BinaryPlyEndingEarlyIsRefused) {
  const std::string found = fileBytes(mpm::test::sourcePath("tests/fuzz/corpus/mesh/regress-ply-list-past-the-end"));
  ASSERT_GT(found.size(), 1u);
  std::string small =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const float corners[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const int32_t face[3] = {0, 1, 2};
  small.append(reinterpret_cast<const char*>(corners), sizeof corners);
  small.push_back(char(200));  // 200 vertices promised, 3 given
  small.append(reinterpret_cast<const char*>(face), sizeof face);
  const std::string path = tempPath("ply_ending_early.ply");
  std::ofstream(path, std::ios::binary) << small;
  auto message = [](auto load) -> std::string {
    try {
      load();
    } catch (const mpm::Error& e) {
      return e.what();
    }
    return "no error";
  };
  const std::string fromFound = message([&] { loadTriangleMeshFromMemory(found.data() + 1, found.size() - 1, "ply"); });
  EXPECT_NE(fromFound.find("PLY header line 11 'end_headerSt9exception': not a header line"), std::string::npos)
      << fromFound;
  for (const std::string& m : {message([&] { loadTriangleMeshFromMemory(small.data(), small.size(), "ply"); }),
                               message([&] { loadTriangleMesh(path); })})
    EXPECT_NE(m.find("PLY element 'face' 0 of 1: the file ends inside it (12 bytes left, 800 needed)"), std::string::npos)
        << m;
  // found next: a header cut off in a comment, binary bytes after it (assimp's reader read
  // past the end: a segmentation fault)
  const std::string cut = small.substr(0, small.find("element vertex")) + "comment cut off";
  const std::string noEnd = message([&] { loadTriangleMeshFromMemory(cut.data(), cut.size(), "ply"); });
  EXPECT_NE(noEnd.find("PLY header: no 'end_header' line (the file ends at header line 3)"), std::string::npos) << noEnd;
  // and a format that is none of PLY's (read as if it were one: a segmentation fault)
  std::string otherFormat = small;
  otherFormat.replace(otherFormat.find("binary_little_endian"), 20, "binary_li");
  const std::string badFormat =
      message([&] { loadTriangleMeshFromMemory(otherFormat.data(), otherFormat.size(), "ply"); });
  EXPECT_NE(badFormat.find("PLY header line 2 'format binary_li 1.0': the format is none of"), std::string::npos)
      << badFormat;
  small.replace(small.size() - 13, 1, 1, char(3));  // the face as promised: read
  EXPECT_EQ(loadTriangleMeshFromMemory(small.data(), small.size(), "ply").triangleCount(), 1u);
  std::remove(path.c_str());
}

// fuzz_mesh_import found it: a value of an ASCII PLY that is no number ("0.0433M->2194")
// threw from inside assimp's reader, which leaked the mesh it was filling (LeakSanitizer).
// The body is now checked first, one line per item and one number per value, and such a
// file refused naming the element, the line and the value
TEST(MeshImport, AsciiPlyValueThatIsNoNumberIsRefused) {
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  auto message = [&](const std::string& body) -> std::string {
    const std::string file = header + body;
    try {
      return std::to_string(loadTriangleMeshFromMemory(file.data(), file.size(), "ply").triangleCount()) + " triangles";
    } catch (const mpm::Error& e) {
      return e.what();
    }
  };
  EXPECT_EQ(message("0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"), "1 triangles");
  // found next: "plyply" for the first line, which assimp's reader takes for a PLY's
  {
    const std::string file = "ply" + header + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    try {
      loadTriangleMeshFromMemory(file.data(), file.size(), "ply");
      ADD_FAILURE() << "a PLY whose first line is plyply was read";
    } catch (const mpm::Error& e) {
      EXPECT_NE(std::string(e.what()).find("PLY header line 1 'plyply': not a header line"), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(message("0 0 0\r\n1.5e-1 0 0\r\n-.5 +1 0\r\n3 0 1 2\r\n"), "1 triangles");
  const std::pair<const char*, const char*> bad[] = {
      {"0 0 0\n1x 0 0\n0 1 0\n3 0 1 2\n", "element 'vertex' 1 of 3 (body line 2): '1x' is no number"},
      {"0 0 0\n1 0\n0 1 0\n3 0 1 2\n", "element 'vertex' 1 of 3 (body line 2): '' is no number (the line ends)"},
      {"0 0 0\n1 0 0 7\n0 1 0\n3 0 1 2\n", "element 'vertex' 1 of 3 (body line 2): 1 values more"},
      {"0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n", "element 'face' 0 of 1 (body line 4): '1.5' is no integer"},
      {"0 0 0\n1 0 0\n0 1 0\n-3 0 1 2\n", "element 'face' 0 of 1 (body line 4): '-3' is no list length"},
      {"0 0 0\n1 0 0\n0 1 0\n", "element 'face' 0 of 1: the file ends before it"}};
  for (const auto& b : bad) EXPECT_NE(message(b.first).find(b.second), std::string::npos) << message(b.first);
}

// fuzz_mesh_import found it: PLY faces of no vertices (a binary file's count byte 0) reached
// assimp's Triangulate step, whose assertion aborted the program; the read scene's faces are
// now checked before any post-processing step, from a file and from memory
TEST(MeshImport, FaceWithoutVerticesIsRefused) {
  const std::string ply =
      "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n"
      "3 0 1 2\n0\n";
  const std::string path = tempPath("face_without_vertices.ply");
  std::ofstream(path) << ply;
  for (int fromMemory = 0; fromMemory < 2; ++fromMemory) {
    try {
      if (fromMemory) loadTriangleMeshFromMemory(ply.data(), ply.size(), "ply");
      else loadTriangleMesh(path);
      ADD_FAILURE() << "a face of no vertices was taken";
    } catch (const mpm::Error& e) {
      EXPECT_NE(std::string(e.what()).find("face 1 of mesh 0 has no vertices"), std::string::npos) << e.what();
    }
  }
  std::remove(path.c_str());
}

// fuzz_mesh_import found it: "vertex 0.1pmx -0.02 -0.1" in an ASCII STL threw from inside
// assimp's reader, which leaked the mesh and node it was filling (LeakSanitizer), and so did
// a facet of two vertices; the file is now walked by STL's grammar first and refused naming
// the line
TEST(MeshImport, AsciiStlOffItsGrammarIsRefused) {
  const std::string good = fileBytes(assetPath("tissue_slab.stl"));
  const size_t at = good.find("vertex 0.1 -0.02 -0.1");
  ASSERT_NE(at, std::string::npos);
  std::string bad = good;
  bad.replace(at, 10, "vertex 0.1pmx");
  const int line = 1 + (int)std::count(good.begin(), good.begin() + at, '\n');
  const std::string path = tempPath("value_no_number.stl");
  std::ofstream(path, std::ios::binary) << bad;
  for (int fromMemory = 0; fromMemory < 2; ++fromMemory) {
    try {
      if (fromMemory) loadTriangleMeshFromMemory(bad.data(), bad.size(), "stl");
      else loadTriangleMesh(path);
      ADD_FAILURE() << "a vertex that is no number was taken";
    } catch (const mpm::Error& e) {
      EXPECT_NE(std::string(e.what()).find("STL line " + std::to_string(line) +
                                           ": a number (1 of 3 after 'vertex', on its line) expected, '0.1pmx' found"),
                std::string::npos)
          << e.what();
    }
  }
  EXPECT_EQ(loadTriangleMeshFromMemory(good.data(), good.size(), "stl").triangleCount(), 12u);
  // found next: a facet of two vertices (assimp threw "Invalid number of vertices" and leaked)
  bad = good;
  bad.replace(at, 6, "vepmx ");
  auto message = [&] {
    try {
      loadTriangleMeshFromMemory(bad.data(), bad.size(), "stl");
    } catch (const mpm::Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message().find("STL line " + std::to_string(line) + ": 'vertex' expected, 'vepmx' found"), std::string::npos)
      << message();
  // and then a vertex's third number on the next line: assimp's reader does not look there
  bad = good;
  bad.replace(at + 16, 1, "\n");
  EXPECT_NE(message().find("STL line " + std::to_string(line + 1) + ": a number (3 of 3 after 'vertex', on its line) "
                           "expected, '-0.1' found"),
            std::string::npos)
      << message();
  // and then the same read through the hint "glb": assimp's glTF reader does not recognise
  // it and assimp tries every reader, the STL one among them
  const std::string glb = message();
  EXPECT_NE(glb.find("STL line"), std::string::npos) << glb;
  try {
    loadTriangleMeshFromMemory(bad.data(), bad.size(), "glb");
    ADD_FAILURE() << "an STL off its grammar was read as glb";
  } catch (const mpm::Error& e) {
    EXPECT_EQ(std::string(e.what()), glb.substr(0, glb.find(" (stl)")) + " (glb)" + glb.substr(glb.find(" (stl)") + 6));
  }
  // and then NUL bytes inside a vertex: assimp's reader took the first for the end
  bad = good;
  bad.replace(at + 12, 4, std::string(4, '\0'));
  EXPECT_NE(message().find("a NUL byte at byte " + std::to_string(at + 12) + " of an ASCII STL file"), std::string::npos)
      << message();
  bad = "solid s\n  facet normal 0 0 1\n    outer loop\n      vertex 0 0 0\n      vertex 1 0 0\n      vertex 0 1 0\n"
        "    endloop\n  endfacet\nendsolid s\n";
  EXPECT_EQ(loadTriangleMeshFromMemory(bad.data(), bad.size(), "stl").triangleCount(), 1u);
  bad.replace(bad.find("facet normal 0 0 1"), 18, "facet");
  EXPECT_NE(message().find("STL line 3: 'normal' expected, 'outer' found"), std::string::npos) << message();
  // and then "solid#name": assimp takes any word that begins with "solid" for the keyword
  bad = good;
  bad.replace(bad.find("solid ") + 5, 1, "#");
  bad.replace(at, 6, "vepmx ");
  EXPECT_NE(message().find("STL line " + std::to_string(line) + ": 'vertex' expected, 'vepmx' found"), std::string::npos)
      << message();
  std::remove(path.c_str());
}

// fuzz_mesh_import found it: a character that is no base64 in a .gltf's data URI threw from
// inside assimp's decoder, which leaked the buffer it was filling (LeakSanitizer); data URIs
// are now checked first and the file refused naming where
TEST(MeshImport, GltfDataUriThatIsNoBase64IsRefused) {
  const std::string good = fileBytes(assetPath("box.gltf"));
  const size_t uri = good.find(";base64,") + 8;
  ASSERT_NE(uri, std::string::npos + 8);
  std::string bad = good;
  bad[uri + 100] = char(0xbe);
  const std::string path = tempPath("data_uri_no_base64.gltf");
  std::ofstream(path, std::ios::binary) << bad;
  for (int fromMemory = 0; fromMemory < 2; ++fromMemory) {
    try {
      if (fromMemory) loadTriangleMeshFromMemory(bad.data(), bad.size(), "gltf");
      else loadTriangleMesh(path);
      ADD_FAILURE() << "a data URI that is no base64 was taken";
    } catch (const mpm::Error& e) {
      EXPECT_NE(std::string(e.what()).find("the base64 data URI at byte " + std::to_string(uri) + " holds '?' at byte " +
                                           std::to_string(uri + 100) + ", no base64 character"),
                std::string::npos)
          << e.what();
    }
  }
  bad = good;
  bad.erase(uri + 100, 1);
  try {
    loadTriangleMeshFromMemory(bad.data(), bad.size(), "gltf");
    ADD_FAILURE() << "a data URI of a length no multiple of 4 was taken";
  } catch (const mpm::Error& e) {
    EXPECT_NE(std::string(e.what()).find("not a multiple of 4"), std::string::npos) << e.what();
  }
  std::remove(path.c_str());
}

// fuzz_mesh_import found it (in CI, seed 1, after the libraries became PIC): a GLB whose
// primitive is a LINE_LOOP (mode 2) with indices past its vertices crashed assimp's glTF 2
// reader (a read of address 0: segmentation fault); lines hold no triangles, so a primitive
// of mode 2 is refused first, naming the byte, whether the GLB's JSON chunk or a .gltf
// says it, spaced or escaped ("mo\u0064e") as a JSON reader takes it; mode 4 still loads
TEST(MeshImport, GltfLineLoopIsRefused) {
  const std::string crash = fileBytes(mpm::test::sourcePath("tests/fuzz/corpus/mesh/regress-glb-line-loop-index"));
  ASSERT_GT(crash.size(), 100u);
  const std::string glb = crash.substr(1);  // the fuzz input's first byte picks the format (GLB)
  const std::string gltf = fileBytes(assetPath("box.gltf"));
  const std::string triangles = "\"mode\": 4";
  const size_t mode = gltf.find(triangles);
  ASSERT_NE(mode, std::string::npos);
  std::string spaced = gltf, escaped = gltf;
  spaced.replace(mode, triangles.size(), "\"mode\" :  2");
  escaped.replace(mode, triangles.size(), "\"mo\\u0064e\":2");
  const std::pair<std::string, const char*> cases[] = {{glb, "glb"}, {spaced, "gltf"}, {escaped, "gltf"}};
  for (const auto& [bytes, format] : cases) {
    try {
      loadTriangleMeshFromMemory(bytes.data(), bytes.size(), format);
      ADD_FAILURE() << "a LINE_LOOP primitive was taken (" << format << ")";
    } catch (const mpm::Error& e) {
      EXPECT_NE(std::string(e.what()).find("is 2 (LINE_LOOP): lines hold no triangles"), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(loadTriangleMeshFromMemory(gltf.data(), gltf.size(), "gltf").triangleCount(), 12u);
}

// fuzz_mesh_import found them in CI (seed 1; flaky at the 4 GB limit): GLBs whose JSON
// chunk's length ran past the file (3.6e9 bytes claimed in 713) kept assimp 5.2.5 busy 20 s
// and 4 GB. Refused before assimp reads the file: a chunk past the file's end, and a JSON
// string out of place (not after '{', '[', ',' or ':', or not followed by ':', ',', '}' or
// ']', or never closed); the box still loads.
TEST(MeshImport, GltfMalformedJsonIsRefused) {
  auto message = [](const std::string& bytes, const char* format) -> std::string {
    try {
      return std::to_string(loadTriangleMeshFromMemory(bytes.data(), bytes.size(), format).triangleCount()) + " triangles";
    } catch (const mpm::Error& e) {
      return e.what();
    }
  };
  for (const char* input : {"regress-glb-string-out-of-place", "regress-glb-json-chunk-past-the-end"}) {
    const std::string bytes = fileBytes(mpm::test::sourcePath(std::string("tests/fuzz/corpus/mesh/") + input));
    ASSERT_GT(bytes.size(), 100u);
    // the fuzz input's first byte picks the format (GLB)
    EXPECT_NE(message(bytes.substr(1), "glb").find("JSON chunk"), std::string::npos) << input;
  }
  const std::string gltf = fileBytes(assetPath("box.gltf"));
  std::string quoteOutOfStep = gltf, unclosed = gltf;
  quoteOutOfStep.replace(gltf.find("\"asset\""), 1, "");
  unclosed.resize(gltf.find("\"asset\"") + 3);
  for (const std::string& bytes : {quoteOutOfStep, unclosed})
    EXPECT_NE(message(bytes, "gltf").find("the glTF JSON is not valid at byte"), std::string::npos) << message(bytes, "gltf");
  EXPECT_EQ(message(gltf, "gltf"), "12 triangles");
}

// fuzz_mesh_import found it: an OBJ face naming a vertex the file does not have threw from
// inside assimp's reader ("vertex index out of range"), which leaked the mesh it was
// building (LeakSanitizer); every index is now checked first and the file refused naming
// the line
TEST(MeshImport, ObjIndexOutOfRangeIsRefused) {
  auto message = [](const std::string& obj) -> std::string {
    try {
      return std::to_string(loadTriangleMeshFromMemory(obj.data(), obj.size(), "obj").triangleCount()) + " triangles";
    } catch (const mpm::Error& e) {
      return e.what();
    }
  };
  const std::string v = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\n";
  EXPECT_EQ(message(v + "f 1 2 3\n"), "1 triangles");
  EXPECT_EQ(message(v + "f -3//1 -2//1 -1//1\n"), "1 triangles");
  const std::pair<std::string, std::string> bad[] = {
      {v + "f 1 2 4\n", "OBJ line 5: index 4 names no vertex (the file has 3)"},
      {v + "f 1 2 0\n", "OBJ line 5: index 0 in '0' names no vertex"},
      {v + "f 1 2 -4\n", "OBJ line 5: index -4 in '-4' names no vertex"},
      {v + "f 1//1 2//2 3//1\n", "OBJ line 5: index 2 names no normal (the file has 1)"},
      {v + "f 1 2 x\n", "OBJ line 5: 'x' is no vertex reference"},
      // found next: a vertex with a word that is no number, which assimp read a vertex short
      {"v 0 0 0\nv 1 0ase5 0\nv 0 1 0\nf 1 2 3\n", "OBJ line 2: '0ase5' is no number"},
      {"v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "OBJ line 1: 'v' with 2 values (3 to 7)"}};
  for (const auto& b : bad) EXPECT_NE(message(b.first).find(b.second), std::string::npos) << message(b.first);
}

// ---------------------------------------------------------------- Bullet shapes

void expectAabb(const btCollisionShape& shape, const Bounds& b, float padLow, float padHigh, const char* what) {
  btVector3 lo, hi;
  btTransform moved;
  moved.setIdentity();
  moved.setOrigin(btVector3(0.5f, -0.25f, 2.f));
  shape.getAabb(moved, lo, hi);
  const btVector3 offset = moved.getOrigin();
  for (int a = 0; a < 3; ++a) {
    // bounds padded by at least padLow and at most padHigh
    EXPECT_LE(lo[a] - offset[a], b.lo[a] - padLow + 1e-6f) << what << " axis " << a;
    EXPECT_GE(lo[a] - offset[a], b.lo[a] - padHigh - 1e-6f) << what << " axis " << a;
    EXPECT_GE(hi[a] - offset[a], b.hi[a] + padLow - 1e-6f) << what << " axis " << a;
    EXPECT_LE(hi[a] - offset[a], b.hi[a] + padHigh + 1e-6f) << what << " axis " << a;
  }
}

constexpr float kGImpactQuantization = 3.5e-5f;  // [m]

TEST(BulletShapes, AabbMatchesMeshBounds) {
  const TriangleMesh mesh = loadTriangleMesh(assetPath("sphere.obj"));
  const Bounds b = boundsOf(mesh);
  // without a margin, exactly the mesh's bounds
  expectAabb(*makeBvhTriangleMeshShape(mesh, 0.f), b, 0.f, 0.f, "bvh");
  expectAabb(*makeConvexHullShape(mesh, 0.f), b, 0.f, 0.f, "convex hull");
  // GImpact's box tree stores 16-bit quantized boxes over its bounds padded by 1 m, so its
  // root box may exceed the mesh by one step, (0.1 m + 2 m) / 65535 = 3.2e-5 m
  expectAabb(*makeGImpactMeshShape(mesh, 0.f), b, 0.f, kGImpactQuantization, "gimpact");
  // with the default margin, padded by it (Bullet pads a convex hull's box twice)
  const float m = kDefaultMeshMargin;
  expectAabb(*makeBvhTriangleMeshShape(mesh), b, m, m, "bvh, margin");
  expectAabb(*makeConvexHullShape(mesh), b, m, 2 * m, "convex hull, margin");
  expectAabb(*makeGImpactMeshShape(mesh), b, m, m + kGImpactQuantization, "gimpact, margin");
}

TEST(BulletShapes, ShapeTypes) {
  const TriangleMesh mesh = loadTriangleMesh(assetPath("sphere.obj"));
  const auto bvh = makeBvhTriangleMeshShape(mesh);
  const auto hull = makeConvexHullShape(mesh);
  const auto gimpact = makeGImpactMeshShape(mesh);
  EXPECT_EQ(bvh->getShapeType(), TRIANGLE_MESH_SHAPE_PROXYTYPE);
  EXPECT_EQ(hull->getShapeType(), CONVEX_HULL_SHAPE_PROXYTYPE);
  EXPECT_EQ(gimpact->getShapeType(), GIMPACT_SHAPE_PROXYTYPE);
  ASSERT_NE(dynamic_cast<btBvhTriangleMeshShape*>(bvh.get()), nullptr);
  EXPECT_EQ(dynamic_cast<btBvhTriangleMeshShape*>(bvh.get())->getMeshInterface()->getNumSubParts(), 1);
  ASSERT_NE(dynamic_cast<btConvexHullShape*>(hull.get()), nullptr);
  // every icosphere vertex is on the hull
  EXPECT_EQ(dynamic_cast<btConvexHullShape*>(hull.get())->getNumPoints(), 642);
  ASSERT_NE(dynamic_cast<btGImpactMeshShape*>(gimpact.get()), nullptr);
  EXPECT_EQ(bvh->getMargin(), kDefaultMeshMargin);
  EXPECT_EQ(hull->getMargin(), kDefaultMeshMargin);
  EXPECT_EQ(gimpact->getMargin(), kDefaultMeshMargin);
}

// Closest hit of the ray from -> to against `shape` at the origin; fraction 1 when missed.
struct RayHit {
  bool hit = false;
  btVector3 point, normal;
};
RayHit castRay(const btCollisionShape& shape, const btVector3& from, const btVector3& to) {
  btCollisionObject object;
  object.setCollisionShape(const_cast<btCollisionShape*>(&shape));
  btTransform identity;
  identity.setIdentity();
  object.setWorldTransform(identity);
  btTransform fromT(btQuaternion::getIdentity(), from), toT(btQuaternion::getIdentity(), to);
  btCollisionWorld::ClosestRayResultCallback callback(from, to);
  btCollisionWorld::rayTestSingle(fromT, toT, &object, &shape, identity, callback);
  RayHit result;
  result.hit = callback.hasHit();
  result.point = callback.m_hitPointWorld;
  result.normal = callback.m_hitNormalWorld;
  return result;
}

// Rays from 0.2 m away towards random points near the centre hit the icosphere between
// the sphere of radius R and the inner sphere R - sag that its flat faces dip to, with a
// normal within a face's angular size (~6 degrees) of radial. `slack` widens that for
// shapes Bullet ray-casts only approximately.
void expectRaysHitSphere(const btCollisionShape& shape, const char* what, float slack = 0.f) {
  const float sag = 2.3e-4f + slack;  // chordal sag of sphere.obj: R - min face-plane distance, 0.226 mm
  std::mt19937 rng(5);
  std::normal_distribution<float> gauss(0.f, 1.f);
  std::uniform_real_distribution<float> offset(-0.02f, 0.02f);
  for (int n = 0; n < 100; ++n) {
    btVector3 direction(gauss(rng), gauss(rng), gauss(rng));
    direction.normalize();
    const btVector3 target(offset(rng), offset(rng), offset(rng));
    const btVector3 from = target + 0.2f * direction, to = target - 0.2f * direction;
    const RayHit hit = castRay(shape, from, to);
    ASSERT_TRUE(hit.hit) << what << " ray " << n;
    const float r = hit.point.length();
    ASSERT_GE(r, kSphereRadius - sag - 1e-5f) << what << " ray " << n;
    ASSERT_LE(r, kSphereRadius + slack + 1e-5f) << what << " ray " << n;
    // the first crossing: nearer to `from` than the sphere's far side
    ASSERT_LT((hit.point - from).dot(direction), 0.f) << what;
    // the analytic hit distance along the ray, from |from + s d|^2 = R^2
    const btVector3 d = (to - from).normalized();
    const float b = from.dot(d), c = from.length2() - kSphereRadius * kSphereRadius;
    const float s = -b - std::sqrt(b * b - c);
    ASSERT_NEAR((hit.point - from).length(), s, 2 * sag) << what << " ray " << n;
    if (slack == 0.f)
      ASSERT_GT(hit.normal.normalized().dot(hit.point / r), std::cos(0.105f)) << what << " ray " << n;
  }
  // a ray passing 6 cm from the centre misses
  EXPECT_FALSE(castRay(shape, btVector3(0.2f, 0.06f, 0.f), btVector3(-0.2f, 0.06f, 0.f)).hit) << what;
}

TEST(BulletShapes, BvhRayTestHitsSphere) {
  const auto shape = makeBvhTriangleMeshShape(loadTriangleMesh(assetPath("sphere.obj")), 0.f);
  expectRaysHitSphere(*shape, "bvh");
  // straight along -x from 0.2 m: the hit is 0.2 - R away, give or take the sag
  const RayHit hit = castRay(*shape, btVector3(0.2f, 0.f, 0.f), btVector3(-0.2f, 0.f, 0.f));
  ASSERT_TRUE(hit.hit);
  EXPECT_NEAR(0.2f - hit.point.x(), 0.2f - kSphereRadius, 2.3e-4f);
  EXPECT_NEAR(hit.point.y(), 0.f, 1e-6f);
  EXPECT_NEAR(hit.point.z(), 0.f, 1e-6f);
}

TEST(BulletShapes, GImpactAndHullRayTestsHitSphere) {
  const TriangleMesh mesh = loadTriangleMesh(assetPath("sphere.obj"));
  expectRaysHitSphere(*makeGImpactMeshShape(mesh, 0.f), "gimpact");
  // Bullet ray-casts convex shapes by an iterative GJK cast whose stopping tolerances are
  // absolute, sized for metre-scale bodies: on this 5 cm hull its hits land up to ~4 mm
  // off the surface (measured 3.6 mm worst over these rays)
  expectRaysHitSphere(*makeConvexHullShape(mesh, 0.f), "convex hull", 0.005f);
}

TEST(BulletShapes, ShapesOwnTheirTriangles) {
  std::unique_ptr<btCollisionShape> bvh, gimpact;
  {
    TriangleMesh mesh = loadTriangleMesh(assetPath("sphere.obj"));
    bvh = makeBvhTriangleMeshShape(mesh, 0.f);
    gimpact = makeGImpactMeshShape(mesh, 0.f);
    // scribble over the source and free it: the shapes must not have kept pointers into it
    for (Vec3f& v : mesh.vertices) v = {1e3f, 1e3f, 1e3f};
    for (uint32_t& i : mesh.indices) i = 0;
  }
  expectRaysHitSphere(*bvh, "bvh after the mesh is gone");
  expectRaysHitSphere(*gimpact, "gimpact after the mesh is gone");
}

TEST(BulletShapes, RejectBadMeshes) {
  const TriangleMesh empty;
  EXPECT_THROW(makeBvhTriangleMeshShape(empty), mpm::InvalidArgument);
  EXPECT_THROW(makeConvexHullShape(empty), mpm::InvalidArgument);
  EXPECT_THROW(makeGImpactMeshShape(empty), mpm::InvalidArgument);
  TriangleMesh outOfRange;
  outOfRange.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  outOfRange.indices = {0, 1, 3};
  try {
    makeBvhTriangleMeshShape(outOfRange);
    ADD_FAILURE() << "no error for index 3 of 3 vertices";
  } catch (const mpm::InvalidArgument& e) {
    EXPECT_EQ(e.field(), "TriangleMesh.indices[2]");
  }
  outOfRange.indices = {0, 1, 2};
  try {
    makeConvexHullShape(outOfRange, -0.001f);
    ADD_FAILURE() << "no error for a negative margin";
  } catch (const mpm::InvalidArgument& e) {
    EXPECT_EQ(e.field(), "margin");
  }
}

}  // namespace
}  // namespace mpm::bullet
