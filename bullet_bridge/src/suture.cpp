#include "mpm_bullet/suture.h"

#include <btBulletDynamicsCommon.h>
#include <BulletDynamics/Featherstone/btMultiBody.h>
#include <BulletDynamics/Featherstone/btMultiBodyDynamicsWorld.h>
#include <BulletDynamics/Featherstone/btMultiBodyLinkCollider.h>
#include <BulletDynamics/Featherstone/btMultiBodyPoint2Point.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "mpm/error.h"
#include "thread_bending.h"

namespace mpm::bullet {

namespace {

bool finite(const btVector3& v) { return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z()); }

std::string text(const btVector3& v) {
  return "(" + std::to_string(v.x()) + ", " + std::to_string(v.y()) + ", " + std::to_string(v.z()) + ")";
}

void validate(const btMultiBodyDynamicsWorld* world, const SutureThreadDesc& d) {
  if (!world) throw InvalidArgument("makeSutureThread world", "null", "needs a btMultiBodyDynamicsWorld");
  if (!(d.length > 0.f) || !std::isfinite(d.length))
    throw InvalidArgument("SutureThreadDesc.length", std::to_string(d.length), "must be finite and > 0");
  if (d.segments < 2)
    throw InvalidArgument("SutureThreadDesc.segments", std::to_string(d.segments), "must be >= 2");
  if (d.segments > 100000)
    throw InvalidArgument("SutureThreadDesc.segments", std::to_string(d.segments), "must be <= 100000");
  const float L = d.length / (float)d.segments;
  if (!(d.radius > 0.f) || !std::isfinite(d.radius))
    throw InvalidArgument("SutureThreadDesc.radius", std::to_string(d.radius), "must be finite and > 0");
  if (!(2.f * d.radius < L))
    throw InvalidArgument("SutureThreadDesc.radius", std::to_string(d.radius),
                          "must be < half a segment (length / segments / 2 = " + std::to_string(0.5f * L) + ")");
  if (!(d.linearDensity > 0.f) || !std::isfinite(d.linearDensity))
    throw InvalidArgument("SutureThreadDesc.linearDensity", std::to_string(d.linearDensity), "must be finite and > 0");
  if (!(d.damping >= 0.f) || !std::isfinite(d.damping))
    throw InvalidArgument("SutureThreadDesc.damping", std::to_string(d.damping), "must be finite and >= 0");
  if (!(d.youngsModulus >= 0.f) || !std::isfinite(d.youngsModulus))
    throw InvalidArgument("SutureThreadDesc.youngsModulus", std::to_string(d.youngsModulus),
                          "must be finite and >= 0 (0: a limp thread)");
  if (!finite(d.start)) throw InvalidArgument("SutureThreadDesc.start", text(d.start), "must be finite");
  if (!finite(d.direction) || !(d.direction.length2() > 1e-12f))
    throw InvalidArgument("SutureThreadDesc.direction", text(d.direction), "must be finite and non-zero");
  if (!(d.friction >= 0.f) || !std::isfinite(d.friction))
    throw InvalidArgument("SutureThreadDesc.friction", std::to_string(d.friction), "must be finite and >= 0");
  if (!(d.maxTension >= 0.f) || !std::isfinite(d.maxTension))
    throw InvalidArgument("SutureThreadDesc.maxTension", std::to_string(d.maxTension), "must be finite and >= 0");
  if (!(d.tick > 0.f) || !std::isfinite(d.tick))
    throw InvalidArgument("SutureThreadDesc.tick", std::to_string(d.tick), "must be finite and > 0");
}

/// Number of segments of a thread (the base and its links).
int segmentCount(const btMultiBody* mb) { return mb->getNumLinks() + 1; }

void requireChain(const btMultiBody* mb, const char* who) {
  if (!mb) throw InvalidArgument(std::string(who) + " thread", "null", "needs a btMultiBody");
  if (mb->getNumLinks() < 1)
    throw InvalidArgument(std::string(who) + " thread", "0 links", "a thread needs a base and at least one link");
  for (int i = 0; i < mb->getNumLinks(); ++i)
    if (mb->getParent(i) != i - 1)
      throw InvalidArgument(std::string(who) + " thread", "link " + std::to_string(i) + "'s parent is " +
                                                              std::to_string(mb->getParent(i)),
                            "a thread is a chain: link i's parent is i - 1");
}

/// Segment s's pivot toward the previous point and toward the next one, in its own frame:
/// the base is taken symmetric about its centre (its outer end mirrors its joint).
btVector3 segmentHalf(const btMultiBody* mb, int s) {
  return s == 0 ? mb->getLink(0).m_eVector : mb->getLink(s - 1).m_dVector;
}

}  // namespace

