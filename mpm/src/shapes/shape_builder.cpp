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

void validateSlicerDesc(const QuadSlicerDesc& d) {
  validate::positive("QuadSlicerDesc.halfLength", d.halfLength);
  validate::positive("QuadSlicerDesc.width", d.width);
  validate::finite("QuadSlicerDesc.spineRadius", d.spineRadius);
  if (d.spineRadius < 0.f || d.spineRadius >= d.width)
    throw InvalidArgument("QuadSlicerDesc.spineRadius", validate::show(d.spineRadius),
                          "must lie in [0, width) (0: as thick as the faces' band)");
  validate::finite("QuadSlicerDesc.halfThickness", d.halfThickness);
  if (d.halfThickness < 0.f)
    throw InvalidArgument("QuadSlicerDesc.halfThickness", validate::show(d.halfThickness), "must be >= 0");
  validate::finite("QuadSlicerDesc.friction", d.friction);
  if (d.friction < 0.f) throw InvalidArgument("QuadSlicerDesc.friction", validate::show(d.friction), "must be >= 0");
  validateShapeState({d.pose, d.linearVelocity, d.angularVelocity});
}

void validateSlicerDesc(const MeshSlicerDesc& d) {
  validate::finite("MeshSlicerDesc.spineFrom", d.spineFrom);
  validate::finite("MeshSlicerDesc.spineTo", d.spineTo);
  validate::finite("MeshSlicerDesc.spineRadius", d.spineRadius);
  if (d.spineRadius < 0.f)
    throw InvalidArgument("MeshSlicerDesc.spineRadius", validate::show(d.spineRadius), "must be >= 0 (0: no spine)");
  validate::finite("MeshSlicerDesc.halfThickness", d.halfThickness);
  if (d.halfThickness < 0.f)
    throw InvalidArgument("MeshSlicerDesc.halfThickness", validate::show(d.halfThickness), "must be >= 0");
  validate::finite("MeshSlicerDesc.friction", d.friction);
  if (d.friction < 0.f) throw InvalidArgument("MeshSlicerDesc.friction", validate::show(d.friction), "must be >= 0");
  validate::finite("MeshSlicerDesc.sampleSpacing", d.sampleSpacing);
  if (d.sampleSpacing < 0.f)
    throw InvalidArgument("MeshSlicerDesc.sampleSpacing", validate::show(d.sampleSpacing), "must be >= 0 (0: dx / 4)");
  validateShapeState({d.pose, d.linearVelocity, d.angularVelocity});
}

QuadSlicerDesc commonFields(const MeshSlicerDesc& d) {
  QuadSlicerDesc q;
  q.spineRadius = d.spineRadius;
  q.halfThickness = d.halfThickness;
  q.friction = d.friction;
  q.pose = d.pose;
  q.linearVelocity = d.linearVelocity;
  q.angularVelocity = d.angularVelocity;
  return q;
}

namespace {
/// The rotation taking local x to the direction `d` (unit).
Quat rotationFromX(Vec3f d) {
  const float c = d.x;  // cos of the angle between x and d
  if (c < -0.999999f) return {0.f, 0.f, 1.f, 0.f};  // half a turn about y
  const Vec3f axis = cross(Vec3f{1.f, 0.f, 0.f}, d);
  const float w = 1.f + c, n = std::sqrt(w * w + dot(axis, axis));
  return {w / n, axis.x / n, axis.y / n, axis.z / n};
}
}  // namespace

