// A needle as the kernels see it: its wire and its tip as two bodies.
#include "tools/tool_builder.h"

#include <algorithm>
#include <cmath>

#include "core/validate.h"
#include "shapes/shape_builder.h"

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
  // the tip: a blunt sphere of the wire's radius until it breaks in, holding the nodes
  // within kTipReach dx of its point
  ShapeDesc point;
  Geometry g = Geometry::sphere(d.wireRadius);
  g.localPose.position = {d.radius * std::cos(d.endAngle), d.radius * std::sin(d.endAngle), 0.f};
  point.parts.push_back(g);
  // sticky while pressed on: the surface cannot slide off a point (with Coulomb friction
  // the material flowed round the sub-cell tip at a tenth of the force)
  point.contact.mode = ContactMode::Sticky;
  const int tipBody = (int)bodies.size();
  bodies.push_back(makeBody(point, state, 0.f));
  PartView tip = makePart(g, point, state, tipBody, kTipReach * dx, near);
  tip.type = tipInside ? kPartTipInside : kPartTip;
  tip.tangent = {-std::sin(d.endAngle), std::cos(d.endAngle), 0.f};
  parts.push_back(tip);
}

}  // namespace mpm
