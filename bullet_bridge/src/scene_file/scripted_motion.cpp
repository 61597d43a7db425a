#include "scene_file/scripted_motion.h"

#include <algorithm>
#include <cmath>

namespace mpm::bullet::scene_file {

namespace {
btQuaternion rotation(const Keyframe& k) {
  return btQuaternion(btVector3(k.axis.x, k.axis.y, k.axis.z).normalized(), k.angle);
}
}  // namespace

btTransform Keyframes::pose(double t) const {
  if (t <= frames.front().time || frames.size() == 1) {
    const Keyframe& k = frames.front();
    return btTransform(rotation(k), btVector3(k.position.x, k.position.y, k.position.z));
  }
  size_t i = 1;
  while (i < frames.size() && frames[i].time < t) ++i;
  if (i == frames.size()) {
    const Keyframe& k = frames.back();
    return btTransform(rotation(k), btVector3(k.position.x, k.position.y, k.position.z));
  }
  const Keyframe &a = frames[i - 1], &b = frames[i];
  double u = std::clamp((t - a.time) / (b.time - a.time), 0.0, 1.0);
  if (b.smoothstep.value_or(smoothstep)) u = u * u * (3 - 2 * u);
  const float s = (float)u;
  const Vec3f p = a.position + s * (b.position - a.position);
  const btVector3 axisA = btVector3(a.axis.x, a.axis.y, a.axis.z).normalized();
  const btVector3 axisB = btVector3(b.axis.x, b.axis.y, b.axis.z).normalized();
  const btQuaternion q = axisA == axisB ? btQuaternion(axisA, a.angle + s * (b.angle - a.angle))
                                        : slerp(rotation(a), rotation(b), s);
  return btTransform(q, btVector3(p.x, p.y, p.z));
}

void Keyframes::velocity(double t, btVector3& v, btVector3& w) const {
  v = w = btVector3(0, 0, 0);
  if (t <= frames.front().time || frames.size() == 1 || t > frames.back().time) return;  // held
  size_t i = 1;
  while (i < frames.size() && frames[i].time < t) ++i;
  const Keyframe &a = frames[i - 1], &b = frames[i];
  const btVector3 axisA = btVector3(a.axis.x, a.axis.y, a.axis.z).normalized();
  const btVector3 axisB = btVector3(b.axis.x, b.axis.y, b.axis.z).normalized();
  if (axisA == axisB) {
    // the stretch's own derivative, in double: a central difference of float rotations loses
    // a slow turn (cos of half of 6e-4 rad rounds to within an ulp of 1)
    const double T = b.time - a.time, u = std::clamp((t - a.time) / T, 0.0, 1.0);
    const double dsdt = (b.smoothstep.value_or(smoothstep) ? 6 * u * (1 - u) : 1.0) / T;
    const Vec3f dp = b.position - a.position;
    v = btVector3((btScalar)(dp.x * dsdt), (btScalar)(dp.y * dsdt), (btScalar)(dp.z * dsdt));
    w = axisA * (btScalar)(((double)b.angle - a.angle) * dsdt);
    return;
  }
  const double h = 1e-3;
  const btTransform before = pose(t - h), after = pose(t + h);
  v = (after.getOrigin() - before.getOrigin()) / (btScalar)(2 * h);
  const btQuaternion d = after.getRotation() * before.getRotation().inverse();  // world-frame turn over 2h
  const btScalar angle = d.getAngleShortestPath();
  w = angle > 0 ? d.getAxis() * (angle / (btScalar)(2 * h)) : btVector3(0, 0, 0);
  if (d.getW() < 0) w = -w;  // getAxis of the long way round
}

}  // namespace mpm::bullet::scene_file