void appendSlicer(const QuadSlicerDesc& d, const ShapeState& state, float faceBand, Vec3f near,
                  const CurvedBlade* curved, const float* curvedValues, std::vector<BodyView>& bodies,
                  std::vector<PartView>& parts) {
  const float half = d.halfThickness + faceBand;
  const float spine = d.spineRadius > 0.f ? d.spineRadius : (curved ? 0.f : half);
  ShapeDesc faces;
  faces.contact.friction = d.friction;
  const int facesBody = (int)bodies.size();
  Geometry bar;  // the spine's axis along its local x
  bar.type = GeometryType::Capsule;
  bar.axis = 0;
  bar.radius = spine;
  if (curved) {
    Geometry g;
    g.type = GeometryType::Mesh;
    g.sdf = curved->grid;
    faces.parts.push_back(g);
    bodies.push_back(makeBody(faces, state, 0.f));
    PartView blade = makePart(g, faces, state, facesBody, 0.f, near);
    blade.type = kPartCurvedBlade;
    blade.sdfValues = curvedValues;
    blade.bladeHalf = half;
    blade.faceLower = curved->spineFrom;
    blade.faceUpper = curved->spineTo;
    blade.radius = spine;
    parts.push_back(blade);
    const Vec3f axis = curved->spineTo - curved->spineFrom;
    const float length = norm(axis);
    bar.halfHeight = 0.5f * length;
    bar.localPose.position = 0.5f * (curved->spineFrom + curved->spineTo);
    if (length > 0.f) bar.localPose.rotation = rotationFromX((1.f / length) * axis);
  } else {
    // the faces: a box from the edge (y = 0) to the spine's axis, `half` thick each side
    faces.parts.push_back(Geometry::box({d.halfLength, 0.5f * d.width, half}));
    faces.parts[0].localPose.position = {0.f, 0.5f * d.width, 0.f};
    bodies.push_back(makeBody(faces, state, 0.f));
    PartView blade = makePart(faces.parts[0], faces, state, facesBody, 0.f, near);
    blade.type = kPartBlade;
    blade.radius = spine;  // material within the spine's radius of its axis is not cut
    // its bounds reach the particles it records (up to 2.6 dx off its plane; the grid's
    // placement adds a cell, faceBand is half of one)
    blade.localLower.z -= 4.f * faceBand;
    blade.localUpper.z += 4.f * faceBand;
    parts.push_back(blade);
    bar.halfHeight = d.halfLength;
    bar.localPose.position = {0.f, d.width, 0.f};
  }
  // the spine: blunt, sticky while pressed on (it pushes tissue, never cuts it)
  ShapeDesc back;
  back.parts.push_back(bar);
  back.contact.mode = ContactMode::Sticky;
  const int spineBody = (int)bodies.size();
  bodies.push_back(makeBody(back, state, 0.f));
  if (spine > 0.f && bar.halfHeight > 0.f) parts.push_back(makePart(bar, back, state, spineBody, 0.f, near));
}

}  // namespace mpm

