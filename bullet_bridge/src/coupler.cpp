// Coupler's tick (coupler.h): Bullet's internal tick hooks, the scene advanced over an
// interval of ticks with the bodies' poses and velocities, and the momentum the grid gave
// each shape handed back to its body, a share per tick.
#include "coupler_links.h"

#include <string>

namespace mpm::bullet {

namespace {

void preTick(btDynamicsWorld* world, btScalar dt) {
  static_cast<Coupler*>(world->getWorldUserInfo())->hookedTick((float)dt, true);
}

void postTick(btDynamicsWorld* world, btScalar dt) {
  static_cast<Coupler*>(world->getWorldUserInfo())->hookedTick((float)dt, false);
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

void Coupler::rethrowError() {
  std::exception_ptr e = error_;
  error_ = nullptr;
  if (e) std::rethrow_exception(e);
}

void Coupler::setPreTickCallback(std::function<void(float)> callback) { preTickCallback_ = std::move(callback); }

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

}  // namespace mpm::bullet
