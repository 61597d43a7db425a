// The coupled bodies in a checkpoint (coupler.h: save, load): each link's rigid body or
// multibody state as the scene checkpoint's attachment, read and checked whole before
// anything is set.
#include "coupler_links.h"

#include <algorithm>
#include <string>

#include "mpm/checkpoint_io.h"

namespace mpm::bullet {

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

/// A rigid body's saved pose and velocities.
struct RigidState {
  btTransform t;
  btVector3 v, w;

  static void write(checkpoint::Writer& w, const btRigidBody& b) {
    put(w, b.getWorldTransform());
    put(w, b.getLinearVelocity());
    put(w, b.getAngularVelocity());
  }
  void read(checkpoint::Reader& r) {
    t = getTransform(r, "a rigid body's transform");
    v = getVector(r, "a rigid body's velocity");
    w = getVector(r, "a rigid body's angular velocity");
  }
  void apply(btRigidBody& b, bool dynamic) const {
    b.setWorldTransform(t);
    b.updateInertiaTensor();  // the world inertia follows the orientation only when Bullet integrates
    b.setInterpolationWorldTransform(t);
    if (b.getMotionState()) b.getMotionState()->setWorldTransform(t);
    b.setLinearVelocity(v);
    b.setAngularVelocity(w);
    b.setInterpolationLinearVelocity(v);
    b.setInterpolationAngularVelocity(w);
    b.clearForces();
    if (dynamic) b.activate(true);
  }
};

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

std::vector<uint8_t> Coupler::bodiesAttachment() const {
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
      RigidState::write(w, *l.rigid);
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
  // the tools: the bodies that carry blades and needles (a body coupled above as well is
  // written twice, the same state), each thread's chain and what its added mass keeps
  // from one advance to the next
  w.section("coupled tools");
  w.put((uint64_t)slicers_.size());
  for (const SlicerLink& l : slicers_) RigidState::write(w, *l.frame.body);
  w.put((uint64_t)needles_.size());
  for (const NeedleLink& l : needles_) RigidState::write(w, *l.frame.body);
  w.put((uint64_t)threads_.size());
  for (const ThreadLink& t : threads_) {
    writeMultiBody(w, *t.thread);
    w.put((uint64_t)t.velocity.size());
    for (const btVector3& v : t.velocity) put(w, v);
  }
  return w.finish();
}

std::vector<uint8_t> Coupler::saveToMemory() const { return scene_.saveToMemory(bodiesAttachment()); }
void Coupler::save(const std::string& path) const { scene_.save(path, bodiesAttachment()); }

void Coupler::loadFromMemory(const std::vector<uint8_t>& bytes) {
  // read and check every body against this coupler's first, so a refusal changes nothing
  const std::vector<uint8_t> attachment = scene_.attachmentOf(bytes);
  checkpoint::Reader r(attachment.data(), attachment.size());
  r.section("coupled bodies");
  if (r.get<uint64_t>("the coupled body count") != links_.size())
    throw CheckpointError(CheckpointError::Reason::Unsupported,
                          "it holds another number of coupled bodies than this coupler's " + std::to_string(links_.size()));
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
      rigid[i].read(r);
    else if (kind == BodyKind::MultiBody)
      multi[i].read(r, *l.multi);
  }
  r.section("coupled tools");
  auto count = [&](size_t mine, const char* what) {
    if (r.get<uint64_t>(what) != mine)
      throw CheckpointError(CheckpointError::Reason::Unsupported,
                            std::string("it holds another number of ") + what + " than this coupler's " +
                                std::to_string(mine));
  };
  count(slicers_.size(), "coupled slicers");
  std::vector<RigidState> slicerBodies(slicers_.size()), needleBodies(needles_.size());
  for (RigidState& b : slicerBodies) b.read(r);
  count(needles_.size(), "coupled needles");
  for (RigidState& b : needleBodies) b.read(r);
  count(threads_.size(), "coupled threads");
  std::vector<MultiBodyState> chains(threads_.size());
  std::vector<std::vector<btVector3>> velocities(threads_.size());
  for (size_t i = 0; i < threads_.size(); ++i) {
    chains[i].read(r, *threads_[i].thread);
    velocities[i].resize(r.get<uint64_t>("a thread's segment velocity count"));
    if (velocities[i].size() != threads_[i].velocity.size())
      throw CheckpointError(CheckpointError::Reason::Unsupported,
                            "coupled thread " + std::to_string(i) + "'s added mass is not as in the checkpoint");
    for (btVector3& v : velocities[i]) v = getVector(r, "a thread segment's velocity");
  }
  r.finish();
  scene_.loadFromMemory(bytes);
  for (size_t i = 0; i < links_.size(); ++i) {
    const Link& l = links_[i];
    if (l.rigid)
      rigid[i].apply(*l.rigid, l.dynamic);
    else if (multi[i].saved)
      multi[i].apply(*l.multi);
  }
  for (size_t i = 0; i < slicers_.size(); ++i)
    slicerBodies[i].apply(*slicers_[i].frame.body, !slicers_[i].frame.body->isStaticOrKinematicObject());
  for (size_t i = 0; i < needles_.size(); ++i)
    needleBodies[i].apply(*needles_[i].frame.body, !needles_[i].frame.body->isStaticOrKinematicObject());
  for (size_t i = 0; i < threads_.size(); ++i) {
    chains[i].apply(*threads_[i].thread);
    threads_[i].velocity = velocities[i];
  }
  for (Link& l : links_) l.force = l.torque = btVector3(0, 0, 0);
  resetInterval();
}

void Coupler::load(const std::string& path) { loadFromMemory(checkpoint::readFile(path)); }

}  // namespace mpm::bullet