btTransform threadSegmentTransform(const btMultiBody* mb, int s) {
  if (s == 0) {
    if (const btMultiBodyLinkCollider* c = mb->getBaseCollider()) return c->getWorldTransform();
    return mb->getBaseWorldTransform();
  }
  if (const btMultiBodyLinkCollider* c = mb->getLink(s - 1).m_collider) return c->getWorldTransform();
  return mb->getLink(s - 1).m_cachedWorldTransform;
}

btMultiBody* makeSutureThread(btMultiBodyDynamicsWorld* world, const SutureThreadDesc& d) {
  validate(world, d);
  const int n = d.segments;
  const btScalar L = d.length / (btScalar)n, r = d.radius;
  const btScalar m = d.linearDensity * L;
  // a solid rod along local x, every moment floored (suture.h): at the transverse one
  // m L^2 / 12 (the axial moment m r^2 / 2 is 1e-2 to 1e-3 of it for a thin thread), and
  // at kMinMoment. Measured: a real suture (1e-4 kg/m, 2 mm segments: m 2e-7 kg, moments
  // 6.7e-14 kg m^2) turns to NaN in the first tick, as Bullet (float) inverts each spherical
  // joint's 3 x 3 articulated inertia, whose determinant (~1e-40) is below FLT_MIN; with
  // moments of 1e-12 (determinant >= 1e-36) it steps, and a bent 30-segment thread
  // spinning in free fall ends 2 s later within 1e-5 m of where one 10 to 1000 times
  // heavier (not floored) does
  constexpr btScalar kMinMoment = 1e-12f;  // [kg m^2]
  // Bullet clamps a joint's rate at 100 rad/s by default; a taut segment's turn runs
  // faster (ThreadBending answers it implicitly), and the clamp cut it short
  constexpr btScalar kMaxJointRate = 1e6f;  // [rad/s]
  const btScalar transverse = m * (L * L / 12 + r * r / 4);
  // and the turn of a segment under the tension it must carry, resolved by the tick
  // (SutureThreadDesc::maxTension: omega^2 = T L / I, omega tick <= 1)
  const btScalar tensionMoment = d.maxTension * L * d.tick * d.tick;
  const btScalar floorMoment = std::max({m * L * L / 12, kMinMoment, tensionMoment});
  const btVector3 inertia(std::max(m * r * r / 2, floorMoment), std::max(transverse, floorMoment),
                          std::max(transverse, floorMoment));
  auto* shape = new btCapsuleShapeX(r, L - 2 * r);  // end to end: the capsules' tips touch at the joints
  auto* mb = new btMultiBody(n - 1, m, inertia, d.fixedBase, /*canSleep*/ false);
  const btVector3 half(L / 2, 0, 0);
  for (int i = 0; i < n - 1; ++i)
    mb->setupSpherical(i, m, inertia, i - 1, btQuaternion::getIdentity(), half, half, /*disableParentCollision*/ true);
  mb->finalizeMultiDof();
  mb->setMaxCoordinateVelocity(kMaxJointRate);
  const btVector3 dir = d.direction.normalized();
  const btQuaternion rot = shortestArcQuat(btVector3(1, 0, 0), dir);
  mb->setBasePos(d.start + dir * (L / 2));
  mb->setWorldToBaseRot(rot.inverse());
  // damping (suture.h): Bullet's own per-link drag, m v (k + k |v|) and I w (k + k |w|)
  // (btMultiBody::computeAccelerationsArticulatedBodyAlgorithmMultiDof); 0 by default, not
  // Bullet's 0.04, so the thread's momentum is only what gravity, pins and the tissue give
  mb->setLinearDamping(d.damping);
  mb->setAngularDamping(d.damping);
  world->addMultiBody(mb);
  for (int link = -1; link < n - 1; ++link) {
    auto* c = new btMultiBodyLinkCollider(mb, link);
    c->setCollisionShape(shape);
    c->setFriction(d.friction);
    world->addCollisionObject(c, d.collisionGroup, d.collisionMask);
    if (link < 0)
      mb->setBaseCollider(c);
    else
      mb->getLink(link).m_collider = c;
  }
  // bending, a spring of EI / L at each joint, and the tension's turn, both implicit
  // (suture.h, ThreadBending; also an action, to read the pins' share after the step)
  const btScalar EI = d.youngsModulus * (btScalar)M_PI * r * r * r * r / 4;
  auto* stiffness = new ThreadBending(world, mb, EI / L, L);
  world->addMultiBodyConstraint(stiffness);
  world->addAction(stiffness);
  btAlignedObjectArray<btQuaternion> scratchRot;
  btAlignedObjectArray<btVector3> scratchPos;
  mb->forwardKinematics(scratchRot, scratchPos);
  mb->updateCollisionObjectWorldTransforms(scratchRot, scratchPos);
  return mb;
}

