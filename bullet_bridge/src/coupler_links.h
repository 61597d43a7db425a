#pragma once
// What Coupler keeps per coupled body, blade, needle and thread (its private structs), and
// the conversions and Bullet calls its files share: coupler.cpp (the tick: poses to the
// scene, impulses back), coupler_attach.cpp (adding and removing bodies and tools),
// coupler_checkpoint.cpp (the bodies in a checkpoint), coupler_debug_draw.cpp.
#include <btBulletDynamicsCommon.h>
#include <BulletDynamics/Featherstone/btMultiBody.h>

#include <vector>

#include "mpm_bullet/coupler.h"
#include "mpm_bullet/shape_conversion.h"
#include "mpm_bullet/suture.h"

namespace mpm::bullet {

struct Coupler::Link {
  btCollisionObject* object;
  btRigidBody* rigid;   ///< or null
  btMultiBody* multi;   ///< or null
  int link;             ///< multibody link index, -1 for the base
  ShapeId shape;
  bool dynamic;
  btVector3 force{0, 0, 0}, torque{0, 0, 0};  ///< multibody: applied over the next tick
  /// the impulse of the last advance over the ticks of its interval: given each tick
  btVector3 shareLinear{0, 0, 0}, shareAngular{0, 0, 0};
};

/// A tool's frame fixed in a rigid body: a blade's, a needle's arc's.
struct BodyFrame {
  btRigidBody* body;
  btTransform local;  ///< the tool's frame in the body's centre-of-mass frame

  BodyFrame(btRigidBody* b, const Pose& p)
      : body(b),
        local(btQuaternion(p.rotation.x, p.rotation.y, p.rotation.z, p.rotation.w),
              btVector3(p.position.x, p.position.y, p.position.z)) {}
  /// The tool's frame in the world.
  btTransform world() const { return body->getCenterOfMassTransform() * local; }
  /// The tool frame's pose and velocities (of its origin) from the body's motion.
  ShapeState state() const {
    const btTransform t = world();
    return {toPose(t), toVec(body->getVelocityInLocalPoint(t.getOrigin() - body->getCenterOfMassPosition())),
            toVec(body->getAngularVelocity())};
  }
  /// A dynamic body takes an impulse given about the tool frame's origin.
  void receive(const ShapeImpulse& J) const {
    if (body->isStaticOrKinematicObject()) return;
    const btVector3 linear(J.linear.x, J.linear.y, J.linear.z), angular(J.angular.x, J.angular.y, J.angular.z);
    const btVector3 lever = world().getOrigin() - body->getCenterOfMassPosition();
    body->applyCentralImpulse(linear);
    body->applyTorqueImpulse(angular + lever.cross(linear));
    body->activate();
  }
};

/// A tool's description with the pose and velocities of its frame now.
template <class Desc>
Desc placedAt(Desc d, const ShapeState& now) {
  d.pose = now.pose;
  d.linearVelocity = now.linearVelocity;
  d.angularVelocity = now.angularVelocity;
  return d;
}

struct Coupler::SlicerLink {
  BodyFrame frame;
  SlicerId slicer;
  QuadSlicerDesc blade;  ///< as given: its outline for debugDraw (the scene keeps no copy we can read)
  ShapeImpulse share{};  ///< the last advance's impulse over the ticks of its interval
};

struct Coupler::NeedleLink {
  BodyFrame frame;
  CurveId curve;
  ArcDesc needle;  ///< as given: its arc for debugDraw
  ShapeImpulse share{};  ///< the last advance's impulse over the ticks of its interval
};

struct Coupler::ThreadLink {
  btMultiBody* thread = nullptr;
  CurveId curve;
  bool dynamic = false;
  std::vector<btVector3> force, torque;  ///< per segment: applied over the current tick
  std::vector<btVector3> shareLinear, shareAngular;  ///< per segment: its impulse per tick of the interval
  bool addedMass = false;
  std::vector<btScalar> mass;            ///< per segment: the link's own (added mass)
  std::vector<btVector3> inertia;        ///< per segment: the link's own principal moments
  std::vector<btVector3> velocity;       ///< per segment: its midpoint's, as given to the advance before
  std::vector<btVector3> advanced;       ///< per segment: its midpoint's, as given to this advance
};

/// Segment s's (0: the base) mass and principal moments in Bullet.
inline void setSegmentMass(btMultiBody* mb, int s, btScalar m, const btVector3& I) {
  if (s == 0) {
    mb->setBaseMass(m);
    mb->setBaseInertia(I);
  } else {
    mb->getLink(s - 1).m_mass = m;  // Bullet 3.24 has no setter; the articulated solve reads both each tick
    mb->getLink(s - 1).m_inertiaLocal = I;
  }
}

/// Each segment's midpoint velocity from its points'.
inline std::vector<btVector3> segmentVelocities(const btMultiBody* thread) {
  const std::vector<btVector3> v = threadPointVelocities(thread);
  std::vector<btVector3> out(v.size() - 1);
  for (size_t s = 0; s + 1 < v.size(); ++s) out[s] = 0.5f * (v[s] + v[s + 1]);
  return out;
}

/// The scene's vector as Bullet's.
inline btVector3 toBt(Vec3f v) { return {v.x, v.y, v.z}; }

/// Bullet's vectors as the scene's.
inline std::vector<Vec3f> toVecs(const std::vector<btVector3>& v) {
  std::vector<Vec3f> out(v.size());
  for (size_t i = 0; i < v.size(); ++i) out[i] = toVec(v[i]);
  return out;
}

/// Adds (sign +1) or takes back (sign -1) a multibody link's coupling force.
inline void addLinkForce(btMultiBody* mb, int link, const btVector3& f, const btVector3& tau) {
  if (link < 0) {
    mb->addBaseForce(f);
    mb->addBaseTorque(tau);
  } else {
    mb->addLinkForce(link, f);
    mb->addLinkTorque(link, tau);
  }
}

}  // namespace mpm::bullet
