#include "mpm_bullet/coupler.h"

#include <btBulletDynamicsCommon.h>
#include <BulletDynamics/Featherstone/btMultiBody.h>
#include <BulletDynamics/Featherstone/btMultiBodyLinkCollider.h>
#include <LinearMath/btIDebugDraw.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "mpm/checkpoint_io.h"
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

namespace {
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
}  // namespace

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

namespace {
/// Segment s's (0: the base) mass and principal moments in Bullet.
void setSegmentMass(btMultiBody* mb, int s, btScalar m, const btVector3& I) {
  if (s == 0) {
    mb->setBaseMass(m);
    mb->setBaseInertia(I);
  } else {
    mb->getLink(s - 1).m_mass = m;  // Bullet 3.24 has no setter; the articulated solve reads both each tick
    mb->getLink(s - 1).m_inertiaLocal = I;
  }
}

/// Each segment's midpoint velocity from its points'.
std::vector<btVector3> segmentVelocities(const btMultiBody* thread) {
  const std::vector<btVector3> v = threadPointVelocities(thread);
  std::vector<btVector3> out(v.size() - 1);
  for (size_t s = 0; s + 1 < v.size(); ++s) out[s] = 0.5f * (v[s] + v[s + 1]);
  return out;
}
}  // namespace

// CouplingContact repeats ContactParams' fields but friction: a field added there must be
// added here too
static_assert(sizeof(ContactParams) == sizeof(ContactMode) + 3 * sizeof(float),
              "ContactParams changed: update CouplingContact");

ContactParams CouplingContact::resolve(float bodyFriction) const {
  ContactParams p;
  p.mode = mode;
  p.friction = friction ? *friction : bodyFriction;
  p.drag = drag;
  p.band = band;
  return p;
}

namespace {

btVector3 toBt(Vec3f v) { return {v.x, v.y, v.z}; }

void preTick(btDynamicsWorld* world, btScalar dt) {
  static_cast<Coupler*>(world->getWorldUserInfo())->hookedTick((float)dt, true);
}

void postTick(btDynamicsWorld* world, btScalar dt) {
  static_cast<Coupler*>(world->getWorldUserInfo())->hookedTick((float)dt, false);
}

/// Adds (sign +1) or takes back (sign -1) a multibody link's coupling force.
void addLinkForce(btMultiBody* mb, int link, const btVector3& f, const btVector3& tau) {
  if (link < 0) {
    mb->addBaseForce(f);
    mb->addBaseTorque(tau);
  } else {
    mb->addLinkForce(link, f);
    mb->addLinkTorque(link, tau);
  }
}

/// World-frame velocities of a multibody link's centre of mass (index -1: the base).
void multiBodyLinkVelocity(const btMultiBody* mb, int link, const btTransform& linkFrame, btVector3& v,
                           btVector3& w) {
  if (link < 0) {
    v = mb->getBaseVel();
    w = mb->getBaseOmega();
    return;
  }
  // Featherstone velocities come in each link's own frame, base first
  btAlignedObjectArray<btVector3> omega, vel;
  omega.resize(mb->getNumLinks() + 1);
  vel.resize(mb->getNumLinks() + 1);
  mb->compTreeLinkVelocities(&omega[0], &vel[0]);
  v = linkFrame.getBasis() * vel[link + 1];
  w = linkFrame.getBasis() * omega[link + 1];
}

}  // namespace

Coupler::Coupler(btDynamicsWorld* world, Scene& scene) : world_(world), scene_(scene) {
  if (!world) throw InvalidArgument("Coupler world", "null", "needs a Bullet dynamics world");
  world_->setInternalTickCallback(&postTick, this, false);
  world_->setInternalTickCallback(&preTick, this, true);
}

Coupler::~Coupler() {
  world_->setInternalTickCallback(nullptr, nullptr, false);
  world_->setInternalTickCallback(nullptr, nullptr, true);
}

void Coupler::finishTick(float dt) {
  // Bullet clears multibody forces only when stepSimulation returns, not between its
  // internal ticks: the coupling force added before this tick is taken back after it
  // (and forgotten, so a tick that fails before adding its own takes back nothing)
  for (Link& l : links_)
    if (l.multi && l.dynamic) {
      addLinkForce(l.multi, l.link, -l.force, -l.torque);
      l.force = l.torque = btVector3(0, 0, 0);
    }
  takeBackThreadForces();
  if (userCallback_) userCallback_(dt);
}

