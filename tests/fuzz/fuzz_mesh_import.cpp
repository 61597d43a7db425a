// libFuzzer target: the mesh importer (mpm::bullet::loadTriangleMeshFromMemory, assimp)
// and what a user builds from the mesh it returns. The first input byte picks the format
// (byte % 5: OBJ, STL (ASCII or binary: assimp tells them apart), PLY, glTF, GLB), the
// rest is the file. A mesh that loads then becomes what the library makes of meshes: its
// watertightness report, its signed distance grid at a coarse cell (the mesh's largest
// extent / 8, at least 5 mm, one cell of padding: at most 11^3 samples, so every input
// runs fast), a rigid shape of that grid in a scene, tissue filling it when it is closed
// and inside the scene's domain, and Bullet's static and convex-hull shapes. Meshes of
// more than 20,000 triangles stop after loading (the work cap; the importer itself has no
// limit). mpm::Error (InvalidArgument among them) is the library's answer to bad bytes;
// any other exception, a crash, a hang, a leak or a sanitizer report is a finding.
//
// Seeds (corpus/mesh/): the small files of assets/ with their format byte in front, the
// slab as binary STL, the bowl as binary PLY and the box as GLB (make_mesh_seeds.py writes
// them), and each input that once found a bug (regress-*).
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>

#include "mpm/error.h"
#include "mpm/scene.h"
#include "mpm/sdf_grid.h"
#include "mpm/shapes.h"
#include "mpm_bullet/mesh_import.h"

namespace {

constexpr const char* kFormats[] = {"obj", "stl", "ply", "gltf", "glb"};
constexpr size_t kMaxTriangles = 20000;
constexpr float kMinCell = 0.005f;  // [m]
constexpr float kCellsAcross = 8.f;
constexpr float kDomain = -0.1f;  // the scene's domain: [kDomain, -kDomain]^3 [m]

mpm::SceneSettings settings() {
  mpm::SceneSettings s;
  s.domain = {{kDomain, kDomain, kDomain}, {-kDomain, -kDomain, -kDomain}};
  s.dx = 0.02f;
  s.backend = mpm::Backend::Cpu;
  s.cpuThreads = 1;
  return s;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 2) return 0;
  const char* format = kFormats[data[0] % (sizeof kFormats / sizeof kFormats[0])];
  try {
    const mpm::TriangleMesh mesh = mpm::bullet::loadTriangleMeshFromMemory(data + 1, size - 1, format, 1.f, "fuzz input");
    if (mesh.triangleCount() > kMaxTriangles) return 0;
    const mpm::WatertightReport report = mpm::checkWatertight(mesh);

    // the grid's cell: coarse, from the mesh's size (a user picks it from the scene's dx)
    double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
    for (uint32_t index : mesh.indices)
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], (double)mesh.vertices[index][a]);
        hi[a] = std::max(hi[a], (double)mesh.vertices[index][a]);
      }
    double extent = 0;
    for (int a = 0; a < 3; ++a) extent = std::max(extent, hi[a] - lo[a]);
    const float cell = std::max(kMinCell, (float)(extent / kCellsAcross));
    auto grid = std::make_shared<const mpm::SignedDistanceGrid>(mpm::buildSignedDistanceGrid(mesh, cell, 1));
    if (grid->signReliable != report.watertight) __builtin_trap();  // the grid and the report disagree

    static mpm::Scene scene(settings());
    mpm::ShapeDesc shape;
    mpm::Geometry part;
    part.type = mpm::GeometryType::Mesh;
    part.sdf = grid;
    shape.parts = {part};
    scene.removeShape(scene.addShape(shape));
    // tissue as a user places it, inside the scene's domain: the seeding scans the object's
    // bounds at particle spacing (a mesh of metres would take seconds before its refusal)
    bool fits = true;
    for (int a = 0; a < 3; ++a) fits = fits && lo[a] > kDomain && hi[a] < -kDomain;
    if (grid->signReliable && fits) {
      mpm::ParticleObjectDesc tissue;
      tissue.primitive = mpm::PrimitiveType::Mesh;
      tissue.mesh = grid;
      tissue.particlesPerCellAxis = 1;
      try {
        scene.removeParticleObject(scene.addParticleObject(tissue));
      } catch (const mpm::InvalidArgument&) {  // outside the domain, or no particle inside
      }
    }

    mpm::bullet::makeBvhTriangleMeshShape(mesh, 0.f);
    mpm::bullet::makeConvexHullShape(mesh);
  } catch (const mpm::Error&) {
  }
  return 0;
}
