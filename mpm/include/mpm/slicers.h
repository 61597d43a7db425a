#pragma once
/// Slicers: blades that cut the material (seed 000 section IV-B, DESIGN 5). A slicer is
/// not a solid: its faces push the material aside within a thin band, its spine pushes
/// like a blunt rod and never cuts, and where its blade passes the material is separated
/// for good. Moved like a kinematic shape (pose and velocities before each advance).
#include <cstdint>
#include <limits>

#include "mpm/shapes.h"

namespace mpm {

/// A rectangular blade in its own frame: the cutting edge runs along local x from
/// -halfLength to +halfLength at y = 0, the blade's faces are the plane z = 0 from the edge
/// up to the spine at y = width, and the spine is a round bar of `spineRadius` along x at
/// y = width. Everything the blade's faces pass between the edge and the spine is cut:
/// the edge leads the blade into the material, but a side of the blade moving through
/// material within the faces' extent cuts as well (only the spine is blunt).
struct QuadSlicerDesc {
  float halfLength = 0.05f;   ///< [m] half the length of the cutting edge (local x)
  float width = 0.02f;        ///< [m] from the edge to the spine's axis (local y)
  float spineRadius = 0.f;    ///< [m] the blunt back; 0: as thick as the faces' band
  /// Half-thickness of the blade itself [m]; the grid sees it grown by half a cell on each
  /// face (the band the material is pushed out of: the gap a cut opens is about one cell).
  float halfThickness = 0.f;
  float friction = 0.f;       ///< kinetic friction of the faces on the material, mu_k >= 0
  Pose pose;
  Vec3f linearVelocity{0.f, 0.f, 0.f};   ///< of the frame's origin [m/s]
  Vec3f angularVelocity{0.f, 0.f, 0.f};  ///< [rad/s], world frame
};

/// Handle to a slicer.
struct SlicerId {
  uint32_t index = std::numeric_limits<uint32_t>::max();
  uint32_t generation = 0;
};

}  // namespace mpm