void Coupler::takeBackThreadForces() {
  for (ThreadLink& t : threads_)
    for (size_t s = 0; s < t.force.size(); ++s) {
      if (t.force[s].isZero() && t.torque[s].isZero()) continue;
      addLinkForce(t.thread, (int)s - 1, -t.force[s], -t.torque[s]);
      t.force[s] = t.torque[s] = btVector3(0, 0, 0);
    }
}

void Coupler::hookedTick(float dt, bool pre) noexcept {
  // Bullet is not exception-safe: an exception unwinding through stepSimulation would
  // leave its world half-stepped. Keep it for rethrowError(); until the caller has taken
  // it the coupling stays off (no scene step, no impulses), so Bullet finishes the step
  // as if the tissue were absent. A tick failing in step 3 may have pushed some bodies.
  if (error_) return;
  try {
    if (pre)
      tick(dt);
    else
      finishTick(dt);
  } catch (...) {
    error_ = std::current_exception();
    // take back this tick's multibody forces (a failure in tick() left them unset)
    for (Link& l : links_)
      if (l.multi && l.dynamic) {
        addLinkForce(l.multi, l.link, -l.force, -l.torque);
        l.force = l.torque = btVector3(0, 0, 0);
      }
    takeBackThreadForces();
    resetInterval();  // the next tick advances the scene from where it was put back
  }
}

void Coupler::resetInterval() {
  intervalTick_ = 0;
  for (Link& l : links_) l.shareLinear = l.shareAngular = btVector3(0, 0, 0);
  for (SlicerLink& l : slicers_) l.share = {};
  for (NeedleLink& l : needles_) l.share = {};
  for (ThreadLink& t : threads_)
    for (size_t s = 0; s < t.shareLinear.size(); ++s) t.shareLinear[s] = t.shareAngular[s] = btVector3(0, 0, 0);
}

void Coupler::setTissueInterval(int ticks) {
  if (ticks < 1) throw InvalidArgument("Coupler::setTissueInterval ticks", std::to_string(ticks), "must be >= 1");
  if (intervalTick_ != 0)
    throw InvalidArgument("Coupler::setTissueInterval ticks", std::to_string(ticks),
                          "cannot change while an interval is open (the scene is " +
                              std::to_string(tissueInterval_ - intervalTick_) + " tick(s) ahead of Bullet)");
  tissueInterval_ = ticks;
}

ShapeId Coupler::addObject(btCollisionObject* object, btRigidBody* rigid, btMultiBody* multi, int link,
                           const CouplingOptions& options) {
  const float cell = options.sdfCellSize > 0.f ? options.sdfCellSize : 0.5f * scene_.settings().dx;
  ShapeDesc d;
  d.parts = convertShape(object->getCollisionShape(), cell);
  // mu_k: the override, else the object's own Bullet friction (see CouplingContact)
  d.contact = options.contact.resolve((float)object->getFriction());
  if (!(d.contact.friction >= 0.f) || !std::isfinite(d.contact.friction))
    throw InvalidArgument(options.contact.friction ? "CouplingOptions.contact.friction"
                                                   : "btCollisionObject::getFriction() of the coupled body",
                          std::to_string(d.contact.friction), "must be finite and >= 0");
  d.pose = toPose(object->getWorldTransform());
  bool dynamic = false;
  if (rigid && rigid->getInvMass() > 0.f) {
    dynamic = true;
    d.mass = 1.f / (float)rigid->getInvMass();
    const btVector3 invI = rigid->getInvInertiaDiagLocal();
    d.inertia = {invI.x() > 0 ? 1.f / (float)invI.x() : 1e30f, invI.y() > 0 ? 1.f / (float)invI.y() : 1e30f,
                 invI.z() > 0 ? 1.f / (float)invI.z() : 1e30f};
    d.linearVelocity = toVec(rigid->getLinearVelocity());
    d.angularVelocity = toVec(rigid->getAngularVelocity());
    d.gravity = toVec(rigid->getGravity());
  } else if (multi) {
    const float m = link < 0 ? (float)multi->getBaseMass() : (float)multi->getLink(link).m_mass;
    const btVector3 I = link < 0 ? multi->getBaseInertia() : multi->getLink(link).m_inertiaLocal;
    if (m > 0.f && !(link < 0 && multi->hasFixedBase())) {
      dynamic = true;
      d.mass = m;
      d.inertia = toVec(I);
      d.gravity = toVec(world_->getGravity());
    }
  }
  const ShapeId id = scene_.addShape(d);
  links_.push_back({object, rigid, multi, link, id, dynamic});
  return id;
}

