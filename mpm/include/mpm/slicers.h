#pragma once
/// Slicers: blades that cut the material (CRESSim-MPM, section IV-B). A slicer is
/// not a solid: its faces push the material aside within a thin band, its spine pushes
/// like a blunt rod and never cuts, and where its blade passes the material is separated
/// for good. Moved like a kinematic shape (pose and velocities before each advance), its
/// velocities bounded as a shape's are (ShapeDesc: its blade's farthest point no faster
/// than SubstepPolicy::kMaxSubsteps * cflFor(solver) * dx per second).
#include <cstdint>
#include <limits>

#include "mpm/sdf_grid.h"
#include "mpm/shapes.h"

namespace mpm {

/// A rectangular blade in its own frame: the cutting edge runs along local x from
/// -halfLength to +halfLength at y = 0, the blade's faces are the plane z = 0 from the edge
/// up to its back at y = width, and with `spineRadius` > 0 a blunt spine, a round bar of
/// that radius along x at y = width, pushes what reaches it. Everything the blade's faces
/// pass between the edge and the spine's radius is cut: the edge leads the blade into the
/// material, but a side of the blade moving through material within the faces' extent cuts
/// as well (only the spine is blunt).
struct QuadSlicerDesc {
  float halfLength = 0.05f;   ///< [m] half the length of the cutting edge (local x)
  float width = 0.02f;        ///< [m] from the edge to the spine's axis (local y)
  /// [m] the blunt back, in [0, width); 0: none (the faces end at y = width). A spine
  /// thinner than 0.75 dx reaches the grid as 0.75 dx thick, and one pushed into material
  /// the faces have not cut pushes it aside (a blade deeper than its width).
  float spineRadius = 0.f;
  /// Half-thickness of the blade itself [m]; the grid sees it grown by half a cell on each
  /// face (the band the material is pushed out of: the gap a cut opens is about one cell).
  float halfThickness = 0.f;
  float friction = 0.f;       ///< kinetic friction of the faces on the material, mu_k >= 0
  Pose pose;
  Vec3f linearVelocity{0.f, 0.f, 0.f};   ///< of the frame's origin [m/s]
  Vec3f angularVelocity{0.f, 0.f, 0.f};  ///< [rad/s], world frame
};

/// A curved blade: an open triangle mesh in the slicer's frame, its triangles consistently
/// oriented (a scalpel's belly, a curved knife; from a file through
/// mpm::bullet::loadTriangleMesh). Material beside the mesh, where the point of the mesh
/// nearest it lies inside the mesh, is cut: the mesh's boundary cuts (there is no surface
/// past it) and only the spine, a round bar along a segment, is blunt. The side a particle
/// is on follows the curve (the nearest feature's normal), so a curved blade cuts along its
/// curve. The resistance to cutting (Material::fractureToughness) applies to quad blades
/// only for now.
struct MeshSlicerDesc {
  TriangleMesh blade;  ///< [m], in the slicer's frame
  Vec3f spineFrom{0.f, 0.f, 0.f}, spineTo{0.f, 0.f, 0.f};  ///< the spine's axis, slicer frame [m]
  float spineRadius = 0.f;    ///< [m]; 0: no spine
  float halfThickness = 0.f;  ///< as QuadSlicerDesc
  float friction = 0.f;       ///< as QuadSlicerDesc
  /// Spacing of the blade's sampled distance [m]; 0: a quarter of the grid's dx.
  float sampleSpacing = 0.f;
  Pose pose;
  Vec3f linearVelocity{0.f, 0.f, 0.f};
  Vec3f angularVelocity{0.f, 0.f, 0.f};
};

/// Handle to a slicer.
struct SlicerId {
  uint32_t index = std::numeric_limits<uint32_t>::max();
  uint32_t generation = 0;
};

}  // namespace mpm
