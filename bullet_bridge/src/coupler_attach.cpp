// Coupling and uncoupling (coupler.h): rigid bodies and multibody links as scene shapes,
// blades, needles and threads as the scene's slicers and curves, and their removal.
#include "coupler_links.h"

#include <BulletDynamics/Featherstone/btMultiBodyLinkCollider.h>

#include <cmath>
#include <string>

namespace mpm::bullet {

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

}  // namespace mpm::bullet