ShapeId Coupler::addRigidBody(btRigidBody* body, const CouplingOptions& options) {
  if (!body) throw InvalidArgument("Coupler::addRigidBody body", "null", "no body given");
  return addObject(body, body, nullptr, -1, options);
}

std::vector<ShapeId> Coupler::addMultiBody(btMultiBody* body, const CouplingOptions& options) {
  if (!body) throw InvalidArgument("Coupler::addMultiBody body", "null", "no multibody given");
  std::vector<ShapeId> ids;
  if (body->getBaseCollider()) ids.push_back(addObject(body->getBaseCollider(), nullptr, body, -1, options));
  for (int i = 0; i < body->getNumLinks(); ++i)
    if (body->getLinkCollider(i)) ids.push_back(addObject(body->getLinkCollider(i), nullptr, body, i, options));
  return ids;
}

SlicerId Coupler::addSlicer(btRigidBody* body, const QuadSlicerDesc& blade) {
  if (!body) throw InvalidArgument("Coupler::addSlicer body", "null", "needs a btRigidBody");
  for (const SlicerLink& l : slicers_)
    if (l.frame.body == body) throw InvalidArgument("Coupler::addSlicer body", "already a slicer", "one blade per body");
  SlicerLink link{BodyFrame(body, blade.pose), {}, blade};
  link.slicer = scene_.addSlicer(placedAt(blade, link.frame.state()));  // validates the blade
  slicers_.push_back(link);
  return link.slicer;
}

SlicerId Coupler::slicerOf(const btRigidBody* body) const {
  for (const SlicerLink& l : slicers_)
    if (l.frame.body == body) return l.slicer;
  throw InvalidArgument("Coupler::slicerOf body", "not a slicer", "this body was never added with addSlicer");
}

CurveId Coupler::addNeedle(btRigidBody* body, const ArcDesc& needle) {
  if (!body) throw InvalidArgument("Coupler::addNeedle body", "null", "needs a btRigidBody");
  for (const NeedleLink& l : needles_)
    if (l.frame.body == body) throw InvalidArgument("Coupler::addNeedle body", "already a needle", "one needle per body");
  NeedleLink link{BodyFrame(body, needle.pose), {}, needle};
  link.curve = scene_.addCurve(placedAt(needle, link.frame.state()));  // validates the needle
  needles_.push_back(link);
  return link.curve;
}

CurveId Coupler::needleOf(const btRigidBody* body) const {
  for (const NeedleLink& l : needles_)
    if (l.frame.body == body) return l.curve;
  throw InvalidArgument("Coupler::needleOf body", "not a needle", "this body was never added with addNeedle");
}

namespace {
std::vector<Vec3f> toVecs(const std::vector<btVector3>& v) {
  std::vector<Vec3f> out(v.size());
  for (size_t i = 0; i < v.size(); ++i) out[i] = toVec(v[i]);
  return out;
}
}  // namespace

CurveId Coupler::addThread(btMultiBody* thread, const ThreadCoupling& options) {
  if (!thread) throw InvalidArgument("Coupler::addThread thread", "null", "needs a btMultiBody");
  for (const ThreadLink& t : threads_)
    if (t.thread == thread) throw InvalidArgument("Coupler::addThread thread", "already coupled", "one curve per thread");
  LineSegmentsDesc d;
  d.points = toVecs(threadPoints(thread));  // checks it is a chain
  d.velocities = toVecs(threadPointVelocities(thread));
  d.radius = options.radius;
  if (!(d.radius > 0.f)) {
    const btCollisionObject* base = thread->getBaseCollider();
    const btCollisionShape* shape = base ? base->getCollisionShape() : nullptr;
    if (!shape || shape->getShapeType() != CAPSULE_SHAPE_PROXYTYPE)
      throw InvalidArgument("ThreadCoupling.radius", std::to_string(options.radius),
                            "must be > 0 when the thread's base collider is not a btCapsuleShape");
    d.radius = (float)static_cast<const btCapsuleShape*>(shape)->getRadius();
  }
  d.friction = options.friction;
  d.drag = options.drag;
  const int n = thread->getNumLinks() + 1;
  if (options.dynamic) {
    double mass = thread->getBaseMass(), length = 0;
    for (int i = 0; i < n - 1; ++i) mass += thread->getLink(i).m_mass;
    for (size_t k = 1; k < d.points.size(); ++k) length += std::sqrt(dot(d.points[k] - d.points[k - 1], d.points[k] - d.points[k - 1]));
    // a fixed base (an anchored end) is allowed: Bullet ignores the force on it, the anchor holds it
    if (!(mass > 0))
      throw InvalidArgument("ThreadCoupling.dynamic", "true",
                            "the thread needs mass in its links; couple it with dynamic = false");
    d.linearDensity = options.addedMass ? 0.f : (float)(mass / length);  // added mass: kinematic in the scene
    d.gravity = toVec(world_->getGravity());
  } else if (options.addedMass) {
    throw InvalidArgument("ThreadCoupling.addedMass", "true", "needs dynamic = true (the tissue's push on the links)");
  }
  ThreadLink link;
  link.thread = thread;
  link.curve = scene_.addCurve(d);  // validates the thread
  link.dynamic = options.dynamic;
  link.force.assign((size_t)n, btVector3(0, 0, 0));
  link.torque.assign((size_t)n, btVector3(0, 0, 0));
  link.shareLinear.assign((size_t)n, btVector3(0, 0, 0));
  link.shareAngular.assign((size_t)n, btVector3(0, 0, 0));
  if (options.addedMass) {
    link.addedMass = true;
    for (int s = 0; s < n; ++s) {
      link.mass.push_back(s == 0 ? thread->getBaseMass() : thread->getLink(s - 1).m_mass);
      link.inertia.push_back(s == 0 ? thread->getBaseInertia() : thread->getLink(s - 1).m_inertiaLocal);
    }
    link.velocity = segmentVelocities(thread);
  }
  threads_.push_back(link);
  return link.curve;
}

