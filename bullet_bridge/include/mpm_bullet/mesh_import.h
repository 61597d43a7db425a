#pragma once
/// Triangle meshes from files (through assimp) and the Bullet collision shapes built from
/// them. The same mpm::TriangleMesh feeds the MPM side (buildSignedDistanceGrid, filling
/// tissue) and the Bullet side (the shapes below), so both see one geometry.
#include <cstddef>
#include <memory>
#include <string>

#include <BulletCollision/CollisionShapes/btCollisionShape.h>

#include "mpm/sdf_grid.h"

namespace mpm::bullet {

/// Reads every triangle of a mesh file: OBJ, STL (ASCII or binary), PLY, glTF 2.0 (.gltf
/// with embedded or side-by-side buffers, .glb), and whatever else assimp reads. Polygons
/// are triangulated, all meshes of the scene are merged into one with their node
/// transforms applied (a mirroring transform keeps the winding outward), points and lines
/// are dropped, and vertices at identical positions are joined, so a closed surface comes
/// back watertight. Positions are multiplied by `scale` (e.g. 0.001 for a file in mm) to
/// give metres. Throws mpm::Error naming `path` and assimp's message when the file cannot
/// be read or holds no triangles; mpm::InvalidArgument for a scale that is not a finite
/// number > 0.
mpm::TriangleMesh loadTriangleMesh(const std::string& path, float scale = 1.f);

/// The same from a file's bytes already in memory (`size` bytes at `data`): `formatHint`
/// is the extension the file would have ("obj", "stl", "ply", "gltf", "glb", ...; without
/// the dot), which picks assimp's reader. The bytes are the whole file: references to
/// other files (a .gltf's side-by-side buffers, an .obj's .mtl) are not followed (a .gltf
/// with a buffer elsewhere is an error). Errors as loadTriangleMesh, naming `name` (e.g.
/// where the bytes came from) in place of the path; mpm::InvalidArgument on `data` NULL,
/// `size` 0 or an empty or unknown `formatHint` (naming it).
mpm::TriangleMesh loadTriangleMeshFromMemory(const void* data, size_t size, const std::string& formatHint,
                                             float scale = 1.f, const std::string& name = "memory");

/// Collision margin [m] given to the shapes built below unless the caller says otherwise.
/// Bullet pads shapes by their margin for robust contact; its own default (0.04 m for convex
/// shapes, 0.01 m for GImpact) suits metre-sized bodies, not tools and organs a few
/// centimetres across.
constexpr float kDefaultMeshMargin = 0.001f;

/// A static (never moving) concave triangle-mesh shape: a btBvhTriangleMeshShape with a
/// quantized BVH. The returned object owns copies of the vertices and indices and the
/// btTriangleIndexVertexArray that points into them, so `mesh` may be discarded at once
/// and nothing dangles while the shape lives. getAabb() pads the mesh bounds by `margin`.
/// Throws mpm::InvalidArgument for an empty mesh, out-of-range indices or a bad margin.
std::unique_ptr<btCollisionShape> makeBvhTriangleMeshShape(const mpm::TriangleMesh& mesh,
                                                           float margin = kDefaultMeshMargin);

/// The convex hull of the mesh's vertices (a btConvexHullShape, interior points removed),
/// for a dynamic body whose shape is close to convex. Note Bullet's getAabb() of this shape
/// pads the hull's bounds by twice `margin`.
std::unique_ptr<btCollisionShape> makeConvexHullShape(const mpm::TriangleMesh& mesh,
                                                      float margin = kDefaultMeshMargin);

/// A concave triangle-mesh shape that may move (btGImpactMeshShape, bounds already
/// updated), owning its data like makeBvhTriangleMeshShape. A world that collides it must
/// register btGImpactCollisionAlgorithm with its dispatcher. getAabb() pads the mesh
/// bounds by `margin`.
std::unique_ptr<btCollisionShape> makeGImpactMeshShape(const mpm::TriangleMesh& mesh,
                                                       float margin = kDefaultMeshMargin);

}  // namespace mpm::bullet
