#pragma once
/// Bullet collision shapes as MPM shape geometry. Primitives map to their analytic signed
/// distances; convex hulls and triangle meshes (BVH, GImpact) become sampled signed
/// distance grids. Local scaling is honoured.
#include <vector>

#include "mpm/shapes.h"

class btCollisionShape;

namespace mpm::bullet {

/// Geometry parts of `shape` in its own frame. `sdfCellSize` [m] is the sample spacing
/// of grids built for meshes and hulls (a third to a half of the MPM cell is typical).
/// Throws mpm::InvalidArgument naming the shape type for shapes it cannot convert.
std::vector<Geometry> convertShape(const btCollisionShape* shape, float sdfCellSize);

}  // namespace mpm::bullet