CurveId Coupler::threadOf(const btMultiBody* thread) const {
  for (const ThreadLink& t : threads_)
    if (t.thread == thread) return t.curve;
  throw InvalidArgument("Coupler::threadOf thread", "not coupled", "this multibody was never added with addThread");
}

void Coupler::removeThread(const btMultiBody* thread) {
  for (size_t i = 0; i < threads_.size(); ++i)
    if (threads_[i].thread == thread) {
      ThreadLink& t = threads_[i];
      for (size_t s = 0; s < t.force.size(); ++s)
        if (!t.force[s].isZero() || !t.torque[s].isZero()) addLinkForce(t.thread, (int)s - 1, -t.force[s], -t.torque[s]);
      for (size_t s = 0; s < t.mass.size(); ++s) setSegmentMass(t.thread, (int)s, t.mass[s], t.inertia[s]);
      scene_.removeCurve(t.curve);
      threads_.erase(threads_.begin() + (long)i);
      return;
    }
}

void Coupler::setPreTickCallback(std::function<void(float)> callback) { preTickCallback_ = std::move(callback); }

void Coupler::remove(const btCollisionObject* object) {
  for (size_t i = 0; i < needles_.size(); ++i)
    if (needles_[i].frame.body == object) {
      scene_.removeCurve(needles_[i].curve);
      needles_.erase(needles_.begin() + (long)i);
      break;
    }
  if (const auto* collider = btMultiBodyLinkCollider::upcast(object))
    for (const ThreadLink& t : threads_)
      if (t.thread == collider->m_multiBody) {
        removeThread(t.thread);
        break;
      }
  for (size_t i = 0; i < slicers_.size(); ++i)
    if (slicers_[i].frame.body == object) {
      scene_.removeSlicer(slicers_[i].slicer);
      slicers_.erase(slicers_.begin() + (long)i);
      break;
    }
  for (size_t i = 0; i < links_.size(); ++i)
    if (links_[i].object == object) {
      scene_.removeShape(links_[i].shape);
      links_.erase(links_.begin() + (long)i);
      return;
    }
}

ShapeId Coupler::shapeOf(const btCollisionObject* object) const {
  for (const Link& l : links_)
    if (l.object == object) return l.shape;
  throw InvalidArgument("Coupler::shapeOf object", "not coupled", "this collision object was never added");
}

void Coupler::rethrowError() {
  std::exception_ptr e = error_;
  error_ = nullptr;
  if (e) std::rethrow_exception(e);
}

