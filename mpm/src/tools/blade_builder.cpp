// A slicer as the kernels see it: its blade's faces and its spine as two kinematic bodies.
#include "tools/tool_builder.h"

#include <algorithm>
#include <cmath>

#include "core/validate.h"
#include "shapes/shape_builder.h"

namespace mpm {

void validateSlicerDesc(const QuadSlicerDesc& d) {
  validate::positive("QuadSlicerDesc.halfLength", d.halfLength);
  validate::positive("QuadSlicerDesc.width", d.width);
  validate::finite("QuadSlicerDesc.spineRadius", d.spineRadius);
  if (d.spineRadius < 0.f || d.spineRadius >= d.width)
    throw InvalidArgument("QuadSlicerDesc.spineRadius", validate::show(d.spineRadius),
                          "must lie in [0, width) (0: no spine)");
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

void appendSlicer(const QuadSlicerDesc& d, const ShapeState& state, float faceBand, Vec3f near,
                  const CurvedBlade* curved, const float* curvedValues, std::vector<BodyView>& bodies,
                  std::vector<PartView>& parts) {
  const float half = d.halfThickness + faceBand;
  // no spine unless asked for: the default one (as thick as the faces' band, which thin
  // parts get at least 0.75 dx to the grid) pushed the material it met sideways once the
  // blade went deeper than its width less that band, and the README's scalpel (width 4 cm,
  // dx 2 cm) ploughed from 2 cm deep (10 to 24 N against 3 N)
  const float spine = d.spineRadius;
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
