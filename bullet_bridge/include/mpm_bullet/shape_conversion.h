#pragma once
/// Bullet collision shapes as MPM shape geometry. Box, sphere, capsule (a zero-height one
/// is a sphere), cylinder and plane map to their analytic signed distances; cones and
/// multi-spheres of one or two spheres become grids sampled from their exact distance
/// (margin included, as Bullet collides with them); convex hulls, point clouds and convex
/// triangle meshes become grids of their points' exact hull less the margin; triangle
/// meshes (BVH, scaled BVH, GImpact) grids built from their triangles. Local scaling is honoured. A shape with no inside (a zero extent,
/// radius or height, flat hull points) is refused naming the Bullet shape and what is
/// zero, since the grid contact needs a solid; so are shapes with no conversion
/// (heightfield terrain, empty shape, multi-sphere of three or more spheres).
#include <vector>

#include "mpm/shapes.h"

class btCollisionShape;
class btTransform;
class btVector3;

namespace mpm::bullet {

/// Bullet's vector and rigid transform as mpm's.
Vec3f toVec(const btVector3& v);
Pose toPose(const btTransform& t);

/// Geometry parts of `shape` in its own frame. `sdfCellSize` [m] is the sample spacing
/// of grids built for meshes and hulls (a third to a half of the MPM cell is typical).
/// Throws mpm::InvalidArgument naming the shape type (and, inside a compound, the child)
/// for shapes it cannot convert.
std::vector<Geometry> convertShape(const btCollisionShape* shape, float sdfCellSize);

}  // namespace mpm::bullet