// The coupled bodies in a checkpoint's attachment: per link its kind, then a rigid body's
// transform and velocities, or (at a multibody's first link only) the multibody's base and
// joints.
namespace {

enum class BodyKind : uint8_t { Rigid, MultiBody, MultiBodyAgain, Other };

// Bullet's vector types define their own copies (not trivially copyable): their scalars go
// one by one, bit for bit
void put(checkpoint::Writer& w, const btVector3& v) {
  for (int k = 0; k < 3; ++k) w.put(v[k]);
}
void put(checkpoint::Writer& w, const btQuaternion& q) {
  for (int k = 0; k < 4; ++k) w.put(q[k]);
}
void put(checkpoint::Writer& w, const btTransform& t) {
  for (int r = 0; r < 3; ++r) put(w, t.getBasis()[r]);
  put(w, t.getOrigin());
}
btVector3 getVector(checkpoint::Reader& r, const char* what) {
  btVector3 v;
  for (int k = 0; k < 3; ++k) v[k] = r.get<btScalar>(what);
  return v;
}
btQuaternion getQuaternion(checkpoint::Reader& r, const char* what) {
  btScalar q[4];
  for (btScalar& c : q) c = r.get<btScalar>(what);
  return btQuaternion(q[0], q[1], q[2], q[3]);
}
btTransform getTransform(checkpoint::Reader& r, const char* what) {
  btMatrix3x3 basis;
  for (int row = 0; row < 3; ++row) basis[row] = getVector(r, what);
  return btTransform(basis, getVector(r, what));
}

void writeMultiBody(checkpoint::Writer& w, const btMultiBody& mb) {
  w.put((int32_t)mb.getNumLinks());
  put(w, mb.getBasePos());
  put(w, mb.getWorldToBaseRot());
  put(w, mb.getBaseVel());
  put(w, mb.getBaseOmega());
  for (int i = 0; i < mb.getNumLinks(); ++i) {
    const btMultibodyLink& l = mb.getLink(i);
    w.putArray(mb.getJointPosMultiDof(i), (size_t)l.m_posVarCount);
    w.putArray(mb.getJointVelMultiDof(i), (size_t)l.m_dofCount);
  }
}

/// A multibody's saved state, read and checked against `mb` before anything is set.
struct MultiBodyState {
  btVector3 basePos, baseVel, baseOmega;
  btQuaternion worldToBase;
  std::vector<std::vector<btScalar>> q, qd;
  bool saved = false;  ///< read at this multibody's first link

  void read(checkpoint::Reader& r, const btMultiBody& mb) {
    if (r.get<int32_t>("a multibody's link count") != mb.getNumLinks())
      throw CheckpointError(CheckpointError::Reason::Unsupported,
                            "a coupled multibody has another number of links than in the checkpoint");
    basePos = getVector(r, "a multibody's base position");
    worldToBase = getQuaternion(r, "a multibody's base rotation");
    baseVel = getVector(r, "a multibody's base velocity");
    baseOmega = getVector(r, "a multibody's base angular velocity");
    q.resize((size_t)mb.getNumLinks());
    qd.resize((size_t)mb.getNumLinks());
    for (int i = 0; i < mb.getNumLinks(); ++i) {
      r.getArray(q[(size_t)i], "a joint's positions");
      r.getArray(qd[(size_t)i], "a joint's velocities");
      const btMultibodyLink& l = mb.getLink(i);
      if (q[(size_t)i].size() != (size_t)l.m_posVarCount || qd[(size_t)i].size() != (size_t)l.m_dofCount)
        throw CheckpointError(CheckpointError::Reason::Unsupported,
                              "a coupled multibody's joint " + std::to_string(i) + " is of another kind than in the checkpoint");
    }
    saved = true;
  }
  void apply(btMultiBody& mb) const {
    mb.setBasePos(basePos);
    mb.setWorldToBaseRot(worldToBase);
    mb.setBaseVel(baseVel);
    mb.setBaseOmega(baseOmega);
    for (int i = 0; i < mb.getNumLinks(); ++i) {
      mb.setJointPosMultiDof(i, q[(size_t)i].data());
      mb.setJointVelMultiDof(i, qd[(size_t)i].data());
    }
    btAlignedObjectArray<btQuaternion> rot;
    btAlignedObjectArray<btVector3> pos;
    mb.forwardKinematics(rot, pos);
    mb.updateCollisionObjectWorldTransforms(rot, pos);
    mb.wakeUp();
  }
};

}  // namespace

void Coupler::refuseCurvesInCheckpoints() const {
  if (!needles_.empty() || !threads_.empty())
    throw CheckpointError(CheckpointError::Reason::Unsupported,
                          "a coupler with needles or threads (addNeedle, addThread) cannot be saved or loaded yet: "
                          "their curves' state is not in checkpoints");
}

