#include <algorithm>
#include "shapes/shape_builder.h"

#include <cmath>

#include "core/validate.h"

namespace mpm {

Mat3f rotationMatrix(const Quat& q0) {
  const float n = std::sqrt(q0.w * q0.w + q0.x * q0.x + q0.y * q0.y + q0.z * q0.z);
  const float w = q0.w / n, x = q0.x / n, y = q0.y / n, z = q0.z / n;
  Mat3f R;
  R.m[0][0] = 1 - 2 * (y * y + z * z); R.m[0][1] = 2 * (x * y - w * z);     R.m[0][2] = 2 * (x * z + w * y);
  R.m[1][0] = 2 * (x * y + w * z);     R.m[1][1] = 1 - 2 * (x * x + z * z); R.m[1][2] = 2 * (y * z - w * x);
  R.m[2][0] = 2 * (x * z - w * y);     R.m[2][1] = 2 * (y * z + w * x);     R.m[2][2] = 1 - 2 * (x * x + y * y);
  return R;
}

Quat quaternionFromMatrix(const Mat3f& R) {
  // Shepperd's method: pick the largest of w, x, y, z to divide by
  const float tr = trace(R);
  Quat q;
  if (tr > 0.f) {
    const float s = std::sqrt(tr + 1.f) * 2.f;
    q = {0.25f * s, (R.m[2][1] - R.m[1][2]) / s, (R.m[0][2] - R.m[2][0]) / s, (R.m[1][0] - R.m[0][1]) / s};
  } else if (R.m[0][0] > R.m[1][1] && R.m[0][0] > R.m[2][2]) {
    const float s = std::sqrt(1.f + R.m[0][0] - R.m[1][1] - R.m[2][2]) * 2.f;
    q = {(R.m[2][1] - R.m[1][2]) / s, 0.25f * s, (R.m[0][1] + R.m[1][0]) / s, (R.m[0][2] + R.m[2][0]) / s};
  } else if (R.m[1][1] > R.m[2][2]) {
    const float s = std::sqrt(1.f + R.m[1][1] - R.m[0][0] - R.m[2][2]) * 2.f;
    q = {(R.m[0][2] - R.m[2][0]) / s, (R.m[0][1] + R.m[1][0]) / s, 0.25f * s, (R.m[1][2] + R.m[2][1]) / s};
  } else {
    const float s = std::sqrt(1.f + R.m[2][2] - R.m[0][0] - R.m[1][1]) * 2.f;
    q = {(R.m[1][0] - R.m[0][1]) / s, (R.m[0][2] + R.m[2][0]) / s, (R.m[1][2] + R.m[2][1]) / s, 0.25f * s};
  }
  return q;
}

namespace {
void validateQuat(const std::string& field, const Quat& q) {
  const float n2 = q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z;
  if (!std::isfinite(n2) || n2 < 1e-12f)
    throw InvalidArgument(field, "(" + validate::show(q.w) + ", " + validate::show(q.x) + ", " +
                                     validate::show(q.y) + ", " + validate::show(q.z) + ")",
                          "must be a finite, non-zero quaternion (it is normalised)");
}
}  // namespace

void validateShapeState(const ShapeState& s) {
  validate::finite("ShapeState.pose.position", s.pose.position);
  validateQuat("ShapeState.pose.rotation", s.pose.rotation);
  validate::finite("ShapeState.linearVelocity", s.linearVelocity);
  validate::finite("ShapeState.angularVelocity", s.angularVelocity);
}

void validateShapeDesc(const ShapeDesc& d) {
  if (d.parts.empty()) throw InvalidArgument("ShapeDesc.parts", "[]", "needs at least one part");
  for (size_t i = 0; i < d.parts.size(); ++i) {
    const Geometry& g = d.parts[i];
    const std::string f = "ShapeDesc.parts[" + std::to_string(i) + "]";
    validate::finite(f + ".localPose.position", g.localPose.position);
    validateQuat(f + ".localPose.rotation", g.localPose.rotation);
    validate::enumerator(f + ".type", g.type, GeometryType::Mesh, "GeometryType");
    switch (g.type) {
      case GeometryType::Box: validate::positive(f + ".halfExtents", g.halfExtents); break;
      case GeometryType::Sphere: validate::positive(f + ".radius", g.radius); break;
      case GeometryType::Capsule:
      case GeometryType::Cylinder:
        validate::positive(f + ".radius", g.radius);
        validate::positive(f + ".halfHeight", g.halfHeight);
        if (g.axis < 0 || g.axis > 2)
          throw InvalidArgument(f + ".axis", std::to_string(g.axis), "must be 0 (x), 1 (y) or 2 (z)");
        break;
      case GeometryType::Mesh:
        if (!g.sdf || g.sdf->values.empty() || g.sdf->dims[0] < 2 || g.sdf->dims[1] < 2 || g.sdf->dims[2] < 2)
          throw InvalidArgument(f + ".sdf", "empty", "a Mesh part needs a signed distance grid of at least 2^3 samples");
        validate::positive(f + ".sdf.cellSize", g.sdf->cellSize);
        break;
      case GeometryType::Plane: break;
    }
  }
  validate::finite("ShapeDesc.centerOfMass", d.centerOfMass);
  validateShapeState({d.pose, d.linearVelocity, d.angularVelocity});
  validate::enumerator("ShapeDesc.contact.mode", d.contact.mode, ContactMode::Bonded, "ContactMode");
  validate::finite("ShapeDesc.contact.friction", d.contact.friction);
  if (d.contact.friction < 0.f)
    throw InvalidArgument("ShapeDesc.contact.friction", validate::show(d.contact.friction), "must be >= 0");
  validate::finite("ShapeDesc.contact.drag", d.contact.drag);
  if (d.contact.drag < 0.f || d.contact.drag > 1.f)
    throw InvalidArgument("ShapeDesc.contact.drag", validate::show(d.contact.drag), "must lie in [0, 1]");
  validate::finite("ShapeDesc.contact.band", d.contact.band);
  validate::finite("ShapeDesc.mass", d.mass);
  if (d.mass < 0.f)
    throw InvalidArgument("ShapeDesc.mass", validate::show(d.mass), "must be >= 0 (0 = kinematic)");
  if (d.mass > 0.f) validate::positive("ShapeDesc.inertia", d.inertia);
  validate::finite("ShapeDesc.gravity", d.gravity);
}

BodyView makeBody(const ShapeDesc& d, const ShapeState& s, float bondedBand) {
  BodyView b;
  b.rotation = rotationMatrix(s.pose.rotation);
  b.comLocal = d.centerOfMass;
  b.shapeOrigin = s.pose.position;
  b.com = s.pose.position + b.rotation * d.centerOfMass;
  b.linearVelocity = s.linearVelocity;
  b.angularVelocity = s.angularVelocity;
  b.mode = d.contact.mode == ContactMode::Bonded   ? kContactBonded
           : d.contact.mode == ContactMode::Sticky ? kContactSticky
                                                   : kContactFrictional;
  b.friction = d.contact.friction;
  b.drag = d.contact.drag;
  b.band = d.contact.mode == ContactMode::Bonded ? std::max(d.contact.band, bondedBand) : d.contact.band;
  b.dynamic = d.mass > 0.f ? 1 : 0;
  b.mass = d.mass;
  b.inertia = d.inertia;
  b.gravity = d.gravity;
  return b;
}

PartView makePart(const Geometry& g, int bodyIndex, float minHalfThickness) {
  PartView p;
  p.body = bodyIndex;
  p.halfExtents = g.halfExtents;
  p.radius = g.radius;
  p.halfHeight = g.halfHeight;
  p.axis = g.axis;
  p.localRotation = rotationMatrix(g.localPose.rotation);
  p.localPosition = g.localPose.position;
  const float big = 1e18f;  // a plane's bounds: unbounded, yet finite after rotation
  switch (g.type) {
    case GeometryType::Plane:
      p.type = kPartPlane;
      p.localLower = {-big, -big, -big};
      p.localUpper = {big, 0.f, big};
      break;
    case GeometryType::Box:
      p.type = kPartBox;
      p.localLower = -g.halfExtents;
      p.localUpper = g.halfExtents;
      break;
    case GeometryType::Sphere:
      p.type = kPartSphere;
      p.localLower = {-g.radius, -g.radius, -g.radius};
      p.localUpper = {g.radius, g.radius, g.radius};
      break;
    case GeometryType::Capsule:
    case GeometryType::Cylinder: {
      p.type = g.type == GeometryType::Capsule ? kPartCapsule : kPartCylinder;
      Vec3f h{g.radius, g.radius, g.radius};
      h[g.axis] = g.halfHeight + (g.type == GeometryType::Capsule ? g.radius : 0.f);
      p.localLower = -h;
      p.localUpper = h;
      break;
    }
    case GeometryType::Mesh:
      p.type = kPartMesh;
      p.sdfDims[0] = g.sdf->dims[0];
      p.sdfDims[1] = g.sdf->dims[1];
      p.sdfDims[2] = g.sdf->dims[2];
      p.sdfLower = g.sdf->lower;
      p.sdfCell = g.sdf->cellSize;
      // the solid lies within the sampled grid; its bounds are the grid's
      p.localLower = g.sdf->lower;
      p.localUpper = g.sdf->upper();
      break;
  }
  // Half the thinnest extent of the solid (a sampled mesh's is not known: 0)
  float half = 0.f;
  if (g.type == GeometryType::Box) half = std::min(g.halfExtents.x, std::min(g.halfExtents.y, g.halfExtents.z));
  if (g.type == GeometryType::Sphere || g.type == GeometryType::Capsule) half = g.radius;
  if (g.type == GeometryType::Cylinder) half = std::min(g.radius, g.halfHeight);
  if (g.type != GeometryType::Plane && g.type != GeometryType::Mesh) p.band = std::max(minHalfThickness - half, 0.f);
  return p;
}

}  // namespace mpm