void destroySutureThread(btMultiBodyDynamicsWorld* world, btMultiBody* mb) {
  if (!world || !mb) return;
  for (int i = world->getNumMultiBodyConstraints() - 1; i >= 0; --i) {
    btMultiBodyConstraint* c = world->getMultiBodyConstraint(i);
    if (c->getMultiBodyA() == mb || c->getMultiBodyB() == mb) {
      if (auto* stiffness = dynamic_cast<ThreadBending*>(c)) world->removeAction(stiffness);
      world->removeMultiBodyConstraint(c);
      delete c;
    }
  }
  std::vector<btCollisionShape*> shapes;
  for (int link = -1; link < mb->getNumLinks(); ++link) {
    btMultiBodyLinkCollider* c = link < 0 ? mb->getBaseCollider() : mb->getLink(link).m_collider;
    if (!c) continue;
    world->removeCollisionObject(c);
    if (std::find(shapes.begin(), shapes.end(), c->getCollisionShape()) == shapes.end())
      shapes.push_back(c->getCollisionShape());
    delete c;
  }
  world->removeMultiBody(mb);
  delete mb;
  for (btCollisionShape* s : shapes) delete s;
}

std::vector<btVector3> threadPoints(const btMultiBody* mb) {
  requireChain(mb, "threadPoints");
  const int n = segmentCount(mb);
  std::vector<btVector3> p((size_t)n + 1);
  for (int s = 0; s < n; ++s) {
    const btTransform t = threadSegmentTransform(mb, s);
    const btVector3 h = segmentHalf(mb, s);
    p[(size_t)s] = t * (-h);
    if (s == n - 1) p[(size_t)n] = t * h;
  }
  return p;
}

std::vector<btVector3> threadPointVelocities(const btMultiBody* mb) {
  requireChain(mb, "threadPointVelocities");
  const int n = segmentCount(mb);
  // Featherstone velocities come in each link's own frame, base first
  btAlignedObjectArray<btVector3> omega, vel;
  omega.resize(n);
  vel.resize(n);
  mb->compTreeLinkVelocities(&omega[0], &vel[0]);
  std::vector<btVector3> v((size_t)n + 1);
  for (int s = 0; s < n; ++s) {
    const btTransform t = threadSegmentTransform(mb, s);
    const btVector3 h = segmentHalf(mb, s);
    const btVector3 vs = s == 0 ? mb->getBaseVel() : t.getBasis() * vel[s];
    const btVector3 ws = s == 0 ? mb->getBaseOmega() : t.getBasis() * omega[s];
    v[(size_t)s] = vs + ws.cross(t.getBasis() * (-h));
    if (s == n - 1) v[(size_t)n] = vs + ws.cross(t.getBasis() * h);
  }
  return v;
}

void layThreadAlong(btMultiBody* mb, const std::vector<btVector3>& points) {
  requireChain(mb, "layThreadAlong");
  const int n = segmentCount(mb);
  if ((int)points.size() != n + 1)
    throw InvalidArgument("layThreadAlong points", std::to_string(points.size()) + " points",
                          "must be segments + 1 = " + std::to_string(n + 1));
  for (int s = 0; s < n; ++s) {
    const btScalar L = 2 * segmentHalf(mb, s).length();
    const btScalar d = (points[(size_t)s + 1] - points[(size_t)s]).length();
    if (!finite(points[(size_t)s]) || !finite(points[(size_t)s + 1]) || !(std::fabs(d - L) <= 1e-3f * L))
      throw InvalidArgument("layThreadAlong points[" + std::to_string(s + 1) + "]", text(points[(size_t)s + 1]),
                            "must be finite and one segment (" + std::to_string(L) + " m) from the point before");
  }
  // each segment's frame: its local x along the segment; parallel transport from the one
  // before, so the joints do not twist
  btQuaternion previous = btQuaternion::getIdentity();
  btVector3 axis(1, 0, 0);
  for (int s = 0; s < n; ++s) {
    const btVector3 dir = (points[(size_t)s + 1] - points[(size_t)s]).normalized();
    const btQuaternion frame = shortestArcQuat(axis, dir) * previous;  // segment to world
    if (s == 0) {
      mb->setBasePos(0.5f * (points[0] + points[1]));
      mb->setWorldToBaseRot(frame.inverse());
      mb->setBaseVel(btVector3(0, 0, 0));
      mb->setBaseOmega(btVector3(0, 0, 0));
    } else {
      // a spherical joint's position q turns the link in its parent's frame: R_link = R_parent q
      const btQuaternion q = previous.inverse() * frame;
      btScalar pos[4] = {q.x(), q.y(), q.z(), q.w()};
      btScalar vel[3] = {0, 0, 0};
      mb->setJointPosMultiDof(s - 1, pos);
      mb->setJointVelMultiDof(s - 1, vel);
    }
    previous = frame;
    axis = dir;
  }
  btAlignedObjectArray<btQuaternion> scratchRot;
  btAlignedObjectArray<btVector3> scratchPos;
  mb->forwardKinematics(scratchRot, scratchPos);
  mb->updateCollisionObjectWorldTransforms(scratchRot, scratchPos);
}