std::vector<uint8_t> Coupler::bodiesAttachment() const {
  refuseCurvesInCheckpoints();
  if (intervalTick_ != 0)
    throw CheckpointError(CheckpointError::Reason::Unsupported,
                          "the tissue interval is open: the scene is " + std::to_string(tissueInterval_ - intervalTick_) +
                              " tick(s) ahead of Bullet; save between intervals");
  checkpoint::Writer w;
  w.section("coupled bodies");
  w.put((uint64_t)links_.size());
  std::vector<const btMultiBody*> written;
  for (const Link& l : links_) {
    if (l.rigid) {
      w.put(BodyKind::Rigid);
      put(w, l.rigid->getWorldTransform());
      put(w, l.rigid->getLinearVelocity());
      put(w, l.rigid->getAngularVelocity());
    } else if (l.multi) {
      const bool again = std::find(written.begin(), written.end(), l.multi) != written.end();
      w.put(again ? BodyKind::MultiBodyAgain : BodyKind::MultiBody);
      if (!again) {
        writeMultiBody(w, *l.multi);
        written.push_back(l.multi);
      }
    } else {
      w.put(BodyKind::Other);
    }
  }
  return w.finish();
}

std::vector<uint8_t> Coupler::saveToMemory() const { return scene_.saveToMemory(bodiesAttachment()); }
void Coupler::save(const std::string& path) const { scene_.save(path, bodiesAttachment()); }

void Coupler::loadFromMemory(const std::vector<uint8_t>& bytes) {
  refuseCurvesInCheckpoints();
  // read and check every body against this coupler's first, so a refusal changes nothing
  const std::vector<uint8_t> attachment = scene_.attachmentOf(bytes);
  checkpoint::Reader r(attachment.data(), attachment.size());
  r.section("coupled bodies");
  if (r.get<uint64_t>("the coupled body count") != links_.size())
    throw CheckpointError(CheckpointError::Reason::Unsupported,
                          "it holds another number of coupled bodies than this coupler's " + std::to_string(links_.size()));
  struct RigidState {
    btTransform t;
    btVector3 v, w;
  };
  std::vector<RigidState> rigid(links_.size());
  std::vector<MultiBodyState> multi(links_.size());
  for (size_t i = 0; i < links_.size(); ++i) {
    const Link& l = links_[i];
    const BodyKind kind = r.get<BodyKind>("a coupled body's kind");
    const bool matches = l.rigid ? kind == BodyKind::Rigid
                         : l.multi ? kind == BodyKind::MultiBody || kind == BodyKind::MultiBodyAgain
                                   : kind == BodyKind::Other;
    if (!matches)
      throw CheckpointError(CheckpointError::Reason::Unsupported,
                            "coupled body " + std::to_string(i) + " is of another kind than in the checkpoint");
    if (kind == BodyKind::Rigid)
    {
      rigid[i].t = getTransform(r, "a rigid body's transform");
      rigid[i].v = getVector(r, "a rigid body's velocity");
      rigid[i].w = getVector(r, "a rigid body's angular velocity");
    }
    else if (kind == BodyKind::MultiBody)
      multi[i].read(r, *l.multi);
  }
  r.finish();
  scene_.loadFromMemory(bytes);
  for (size_t i = 0; i < links_.size(); ++i) {
    const Link& l = links_[i];
    if (l.rigid) {
      l.rigid->setWorldTransform(rigid[i].t);
      l.rigid->updateInertiaTensor();  // the world inertia follows the orientation only when Bullet integrates
      l.rigid->setInterpolationWorldTransform(rigid[i].t);
      if (l.rigid->getMotionState()) l.rigid->getMotionState()->setWorldTransform(rigid[i].t);
      l.rigid->setLinearVelocity(rigid[i].v);
      l.rigid->setAngularVelocity(rigid[i].w);
      l.rigid->setInterpolationLinearVelocity(rigid[i].v);
      l.rigid->setInterpolationAngularVelocity(rigid[i].w);
      l.rigid->clearForces();
      if (l.dynamic) l.rigid->activate(true);
    } else if (multi[i].saved) {
      multi[i].apply(*l.multi);
    }
  }
  for (Link& l : links_) l.force = l.torque = btVector3(0, 0, 0);
  resetInterval();
}

void Coupler::load(const std::string& path) { loadFromMemory(checkpoint::readFile(path)); }

void Coupler::setUserTickCallback(std::function<void(float)> callback) { userCallback_ = std::move(callback); }

void Coupler::tick(float dt) {
  lastDt_ = dt;
  advancedThisTick_ = false;
  if (preTickCallback_) preTickCallback_(dt);
  if (intervalTick_ == 0) {
    advanceTissue(dt);
    advancedThisTick_ = true;
  }
  intervalTick_ = (intervalTick_ + 1) % tissueInterval_;
  applyShares(dt);
}

