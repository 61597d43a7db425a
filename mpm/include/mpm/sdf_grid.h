#pragma once
/// Triangle meshes and the signed distance grids sampled from them: the form in which an
/// imported mesh (a tool, an organ) becomes a rigid shape the MPM grid can see, or a
/// volume to fill with tissue particles. Geometry only; loading files is bullet_bridge's.
#include <cstdint>
#include <string>
#include <vector>

#include "mpm/math.h"

namespace mpm {

/// An indexed triangle mesh in its own frame [m]. Triangles are wound counter-clockwise
/// seen from outside (outward normals), as OBJ/STL/glTF exporters write them.
struct TriangleMesh {
  std::vector<Vec3f> vertices;
  std::vector<uint32_t> indices;  ///< three per triangle
  size_t triangleCount() const { return indices.size() / 3; }
};

/// Is the mesh closed? A watertight mesh has every edge shared by exactly two triangles
/// with opposite orientation; only then is "inside" well defined.
struct WatertightReport {
  bool watertight = false;
  size_t boundaryEdges = 0;      ///< edges used by one triangle (holes)
  size_t nonManifoldEdges = 0;   ///< edges used by more than two triangles
  size_t misorientedEdges = 0;   ///< edges whose two triangles traverse them the same way
  std::string reason;            ///< human-readable summary, empty when watertight
};
WatertightReport checkWatertight(const TriangleMesh& mesh);

/// A signed distance field on a regular grid (negative inside), in the mesh's frame.
/// Sample (i, j, k) is at lower + cellSize * (i, j, k); values are stored with k fastest:
/// values[(i * dims[1] + j) * dims[2] + k].
struct SignedDistanceGrid {
  Vec3f lower;
  float cellSize = 0;  ///< [m]
  int dims[3] = {0, 0, 0};
  std::vector<float> values;  ///< [m]
  /// False when the source mesh is not watertight: the magnitude is still the distance to
  /// the surface, but the sign (inside/outside) came from a generalized winding number
  /// and may be wrong near holes. `signWarning` says why.
  bool signReliable = true;
  std::string signWarning;

  /// Trilinear sample [m]. Outside the grid: the value at the nearest grid point plus the
  /// distance to it (an upper bound of the true distance).
  float sample(Vec3f p) const;
  /// Gradient of the trilinear field (unit length where the field is a distance).
  Vec3f gradient(Vec3f p) const;
  Vec3f upper() const { return lower + cellSize * Vec3f{(float)dims[0] - 1, (float)dims[1] - 1, (float)dims[2] - 1}; }
};

/// Samples the signed distance to `mesh` on a grid of `cellSize` [m] covering the mesh's
/// bounds plus `paddingCells` on every side. The sign comes from the generalized winding
/// number (robust to small holes); a mesh that is not watertight yields signReliable =
/// false with the reason. Throws InvalidArgument for an empty mesh, out-of-range indices,
/// or a non-positive cell size.
SignedDistanceGrid buildSignedDistanceGrid(const TriangleMesh& mesh, float cellSize, int paddingCells = 3);

/// Value of a blade grid (buildBladeGrid) where there is no blade to be beside.
constexpr float kNoBlade = 1e30f;

/// The sided distance to an open, consistently oriented mesh (a curved blade), sampled on a
/// grid of `cellSize` [m] reaching `reach` [m] beyond the mesh: where the point nearest a
/// sample lies inside the mesh (on a face or an edge between two faces), the distance with
/// the sign of the side the sample is on (+: the side the triangles' counter-clockwise
/// normals face, from the nearest feature's angle-weighted pseudo-normal); where it lies on
/// the mesh's boundary (past an edge or end of the blade) kNoBlade. Throws InvalidArgument
/// for an empty mesh, bad indices, a non-positive cell size, or a mesh whose triangles are
/// not consistently oriented (or share an edge among more than two); a cell size too fine
/// is named as what it is, MeshSlicerDesc.sampleSpacing. Its values hold a second channel
/// after the first dims[0] dims[1] dims[2]: the distance to the mesh's outline (the edges
/// of one triangle), where the blade opens the material it cuts.
SignedDistanceGrid buildBladeGrid(const TriangleMesh& mesh, float cellSize, float reach);

}  // namespace mpm
