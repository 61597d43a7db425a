#include "shapes/shape_speed.h"

#include <algorithm>
#include <cmath>

#include "core/validate.h"

namespace mpm {

namespace {
/// |v| in double: a float's square overflows from 1.9e19 m/s on
double speedOf(Vec3f v) { return std::sqrt((double)v.x * v.x + (double)v.y * v.y + (double)v.z * v.z); }

std::string tooFast(double speed, float maxSpeed) {
  return "moves at " + validate::show((float)speed) + " m/s, faster than the grid can follow: more than " +
         validate::show(maxSpeed) + " m/s takes more substeps per simulated second than an advance may take";
}

/// The farthest corner of a grid's box from its frame's origin [m].
float farthestCorner(const SignedDistanceGrid& g) {
  float r = 0.f;
  for (int c = 0; c < 8; ++c) {
    Vec3f p = g.lower;
    for (int a = 0; a < 3; ++a)
      if (c >> a & 1) p[a] += (float)(g.dims[a] - 1) * g.cellSize;
    r = std::max(r, norm(p));
  }
  return r;
}
}  // namespace

void validateSpeed(const std::string& prefix, const ShapeState& s, float reach, float maxSpeed) {
  const double linear = speedOf(s.linearVelocity);
  if (linear > maxSpeed)
    throw InvalidArgument(prefix + ".linearVelocity", validate::show(s.linearVelocity), tooFast(linear, maxSpeed));
  const double rim = linear + speedOf(s.angularVelocity) * reach;
  if (rim > maxSpeed)
    throw InvalidArgument(prefix + ".angularVelocity", validate::show(s.angularVelocity),
                          "turns its rim, " + validate::show(reach) + " m from the axis, so that it " +
                              tooFast(rim, maxSpeed));
}

void validateThreadSpeeds(const std::vector<Vec3f>& velocities, float maxSpeed) {
  for (size_t i = 0; i < velocities.size(); ++i)
    if (speedOf(velocities[i]) > maxSpeed)
      throw InvalidArgument("LineSegmentsDesc.velocities[" + std::to_string(i) + "]", validate::show(velocities[i]),
                            tooFast(speedOf(velocities[i]), maxSpeed));
}

float reachOf(const ShapeDesc& d, float planeReach) {
  float reach = 0.f;
  for (const Geometry& g : d.parts) {
    float own = 0.f;
    switch (g.type) {
      case GeometryType::Plane: own = planeReach; break;
      case GeometryType::Box: own = norm(g.halfExtents); break;
      case GeometryType::Sphere: own = g.radius; break;
      case GeometryType::Capsule: own = g.halfHeight + g.radius; break;
      case GeometryType::Cylinder: own = std::hypot(g.halfHeight, g.radius); break;
      case GeometryType::Mesh: own = g.sdf ? farthestCorner(*g.sdf) : 0.f; break;
    }
    reach = std::max(reach, norm(g.localPose.position - d.centerOfMass) + own);
  }
  return reach;
}

float reachOf(const QuadSlicerDesc& d, const CurvedBlade* curved) {
  if (!curved) return std::hypot(d.halfLength, d.width + d.spineRadius) + d.halfThickness;
  const float spine = std::max(norm(curved->spineFrom), norm(curved->spineTo)) + d.spineRadius;
  return std::max(farthestCorner(*curved->grid), spine);
}

}  // namespace mpm