void Coupler::applyShares(float dt) {
  for (Link& l : links_) {
    if (!l.dynamic) continue;
    if (l.rigid) {
      l.rigid->applyCentralImpulse(l.shareLinear);
      l.rigid->applyTorqueImpulse(l.shareAngular);
      l.rigid->activate();
    } else if (l.multi) {
      // a multibody takes its share as a force over this tick
      l.force = l.shareLinear / dt;
      l.torque = l.shareAngular / dt;
      addLinkForce(l.multi, l.link, l.force, l.torque);
      l.multi->wakeUp();
    }
  }
  // a dynamic scalpel or needle takes its share, given about its tool frame's origin
  for (const SlicerLink& l : slicers_) l.frame.receive(l.share);
  for (const NeedleLink& l : needles_) l.frame.receive(l.share);
  // a thread's segments take theirs as forces over this tick on their links
  for (ThreadLink& t : threads_) {
    if (!t.dynamic) continue;
    for (size_t s = 0; s < t.force.size(); ++s) {
      t.force[s] = t.shareLinear[s] / dt;
      t.torque[s] = t.shareAngular[s] / dt;
      addLinkForce(t.thread, (int)s - 1, t.force[s], t.torque[s]);
    }
    t.thread->wakeUp();
  }
}

void Coupler::advanceTissue(float dt) {
  // 1. shapes take the bodies' poses and velocities after Bullet's step
  for (const Link& l : links_) {
    const btTransform& t = l.object->getWorldTransform();
    btVector3 v(0, 0, 0), w(0, 0, 0);
    if (l.rigid) {
      v = l.rigid->getLinearVelocity();
      w = l.rigid->getAngularVelocity();
    } else if (l.multi) {
      multiBodyLinkVelocity(l.multi, l.link, t, v, w);
    }
    scene_.setShapeState(l.shape, {toPose(t), toVec(v), toVec(w)});
  }
  for (const SlicerLink& l : slicers_) scene_.setSlicerState(l.slicer, l.frame.state());
  for (const NeedleLink& l : needles_) scene_.setCurveState(l.curve, l.frame.state());
  for (ThreadLink& t : threads_) {
    scene_.setCurvePoints(t.curve, toVecs(threadPoints(t.thread)), toVecs(threadPointVelocities(t.thread)));
    if (t.addedMass) t.advanced = segmentVelocities(t.thread);
  }
  // 2. the tissue advances over the tick (the interval's ticks) with its own substeps
  const int n = tissueInterval_;
  scene_.step(dt * (float)n);
  // 3. the momentum the grid gave each shape goes back to its body, a share per tick
  // (applyShares; J / 1 is J bit for bit with an interval of one tick)
  for (Link& l : links_) {
    if (!l.dynamic) continue;
    const ShapeImpulse J = scene_.shapeImpulse(l.shape);
    l.shareLinear = toBt(J.linear) / (btScalar)n;
    l.shareAngular = toBt(J.angular) / (btScalar)n;
  }
  auto share = [n](ShapeImpulse J) {
    const float k = (float)n;
    J.linear = {J.linear.x / k, J.linear.y / k, J.linear.z / k};
    J.angular = {J.angular.x / k, J.angular.y / k, J.angular.z / k};
    return J;
  };
  for (SlicerLink& l : slicers_) l.share = share(scene_.slicerImpulse(l.slicer));
  for (NeedleLink& l : needles_) l.share = share(scene_.curveImpulse(l.curve));
  // each thread segment's impulse (about the segment's midpoint), moved to its link's
  // centre of mass, a share per tick
  const btScalar perTick = (btScalar)n;
  for (ThreadLink& t : threads_) {
    if (!t.dynamic) continue;
    const std::vector<ShapeImpulse> J = scene_.segmentImpulses(t.curve);
    if (J.size() != t.force.size())
      throw InvalidArgument("Coupler thread", std::to_string(J.size()) + " segment impulses",
                            "expected one per segment, " + std::to_string(t.force.size()));
    const std::vector<btVector3> p = threadPoints(t.thread);
    if (t.addedMass) {
      // the segment's velocity in this advance, and the nodes it held: J = F dt - M_c dv_n,
      // where dv_n is the segment's change of velocity across itself since the advance
      // before (the held nodes followed it); Bullet's added mass M_c carries that part
      // through the interval
      const std::vector<float> Mc = scene_.segmentContactMasses(t.curve);
      for (size_t s = 0; s < J.size(); ++s) {
        const btVector3 along = (p[s + 1] - p[s]).normalized();
        const btVector3 dv = t.advanced[s] - t.velocity[s];
        const btVector3 push = toBt(J[s].linear) + Mc[s] * (dv - along * along.dot(dv));
        const btScalar scale = (t.mass[s] + Mc[s]) / t.mass[s];
        setSegmentMass(t.thread, (int)s, t.mass[s] * scale, t.inertia[s] * scale);
        const btVector3 lever = 0.5f * (p[s] + p[s + 1]) - threadSegmentTransform(t.thread, (int)s).getOrigin();
        // no torque of the tissue's own: a segment's turn is its chain's (settleBodyVelocity)
        t.shareLinear[s] = push / perTick;
        t.shareAngular[s] = lever.cross(push) / perTick;
      }
      t.velocity = t.advanced;
      continue;
    }
    for (size_t s = 0; s < J.size(); ++s) {
      const btVector3 mid = 0.5f * (p[s] + p[s + 1]);
      const btVector3 lever = mid - threadSegmentTransform(t.thread, (int)s).getOrigin();
      t.shareLinear[s] = toBt(J[s].linear) / perTick;
      t.shareAngular[s] = (toBt(J[s].angular) + lever.cross(toBt(J[s].linear))) / perTick;
    }
  }
}

