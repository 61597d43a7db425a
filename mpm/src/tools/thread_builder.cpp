// A thread as the kernels see it: one body per segment through its points.
#include "tools/tool_builder.h"

#include <algorithm>
#include <cmath>

#include "core/validate.h"
#include "shapes/shape_builder.h"

namespace mpm {

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