std::vector<btVector3> threadPointsAlong(const std::vector<btVector3>& corners, float segmentLength, int segments) {
  if (!(segmentLength > 0.f) || !std::isfinite(segmentLength))
    throw InvalidArgument("threadPointsAlong segmentLength", std::to_string(segmentLength), "must be finite and > 0");
  if (segments < 1) throw InvalidArgument("threadPointsAlong segments", std::to_string(segments), "must be >= 1");
  if (corners.empty()) throw InvalidArgument("threadPointsAlong corners", "none", "needs a polyline");
  for (size_t k = 0; k < corners.size(); ++k)
    if (!finite(corners[k]))
      throw InvalidArgument("threadPointsAlong corners[" + std::to_string(k) + "]", text(corners[k]), "must be finite");
  const btScalar L = segmentLength;
  std::vector<btVector3> p{corners[0]};
  size_t j = 0;
  btScalar t = 0;
  while ((int)p.size() <= segments) {
    if (j + 1 >= corners.size())
      throw InvalidArgument("threadPointsAlong corners", std::to_string(corners.size()) + " corners",
                            "the polyline is shorter than " + std::to_string(segments) + " segments of " +
                                std::to_string(segmentLength) + " m");
    // where the corner's edge j first leaves the sphere of radius L about the last point,
    // past where the walk already is on it
    const btVector3 d = corners[j + 1] - corners[j], f = corners[j] - p.back();
    const btScalar a = d.dot(d), b = 2 * f.dot(d), c = f.dot(f) - L * L;
    const btScalar disc = b * b - 4 * a * c;
    const btScalar root = a > 0 && disc >= 0 ? (-b + std::sqrt(disc)) / (2 * a) : -1;
    if (root >= t && root <= 1) {
      t = root;
      p.push_back(corners[j] + d * root);
    } else {
      ++j;
      t = 0;
    }
  }
  return p;
}

btMultiBodyPoint2Point* pinThreadPoint(btMultiBodyDynamicsWorld* world, btMultiBody* mb, int point, btRigidBody* body,
                                      const btVector3& pivotInBody) {
  if (!world) throw InvalidArgument("pinThreadPoint world", "null", "needs a btMultiBodyDynamicsWorld");
  requireChain(mb, "pinThreadPoint");
  const int n = segmentCount(mb);
  if (point < 0 || point > n)
    throw InvalidArgument("pinThreadPoint point", std::to_string(point),
                          "must be in [0, " + std::to_string(n) + "] (the thread's points)");
  if (!finite(pivotInBody)) throw InvalidArgument("pinThreadPoint pivotInBody", text(pivotInBody), "must be finite");
  const int s = std::min(point, n - 1);  // the segment that carries the point
  const btVector3 h = segmentHalf(mb, s);
  const btVector3 pivotInLink = point == n ? h : -h;
  // a thread's pins join its ThreadBending's implicit solve (ThreadPin)
  ThreadBending* bending = nullptr;
  for (int i = 0; i < world->getNumMultiBodyConstraints() && !bending; ++i)
    if (world->getMultiBodyConstraint(i)->getMultiBodyA() == mb)
      bending = dynamic_cast<ThreadBending*>(world->getMultiBodyConstraint(i));
  btMultiBodyPoint2Point* pin = bending ? new ThreadPin(bending, s - 1, body, pivotInLink, pivotInBody)
                                        : new btMultiBodyPoint2Point(mb, s - 1, body, pivotInLink, pivotInBody);
  pin->setMaxAppliedImpulse((btScalar)BT_LARGE_FLOAT);
  world->addMultiBodyConstraint(pin);
  return pin;
}