namespace {
btTransform toTransform(const Pose& p) {
  return btTransform(btQuaternion(p.rotation.x, p.rotation.y, p.rotation.z, p.rotation.w), toBt(p.position));
}
}  // namespace

void Coupler::debugDraw(btIDebugDraw* drawer, const DebugDrawOptions& options) const {
  if (!drawer) drawer = world_->getDebugDrawer();
  if (!drawer || drawer->getDebugMode() == btIDebugDraw::DBG_NoDebug) return;
  if (!(options.particleSize >= 0.f) || !std::isfinite(options.particleSize))
    throw InvalidArgument("DebugDrawOptions.particleSize", std::to_string(options.particleSize), "must be finite and >= 0");
  if (options.particleStride < 1)
    throw InvalidArgument("DebugDrawOptions.particleStride", std::to_string(options.particleStride), "must be >= 1");
  const float half = 0.5f * (options.particleSize > 0.f ? options.particleSize : 0.25f * scene_.settings().dx);
  const btVector3 tissue = toBt(options.tissueColor), tool = toBt(options.toolColor);
  // the tissue: a cross through each particle, its lines along the world axes
  std::vector<Vec3f> x;
  for (const ParticleObjectId id : scene_.particleObjects()) {
    scene_.readPositions(id, x);
    for (size_t i = 0; i < x.size(); i += (size_t)options.particleStride)
      for (int axis = 0; axis < 3; ++axis) {
        btVector3 h(0, 0, 0);
        h[axis] = half;
        drawer->drawLine(toBt(x[i]) - h, toBt(x[i]) + h, tissue);
      }
  }
  // blades: edge, ends and spine's axis as the scene moved them (the coupler takes quad
  // blades only, so there is no mesh blade to draw)
  for (const SlicerLink& l : slicers_) {
    const btTransform t = toTransform(scene_.slicerState(l.slicer).pose);
    const btScalar a = l.blade.halfLength, w = l.blade.width;
    const btVector3 corner[4] = {t * btVector3(-a, 0, 0), t * btVector3(a, 0, 0), t * btVector3(a, w, 0),
                                 t * btVector3(-a, w, 0)};
    for (int k = 0; k < 4; ++k) drawer->drawLine(corner[k], corner[(k + 1) % 4], tool);
  }
  // needles: the wire's centre line, tail to tip, in the arc's x-y plane
  for (const NeedleLink& l : needles_) {
    const btTransform t = toTransform(scene_.curveState(l.curve).pose);
    const ArcDesc& arc = l.needle;
    auto at = [&](float angle) { return t * btVector3(arc.radius * std::cos(angle), arc.radius * std::sin(angle), 0); };
    const int segments = 32;
    for (int k = 0; k < segments; ++k)
      drawer->drawLine(at(arc.startAngle + (arc.endAngle - arc.startAngle) * k / segments),
                       at(arc.startAngle + (arc.endAngle - arc.startAngle) * (k + 1) / segments), tool);
  }
  // threads: the chain as it is now (the points the scene takes at the next tick)
  for (const ThreadLink& t : threads_) {
    const std::vector<btVector3> p = threadPoints(t.thread);
    for (size_t k = 1; k < p.size(); ++k) drawer->drawLine(p[k - 1], p[k], toBt(options.threadColor));
  }
}

}  // namespace mpm::bullet