namespace mpm {

void validateCurveDesc(const ArcDesc& d) {
  validate::positive("ArcDesc.radius", d.radius);
  validate::finite("ArcDesc.startAngle", d.startAngle);
  validate::finite("ArcDesc.endAngle", d.endAngle);
  const float span = d.endAngle - d.startAngle;
  if (!(span > 0.f) || !(span < 6.2831853f))
    throw InvalidArgument("ArcDesc.endAngle", validate::show(d.endAngle),
                          "must lie in (startAngle, startAngle + 2 pi) (startAngle = " + validate::show(d.startAngle) + ")");
  validate::positive("ArcDesc.wireRadius", d.wireRadius);
  if (d.wireRadius >= d.radius)
    throw InvalidArgument("ArcDesc.wireRadius", validate::show(d.wireRadius), "must be less than the arc's radius");
  validate::finite("ArcDesc.friction", d.friction);
  if (d.friction < 0.f) throw InvalidArgument("ArcDesc.friction", validate::show(d.friction), "must be >= 0");
  validate::finite("ArcDesc.punctureForce", d.punctureForce);
  if (d.punctureForce < 0.f)
    throw InvalidArgument("ArcDesc.punctureForce", validate::show(d.punctureForce), "must be >= 0 (0: breaks in at first touch)");
  validateShapeState({d.pose, d.linearVelocity, d.angularVelocity});
}

void validateCurvePoints(const std::vector<Vec3f>& points, const std::vector<Vec3f>& velocities, size_t count) {
  if (points.size() != count)
    throw InvalidArgument("LineSegmentsDesc.points", std::to_string(points.size()) + " points",
                          count == 0 ? "needs at least two" : "must be " + std::to_string(count) + ", the thread's");
  if (!velocities.empty() && velocities.size() != points.size())
    throw InvalidArgument("LineSegmentsDesc.velocities", std::to_string(velocities.size()) + " velocities",
                          "must be one per point (" + std::to_string(points.size()) + ") or none");
  for (size_t i = 0; i < points.size(); ++i) {
    validate::finite("LineSegmentsDesc.points[" + std::to_string(i) + "]", points[i]);
    if (i > 0 && !(norm(points[i] - points[i - 1]) > 0.f))
      throw InvalidArgument("LineSegmentsDesc.points[" + std::to_string(i) + "]", "the point before it",
                            "must differ from the point before it (a segment of length 0)");
  }
  for (size_t i = 0; i < velocities.size(); ++i)
    validate::finite("LineSegmentsDesc.velocities[" + std::to_string(i) + "]", velocities[i]);
}

void validateCurveDesc(const LineSegmentsDesc& d) {
  if (d.points.size() < 2)
    throw InvalidArgument("LineSegmentsDesc.points", std::to_string(d.points.size()) + " points", "needs at least two");
  validateCurvePoints(d.points, d.velocities, d.points.size());
  validate::positive("LineSegmentsDesc.radius", d.radius);
  validate::finite("LineSegmentsDesc.friction", d.friction);
  if (d.friction < 0.f) throw InvalidArgument("LineSegmentsDesc.friction", validate::show(d.friction), "must be >= 0");
  validate::finite("LineSegmentsDesc.drag", d.drag);
  if (d.drag < 0.f || d.drag > 1.f)
    throw InvalidArgument("LineSegmentsDesc.drag", validate::show(d.drag), "must lie in [0, 1]");
  validate::finite("LineSegmentsDesc.linearDensity", d.linearDensity);
  if (d.linearDensity < 0.f)
    throw InvalidArgument("LineSegmentsDesc.linearDensity", validate::show(d.linearDensity), "must be >= 0 (0: kinematic)");
  validate::finite("LineSegmentsDesc.gravity", d.gravity);
}

void appendNeedle(const ArcDesc& d, const ShapeState& state, bool tipInside, float minHalfThickness, float dx,
                  float trackPressurePerDensity, Vec3f near, std::vector<BodyView>& bodies, std::vector<PartView>& parts) {
  // the wire: its frame is the arc's, anchored at the arc's centre (a sphere around it)
  ShapeDesc wire;
  wire.parts.push_back(Geometry::sphere(d.radius + d.wireRadius));
  const int wireBody = (int)bodies.size();
  BodyView shaft = makeBody(wire, state, 0.f);
  shaft.mode = kContactCurve;
  shaft.friction = 0.f;  // the shaft's friction is its pressure's (frictionRate), not the grid's Coulomb
  bodies.push_back(shaft);
  PartView arc = makePart(wire.parts[0], wire, state, wireBody, 0.f, near);
  arc.type = kPartArc;
  arc.radius = d.wireRadius;
  arc.arcRadius = d.radius;
  arc.arcStart = d.startAngle;
  arc.arcEnd = d.endAngle;
  arc.band = std::max(minHalfThickness - d.wireRadius, 0.f);
  // mu_k p pi d per unit length, p = rho (p / rho), spread over the disc of radius R
  // (the weight's integral pi R^2 / 3) of material of density rho: per unit mass
  const float R = kShaftFrictionReach * dx;
  arc.frictionReach = R;
  arc.frictionRate = d.friction * trackPressurePerDensity * 3.14159265f * 2.f * d.wireRadius / (3.14159265f * R * R / 3.f);
  parts.push_back(arc);
  // the tip: a blunt sphere of the wire's radius until it breaks in
  ShapeDesc point;
  Geometry g = Geometry::sphere(d.wireRadius);
  g.localPose.position = {d.radius * std::cos(d.endAngle), d.radius * std::sin(d.endAngle), 0.f};
  point.parts.push_back(g);
  // sticky while pressed on: the surface cannot slide off a point (with Coulomb friction
  // the material flowed round the sub-cell tip at a tenth of the force)
  point.contact.mode = ContactMode::Sticky;
  const int tipBody = (int)bodies.size();
  bodies.push_back(makeBody(point, state, 0.f));
  PartView tip = makePart(g, point, state, tipBody, minHalfThickness, near);
  tip.type = tipInside ? kPartTipInside : kPartTip;
  tip.tangent = {-std::sin(d.endAngle), std::cos(d.endAngle), 0.f};
  parts.push_back(tip);
}

void appendThread(const LineSegmentsDesc& d, const std::vector<Vec3f>& points, const std::vector<Vec3f>& velocities,
                  float minHalfThickness, Vec3f near, std::vector<BodyView>& bodies, std::vector<PartView>& parts) {
  for (size_t i = 0; i + 1 < points.size(); ++i) {
    const Vec3f a = points[i], b = points[i + 1], axis = b - a;
    const float length = norm(axis);
    const Vec3f va = velocities.empty() ? Vec3f{0.f, 0.f, 0.f} : velocities[i];
    const Vec3f vb = velocities.empty() ? Vec3f{0.f, 0.f, 0.f} : velocities[i + 1];
    ShapeDesc s;
    Geometry g;
    g.type = GeometryType::Capsule;
    g.axis = 0;
    g.radius = d.radius;
    g.halfHeight = 0.5f * length;
    s.parts.push_back(g);
    s.contact.friction = d.friction;
    s.contact.drag = d.drag;
    s.pose.position = 0.5f * (a + b);
    s.pose.rotation = rotationFromX((1.f / length) * axis);
    s.linearVelocity = 0.5f * (va + vb);
    s.angularVelocity = (1.f / (length * length)) * cross(axis, vb - va);  // the turn across the segment
    if (d.linearDensity > 0.f) {
      s.mass = d.linearDensity * length;
      // a rod about its ends' axis; about its own axis the same (a spin about the axis
      // changes nothing the tangent contact sees, and a tiny moment would be ill-conditioned)
      const float across = s.mass * length * length / 12.f;
      s.inertia = {across, across, across};
      s.gravity = d.gravity;
    }
    const ShapeState state{s.pose, s.linearVelocity, s.angularVelocity};
    const int body = (int)bodies.size();
    BodyView bv = makeBody(s, state, 0.f);
    bv.mode = kContactCurve;
    bodies.push_back(bv);
    PartView p = makePart(g, s, state, body, minHalfThickness, near);
    p.tangent = {1.f, 0.f, 0.f};
    parts.push_back(p);
  }
}

}  // namespace mpm