btMultiBodyPoint2Point* attachThreadToNeedle(btMultiBodyDynamicsWorld* world, btMultiBody* thread, btRigidBody* needle,
                                            const btVector3& tailInNeedleFrame) {
  if (!needle) throw InvalidArgument("attachThreadToNeedle needle", "null", "needs the needle's btRigidBody");
  return pinThreadPoint(world, thread, 0, needle, tailInNeedleFrame);
}

btVector3 pinForce(btMultiBodyPoint2Point* pin, float dt) {
  // the rows act along -x, -y, -z (btMultiBodyPoint2Point::createConstraintRows)
  return btVector3(-pin->getAppliedImpulse(0), -pin->getAppliedImpulse(1), -pin->getAppliedImpulse(2)) / dt;
}

NeedleDriver::NeedleDriver(btRigidBody* body, const NeedleDriveLimits& limits) : body_(body), limits_(limits) {
  if (!body) throw InvalidArgument("NeedleDriver body", "null", "needs a btRigidBody");
  if (!(limits.maxForce >= 0.f) || !std::isfinite(limits.maxForce))
    throw InvalidArgument("NeedleDriveLimits.maxForce", std::to_string(limits.maxForce), "must be finite and >= 0");
  if (!(limits.maxTorque >= 0.f) || !std::isfinite(limits.maxTorque))
    throw InvalidArgument("NeedleDriveLimits.maxTorque", std::to_string(limits.maxTorque), "must be finite and >= 0");
  if (!(limits.timeConstant > 0.f) || !std::isfinite(limits.timeConstant))
    throw InvalidArgument("NeedleDriveLimits.timeConstant", std::to_string(limits.timeConstant),
                          "must be finite and > 0");
  target_ = body->getCenterOfMassTransform();
  if (!body->isStaticOrKinematicObject()) body->setActivationState(DISABLE_DEACTIVATION);
}

void NeedleDriver::setTarget(const btTransform& pose, const btVector3& v, const btVector3& w) {
  if (!finite(pose.getOrigin()) || !finite(v) || !finite(w))
    throw InvalidArgument("NeedleDriver::setTarget", "non-finite", "pose and velocities must be finite");
  target_ = pose;
  targetV_ = v;
  targetW_ = w;
}

void NeedleDriver::tick(float dt) {
  force_ = torque_ = btVector3(0, 0, 0);
  if (!(dt > 0.f)) return;
  if (body_->isStaticOrKinematicObject()) {
    // moved: Bullet reads a kinematic body's motion state at each stepSimulation, so it is
    // set too; the coupler reads the transform and the velocities
    body_->setWorldTransform(target_);
    body_->setInterpolationWorldTransform(target_);
    if (body_->getMotionState()) body_->getMotionState()->setWorldTransform(target_);
    body_->setLinearVelocity(targetV_);
    body_->setAngularVelocity(targetW_);
    body_->setInterpolationLinearVelocity(targetV_);
    body_->setInterpolationAngularVelocity(targetW_);
    return;
  }
  const btScalar tau = std::max<btScalar>(limits_.timeConstant, dt);
  const btScalar m = 1 / body_->getInvMass();
  // linear: the impulse that sets v to v* + e / tau, less the gravity Bullet adds this tick
  const btVector3 e = target_.getOrigin() - body_->getCenterOfMassPosition();
  btVector3 J = m * (targetV_ + e / tau - body_->getLinearVelocity()) - m * body_->getGravity() * dt;
  const btScalar maxJ = limits_.maxForce * dt;
  if (J.length() > maxJ) J *= maxJ / J.length();
  // angular: rotation vector from the body's orientation to the target's (shortest way)
  const btVector3 theta = rotationVector(target_.getRotation() * body_->getOrientation().inverse());
  const btVector3 dw = targetW_ + theta / tau - body_->getAngularVelocity();
  // the angular impulse I dw in the body's principal frame (an axis with infinite inertia
  // is left alone)
  const btMatrix3x3& R = body_->getCenterOfMassTransform().getBasis();
  const btVector3 dwLocal = R.transpose() * dw;
  const btVector3 invI = body_->getInvInertiaDiagLocal();
  btVector3 Llocal(0, 0, 0);
  for (int k = 0; k < 3; ++k)
    if (invI[k] > 0) Llocal[k] = dwLocal[k] / invI[k];
  btVector3 L = R * Llocal;
  const btScalar maxL = limits_.maxTorque * dt;
  if (L.length() > maxL) L *= maxL / L.length();
  body_->applyCentralImpulse(J);
  body_->applyTorqueImpulse(L);
  body_->activate();
  force_ = J / dt;
  torque_ = L / dt;
}

}  // namespace mpm::bullet
