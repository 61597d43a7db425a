#include <algorithm>
#include "shapes/shape_builder.h"

#include <cmath>

#include "core/validate.h"

namespace mpm {

namespace {
/// The rotation of the (normalised) quaternion q0 in precision T: float for the kernels'
/// matrices, double for the host's placement of anchored parts (Frame64).
template <class T>
void quaternionRotation(const Quat& q0, T R[3][3]) {
  const T n = std::sqrt((T)q0.w * q0.w + (T)q0.x * q0.x + (T)q0.y * q0.y + (T)q0.z * q0.z);
  const T w = q0.w / n, x = q0.x / n, y = q0.y / n, z = q0.z / n;
  R[0][0] = 1 - 2 * (y * y + z * z); R[0][1] = 2 * (x * y - w * z);     R[0][2] = 2 * (x * z + w * y);
  R[1][0] = 2 * (x * y + w * z);     R[1][1] = 1 - 2 * (x * x + z * z); R[1][2] = 2 * (y * z - w * x);
  R[2][0] = 2 * (x * z - w * y);     R[2][1] = 2 * (y * z + w * x);     R[2][2] = 1 - 2 * (x * x + y * y);
}
}  // namespace

Mat3f rotationMatrix(const Quat& q0) {
  Mat3f R;
  quaternionRotation(q0, R.m);
  return R;
}

/// The rotation taking local x to the direction `d` (unit).
Quat rotationFromX(Vec3f d) {
  const float c = d.x;  // cos of the angle between x and d
  if (c < -0.999999f) return {0.f, 0.f, 1.f, 0.f};  // half a turn about y
  const Vec3f axis = cross(Vec3f{1.f, 0.f, 0.f}, d);
  const float w = 1.f + c, n = std::sqrt(w * w + dot(axis, axis));
  return {w / n, axis.x / n, axis.y / n, axis.z / n};
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

namespace {
/// Rigid placement in double on the host: the anchors are chosen and placed without the
/// float rounding the kernels are spared.
struct Frame64 {
  double R[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  double t[3] = {0, 0, 0};
  Frame64() = default;
  Frame64(const Pose& p) {
    quaternionRotation(p.rotation, R);
    for (int i = 0; i < 3; ++i) t[i] = p.position[i];
  }
  /// This frame then `child` (child -> this frame's parent).
  Frame64 operator*(const Frame64& c) const {
    Frame64 r;
    for (int i = 0; i < 3; ++i) {
      r.t[i] = t[i];
      for (int j = 0; j < 3; ++j) {
        r.R[i][j] = 0;
        for (int k = 0; k < 3; ++k) r.R[i][j] += R[i][k] * c.R[k][j];
        r.t[i] += R[i][j] * c.t[j];
      }
    }
    return r;
  }
  void apply(const double p[3], double out[3]) const {
    for (int i = 0; i < 3; ++i) out[i] = t[i] + R[i][0] * p[0] + R[i][1] * p[1] + R[i][2] * p[2];
  }
  void applyInverse(const double x[3], double out[3]) const {
    const double d[3] = {x[0] - t[0], x[1] - t[1], x[2] - t[2]};
    for (int j = 0; j < 3; ++j) out[j] = R[0][j] * d[0] + R[1][j] * d[1] + R[2][j] * d[2];
  }
};

double clampTo(double v, double lo, double hi) { return v < lo ? lo : (v > hi ? hi : v); }
Vec3f toFloat(const double v[3]) { return {(float)v[0], (float)v[1], (float)v[2]}; }
}  // namespace

PartView makePart(const Geometry& g, const ShapeDesc& desc, const ShapeState& state, int bodyIndex,
                  float minHalfThickness, Vec3f near) {
  PartView p;
  p.body = bodyIndex;
  p.radius = g.radius;
  p.axis = g.axis;
  // the part's frame in the world, and the domain centre in it
  const Frame64 body(state.pose), part = body * Frame64(g.localPose);
  const double nearWorld[3] = {near.x, near.y, near.z};
  double c[3];
  part.applyInverse(nearWorld, c);
  // the anchor (part frame): the part's point nearest the domain centre where that keeps
  // the numbers small; a sphere's (and a mesh grid's) is its centre
  double anchor[3] = {0, 0, 0};
  const double h[3] = {g.halfExtents.x, g.halfExtents.y, g.halfExtents.z};
  double hh = g.halfHeight;
  switch (g.type) {
    case GeometryType::Plane: anchor[0] = c[0]; anchor[2] = c[2]; break;
    case GeometryType::Box:
      for (int a = 0; a < 3; ++a) anchor[a] = clampTo(c[a], -h[a], h[a]);
      break;
    case GeometryType::Capsule:
    case GeometryType::Cylinder: anchor[g.axis] = clampTo(c[g.axis], -hh, hh); break;
    default: break;
  }
  double anchorWorld[3];
  part.apply(anchor, anchorWorld);
  const double comLocal[3] = {desc.centerOfMass.x, desc.centerOfMass.y, desc.centerOfMass.z};
  double com[3], lever[3];
  body.apply(comLocal, com);
  for (int i = 0; i < 3; ++i) lever[i] = anchorWorld[i] - com[i];
  p.uploadPosition = toFloat(anchorWorld);
  p.lever = toFloat(lever);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) p.uploadRotation.m[i][j] = (float)part.R[i][j];
  p.rotation = p.uploadRotation;
  p.position = p.uploadPosition;
  // the geometry relative to the anchor, rounded once from double
  double lower[3] = {0, 0, 0}, upper[3] = {0, 0, 0};
  const double big = 1e18;  // a plane's bounds: unbounded, yet finite after rotation
  switch (g.type) {
    case GeometryType::Plane:
      p.type = kPartPlane;
      for (int a = 0; a < 3; ++a) lower[a] = -big, upper[a] = big;
      upper[1] = 0;
      break;
    case GeometryType::Box:
      p.type = kPartBox;
      for (int a = 0; a < 3; ++a) lower[a] = -h[a] - anchor[a], upper[a] = h[a] - anchor[a];
      p.faceLower = toFloat(lower);
      p.faceUpper = toFloat(upper);
      break;
    case GeometryType::Sphere:
      p.type = kPartSphere;
      for (int a = 0; a < 3; ++a) lower[a] = -g.radius, upper[a] = g.radius;
      break;
    case GeometryType::Capsule:
    case GeometryType::Cylinder: {
      p.type = g.type == GeometryType::Capsule ? kPartCapsule : kPartCylinder;
      p.faceLower[g.axis] = (float)(-hh - anchor[g.axis]);
      p.faceUpper[g.axis] = (float)(hh - anchor[g.axis]);
      const double ends = g.type == GeometryType::Capsule ? g.radius : 0.0;
      for (int a = 0; a < 3; ++a) lower[a] = -(double)g.radius, upper[a] = g.radius;
      lower[g.axis] = -hh - ends - anchor[g.axis];
      upper[g.axis] = hh + ends - anchor[g.axis];
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
      for (int a = 0; a < 3; ++a) lower[a] = g.sdf->lower[a], upper[a] = g.sdf->upper()[a];
      break;
  }
  p.localLower = toFloat(lower);
  p.localUpper = toFloat(upper);
  // Half the thinnest extent of the solid (a sampled mesh's is not known: 0)
  float half = 0.f;
  if (g.type == GeometryType::Box) half = std::min(g.halfExtents.x, std::min(g.halfExtents.y, g.halfExtents.z));
  if (g.type == GeometryType::Sphere || g.type == GeometryType::Capsule) half = g.radius;
  if (g.type == GeometryType::Cylinder) half = std::min(g.radius, g.halfHeight);
  if (g.type != GeometryType::Plane && g.type != GeometryType::Mesh) p.band = std::max(minHalfThickness - half, 0.f);
  return p;
}

}  // namespace mpm
