#include "thread_bending.h"

#include <BulletDynamics/Featherstone/btMultiBodyLinkCollider.h>

#include <algorithm>
#include <cmath>

namespace mpm::bullet {

namespace {

/// The rows: three a joint along its degrees of freedom (bending), then two a segment
/// across it (the tension's geometric stiffness).
int rowCount(const btMultiBody* mb) { return 3 * mb->getNumLinks() + 2 * (mb->getNumLinks() + 1); }

/// A spherical joint's turn.
btVector3 jointTurn(const btMultiBody* mb, int link) {
  const btScalar* q = mb->getJointPosMultiDof(link);
  return rotationVector(btQuaternion(q[0], q[1], q[2], q[3]));
}

/// Segment s's world frame (0: the base, s: link s - 1); a copy, as the base's transform
/// is itself made on the fly.
btMatrix3x3 segmentBasis(const btMultiBody* mb, int s) {
  return s == 0 ? mb->getBaseWorldTransform().getBasis() : mb->getLink(s - 1).m_cachedWorldTransform.getBasis();
}

/// Segment s's moment about its transverse axes.
btScalar transverseMoment(const btMultiBody* mb, int s) {
  return s == 0 ? mb->getBaseInertia().y() : mb->getLink(s - 1).m_inertiaLocal.y();
}

}  // namespace

btVector3 rotationVector(btQuaternion q) {
  if (q.w() < 0) q = -q;
  const btVector3 v(q.x(), q.y(), q.z());
  const btScalar s = v.length();
  return s > 1e-9f ? v * (2 * std::atan2(s, q.w()) / s) : 2 * v;
}

ThreadBending::ThreadBending(btMultiBodyDynamicsWorld* world, btMultiBody* thread, btScalar stiffness,
                             btScalar segmentLength)
    : btMultiBodyConstraint(thread, thread, -1, -1, rowCount(thread), false, MULTIBODY_CONSTRAINT_SPHERICAL_MOTOR),
      world_(world),
      stiffness_(stiffness),
      segmentLength_(segmentLength),
      feedback_((size_t)thread->getNumLinks()),
      tension_((size_t)thread->getNumLinks() + 1, 0),
      free_((size_t)thread->getNumLinks(), 0),
      pinned_((size_t)thread->getNumLinks(), 0),
      other_((size_t)thread->getNumLinks(), 0),
      own_((size_t)thread->getNumLinks(), 0),
      pull_((size_t)thread->getNumLinks() + 1),
      omega_((size_t)thread->getNumLinks() + 1),
      velocity_((size_t)thread->getNumLinks() + 1),
      motion_((size_t)thread->getNumLinks(), 0),
      saved_((size_t)thread->getNumLinks()) {
  m_maxAppliedImpulse = BT_LARGE_FLOAT;
  for (int link = 0; link < thread->getNumLinks(); ++link) {
    feedback_[(size_t)link].m_reactionForces.setZero();
    thread->getLink(link).m_jointFeedback = &feedback_[(size_t)link];
  }
}

ThreadBending::~ThreadBending() {
  for (ThreadPin* pin : pins_) pin->bending_ = nullptr;
  for (int link = 0; link < m_bodyA->getNumLinks(); ++link) m_bodyA->getLink(link).m_jointFeedback = nullptr;
}

void ThreadBending::finalizeMultiDof() {
  allocateJacobiansMultiDof();  // zeroed: row 3 i + a is link i's joint rate about axis a
  for (int link = 0; link < m_bodyA->getNumLinks(); ++link)
    for (int a = 0; a < 3; ++a) jacobianA(3 * link + a)[6 + m_bodyA->getLink(link).m_dofOffset + a] = 1;
  m_numDofsFinalized = m_jacSizeBoth;
}

int ThreadBending::getIslandIdA() const {
  const btMultiBodyLinkCollider* c = m_bodyA->getBaseCollider();
  return c ? c->getIslandTag() : -1;
}
int ThreadBending::getIslandIdB() const { return getIslandIdA(); }

void ThreadBending::updateAction(btCollisionWorld*, btScalar) {
  // what the constraints (pins, contacts) added to each joint's force over the tick just
  // solved: Bullet's joint feedback after its constraint pass, less its unconstrained pass
  // and the velocity products the constraint pass counted again
  for (int link = 0; link < m_bodyA->getNumLinks(); ++link)
    pinned_[(size_t)link] = jointTension(link) - free_[(size_t)link] - motion_[(size_t)link];
  // the pins' impulses this object applied, added to what the solver's iterations added
  for (ThreadPin* pin : pins_)
    for (int d = 0; d < 3; ++d) {
      if (pin->applied_[d] != 0) pin->internalSetAppliedImpulse(d, pin->getAppliedImpulse(d) + pin->applied_[d]);
      pin->applied_[d] = 0;
    }
}

void ThreadBending::makePinRows(btMultiBodyConstraintArray& rows, btMultiBodyJacobianData& data,
                                const btContactSolverInfo& info) {
  pinRows_.clear();
  for (ThreadPin* pin : pins_) {
    bool inWorld = false;
    for (int i = 0; i < world_->getNumMultiBodyConstraints() && !inWorld; ++i)
      inWorld = world_->getMultiBodyConstraint(i) == pin;
    if (!inWorld) continue;
    const int start = rows.size();
    pinRows_.emplace_back(pin, start);
    pin->btMultiBodyPoint2Point::createConstraintRows(rows, data, info);
    // Bullet's rows between a multibody and a rigid body leave out the rigid body's
    // forces of this tick (its solver body adds them after the solve): a 1 g hand pushed
    // with 8 N ran 43 mm off its pin at 1/960 s. Its rows here take them in.
    for (int r = start; r < rows.size(); ++r) {
      btMultiBodySolverConstraint& c = rows[r];
      if (c.m_solverBodyIdB < 0) continue;
      const btSolverBody& b = data.m_solverBodyPool->at(c.m_solverBodyIdB);
      c.m_rhs -= (c.m_contactNormal2.dot(b.m_externalForceImpulse) +
                  c.m_relpos2CrossNormal.dot(b.m_externalTorqueImpulse)) * c.m_jacDiagABInv;
    }
  }
}

btScalar ThreadBending::jointTension(int link) const {
  return -feedback_[(size_t)link].m_reactionForces.m_topVec.x();
}

void ThreadBending::createConstraintRows(btMultiBodyConstraintArray& rows, btMultiBodyJacobianData& data,
                                         const btContactSolverInfo& info) {
  if (m_numDofsFinalized != m_jacSizeBoth) finalizeMultiDof();
  makePinRows(rows, data, info);
  const btScalar dt = info.m_timeStep;
  if (!(dt > 0)) return;
  const int links = m_bodyA->getNumLinks(), ndof = m_bodyA->getNumDofs() + 6;
  // each segment's tension: its inner joint's force along it, the forces' share of this
  // tick (the unconstrained pass), the contacts' of the last and the pins' (their share of
  // the last tick until this tick's solve gives it; the base: its outer joint's)
  for (int link = 0; link < links; ++link) {
    free_[(size_t)link] = jointTension(link);
    other_[(size_t)link] = pinned_[(size_t)link] - own_[(size_t)link];
    tension_[(size_t)link + 1] = free_[(size_t)link] + pinned_[(size_t)link];
  }
  std::fill(own_.begin(), own_.end(), 0);
  // Bullet's constraint pass (after the solve) adds the velocity products (centripetal,
  // Coriolis, gyroscopic) to the feedback a second time; the same pass now, before any
  // constraint force is in, measures that share for updateAction to take out
  for (int link = 0; link < links; ++link) saved_[(size_t)link] = feedback_[(size_t)link].m_reactionForces;
  m_bodyA->computeAccelerationsArticulatedBodyAlgorithmMultiDof(dt, scratchR_, scratchV_, scratchM_, true,
                                                                info.m_jointFeedbackInWorldSpace,
                                                                info.m_jointFeedbackInJointFrame);
  for (int link = 0; link < links; ++link) {
    motion_[(size_t)link] = jointTension(link) - free_[(size_t)link];
    feedback_[(size_t)link].m_reactionForces = saved_[(size_t)link];
  }
  tension_[0] = links > 0 ? tension_[1] : 0;
  // The unknowns: the bending rows (3 a joint), the pins' (hard), the tension's (2 a
  // segment, below)
  const int first = rows.size(), bending = bendingRows();
  rhs_.resize(bending + 3 * (int)pinRows_.size() + 2 * (links + 1));
  row_.clear();
  for (int r = 0; r < bending; ++r) {
    // the spring's stretch: the joint's turn
    const btScalar x = jointTurn(m_bodyA, r / 3)[r % 3];
    rhs_[(int)row_.size()] = -(x / dt + ownRow(rows, data, info, r));
    row_.push_back(first + r);
  }
  for (const auto& [pin, start] : pinRows_)
    for (int d = 0; d < 3; ++d) {
      // a pin's row: the rate its solver row asks for (its position error included)
      const btMultiBodySolverConstraint& p = rows[start + d];
      rhs_[(int)row_.size()] = p.m_jacDiagABInv != 0 ? p.m_rhs / p.m_jacDiagABInv : 0;
      row_.push_back(start + d);
    }
  const int held = (int)row_.size();
  gamma_.resize(rhs_.size());
  for (int i = 0; i < held; ++i) gamma_[i] = i < bending ? 1 / (stiffness_ * dt * dt) : 0;
  response(rows, data, 0, held);
  // With pins, their share of this tick first, from a solve with the bending springs and
  // pins alone (B, the block of A they make).
  if (held > 0) {
    B_ = A_.topLeftCorner(held, held);
    B_.diagonal() += gamma_.head(held);
    ldlt_.compute(B_);
    if (!pinRows_.empty()) {
      lambda_ = ldlt_.solve(rhs_.head(held));
      pinShare(rows, data, bending, held, dt);
      sumTension();
    }
  }
  // The tension's rows only when a turn could outrun the tick (below); a thread whose
  // segments alone turn 3 times slower than that (omega dt < 1/6, omega^2 = T_s L / I_s,
  // I_s a segment's transverse moment) pays for none: the chain's turns couple
  // neighbouring segments, but measured no further (a pinned thread whipping under
  // gravity gained 6 M g length / 2 with the cut at 1/2).
  const int firstPulled = m_bodyA->hasFixedBase() ? 1 : 0;
  double alone = 0;
  for (int s = firstPulled; s <= links; ++s)
    alone = std::max(alone, (double)(tension_[(size_t)s] * segmentLength_ * dt * dt / transverseMoment(m_bodyA, s)));
  for (int s = firstPulled; s <= links && alone > 0.25 / 9; ++s) {
    if (!(tension_[(size_t)s] > 0)) continue;
    const btMatrix3x3 basis = segmentBasis(m_bodyA, s);
    for (int a = 0; a < 2; ++a) {
      const int r = 3 * links + 2 * s + a;
      btScalar* jac = jacobianA(r);
      for (int i = 0; i < ndof; ++i) jac[i] = 0;
      m_bodyA->fillConstraintJacobianMultiDof(s - 1, btVector3(0, 0, 0), basis.getColumn(a + 1), btVector3(0, 0, 0), jac,
                                              scratchR_, scratchV_, scratchM_);
      rhs_[(int)row_.size()] = -ownRow(rows, data, info, r);  // rate only
      row_.push_back(rows.size() - 1);
    }
  }
  int m = (int)row_.size();
  if (m == 0) return;
  const int pulled = m - held;
  // The tension's rows only when a turn would outrun the tick: omega dt > 1/2 for some
  // mode, omega^2 the eigenvalues of K S (K the rows' stiffness, S their response with the
  // springs and pins answering: a Schur complement), bounded above by the largest row sum
  // (Gershgorin). Slower turns Bullet integrates explicitly (symplectic Euler keeps their
  // energy; the implicit rows take (omega dt)^2 of it a tick).
  if (pulled > 0) {
    response(rows, data, held, m);
    pullStiffness(rows, held, m, dt);
    S_ = A_.bottomRightCorner(pulled, pulled);
    if (held > 0) {
      BinvC_ = ldlt_.solve(A_.topRightCorner(held, pulled));
      product_.noalias() = A_.bottomLeftCorner(pulled, held) * BinvC_;
      S_ -= product_;
    }
    double fastest = 0;
    for (int i = 0; i < pulled; ++i) fastest = std::max(fastest, S_.row(i).cwiseAbs().sum() / gamma_[held + i]);
    if (fastest < 0.25) {
      m = held;
      rows.resize(first + bending);
      if (m == 0) return;
    }
  }
  // the whole solve; with pins, again with the tension their impulses give (twice: the
  // tension's rows then hold the pull a pin brings the same tick). Without the tension's
  // rows it is B's, factored above (and solved, with pins).
  if (m == held) {
    if (pinRows_.empty()) lambda_ = ldlt_.solve(rhs_.head(m));
  } else {
    for (int pass = 0;; ++pass) {
      product_ = A_.topLeftCorner(m, m);
      product_.diagonal() += gamma_.head(m);
      ldlt_.compute(product_);
      lambda_ = ldlt_.solve(rhs_.head(m));
      if (pinRows_.empty() || pass == 2) break;
      pinShare(rows, data, bending, held, dt);
      pullStiffness(rows, held, m, dt);
    }
    if (!pinRows_.empty()) pinShare(rows, data, bending, held, dt);
  }
  // The solution is applied as Bullet's warm start applies an impulse (to the body after
  // the solve, and to the solver's accumulator now); each of this object's rows then
  // carries a correction mu, a soft row (c.m_cfm = gamma c.m_jacDiagABInv) whose fixed
  // point is
  //   (A (lambda + mu))_r + gamma (lambda_r + mu_r) + (contacts' share)_r = rhs_r,
  // and a pin's row (hard) adds what the contacts change; the iterations start from the
  // exact solution for the chain and its pins (the solver zeroes a row's own start, so
  // what a pin applied here is added to its impulse after the step, and to the joint
  // feedback's constraint forces now).
  for (int i = 0; i < m; ++i) {
    btMultiBodySolverConstraint& c = rows[row_[i]];
    const btScalar impulse = (btScalar)lambda_[i];
    btScalar* dv = &data.m_deltaVelocitiesUnitImpulse[c.m_jacAindex];
    m_bodyA->applyDeltaVeeMultiDof2(dv, impulse);
    for (int k = 0; k < ndof; ++k) data.m_deltaVelocities[c.m_deltaVelAindex + k] += dv[k] * impulse;
    if (c.m_orgConstraint == this) {
      const btScalar gamma = (btScalar)gamma_[i];
      const btScalar D = c.m_jacDiagABInv > 0 ? 1 / c.m_jacDiagABInv : 0;
      c.m_jacDiagABInv = 1 / (D + gamma);
      c.m_rhs = (btScalar)(rhs_[i] - gamma_[i] * lambda_[i]) * c.m_jacDiagABInv;
      c.m_rhsPenetration = 0;
      c.m_cfm = gamma * c.m_jacDiagABInv;
      continue;
    }
    auto* pin = static_cast<ThreadPin*>(c.m_orgConstraint);
    pin->applied_[c.m_orgDofIndex] += impulse;
    if (c.m_solverBodyIdB >= 0) {
      btSolverBody& b = data.m_solverBodyPool->at(c.m_solverBodyIdB);
      b.internalApplyImpulse(c.m_contactNormal2 * b.internalGetInvMass(), c.m_angularComponentB, impulse);
    }
    const btVector3 force = c.m_contactNormal1 * (impulse / dt), torque = c.m_relpos1CrossNormal * (impulse / dt);
    if (pin->getLinkA() < 0) {
      m_bodyA->addBaseConstraintForce(force);
      m_bodyA->addBaseConstraintTorque(torque);
    } else {
      m_bodyA->addLinkConstraintForce(pin->getLinkA(), force);
      m_bodyA->addLinkConstraintTorque(pin->getLinkA(), torque);
    }
  }
}

btScalar ThreadBending::ownRow(btMultiBodyConstraintArray& rows, btMultiBodyJacobianData& data,
                               const btContactSolverInfo& info, int r) {
  btMultiBodySolverConstraint& c = rows.expandNonInitializing();
  c.m_orgConstraint = this;
  c.m_orgDofIndex = r;
  const btVector3 zero(0, 0, 0);
  return fillMultiBodyConstraint(c, data, jacobianA(r), jacobianB(r), zero, zero, zero, zero, 0, info,
                                 -m_maxAppliedImpulse, m_maxAppliedImpulse);
}

void ThreadBending::response(const btMultiBodyConstraintArray& rows, const btMultiBodyJacobianData& data, int from,
                             int to) {
  // A: row i's rate after a unit impulse on row j (symmetric: J M^-1 J^T, and the pinning
  // body's share for two rows of pins on the same body), for the unknowns from `from` up
  // to `to` against those before; a bending row's Jacobian is one joint axis, so its rate
  // is read off the response
  const int bending = bendingRows(), ndof = m_bodyA->getNumDofs() + 6;
  A_.conservativeResize(to, to);
  for (int j = 0; j < to; ++j) {
    const btMultiBodySolverConstraint& cj = rows[row_[j]];
    const btScalar* dv = &data.m_deltaVelocitiesUnitImpulse[cj.m_jacAindex];
    for (int i = j < from ? from : 0; i < to; ++i) {
      if (i < bending) {
        A_(i, j) = dv[6 + m_bodyA->getLink(i / 3).m_dofOffset + i % 3];
        continue;
      }
      const btMultiBodySolverConstraint& ci = rows[row_[i]];
      const btScalar* J = &data.m_jacobians[ci.m_jacAindex];
      double s = 0;
      for (int k = 0; k < ndof; ++k) s += (double)J[k] * dv[k];
      if (ci.m_orgConstraint != this && cj.m_orgConstraint != this && ci.m_solverBodyIdB == cj.m_solverBodyIdB &&
          ci.m_solverBodyIdB >= 0) {
        const btSolverBody& b = data.m_solverBodyPool->at(ci.m_solverBodyIdB);
        s += ci.m_contactNormal2.dot(cj.m_contactNormal2 * b.internalGetInvMass() * b.m_linearFactor) +
             ci.m_relpos2CrossNormal.dot(cj.m_angularComponentB * b.m_angularFactor);
      }
      A_(i, j) = s;
    }
  }
}

void ThreadBending::pinShare(const btMultiBodyConstraintArray& rows, const btMultiBodyJacobianData& data, int bending,
                             int held, btScalar dt) {
  // the chain's change of rate from the pins' impulses alone (as Bullet's constraint
  // pass sees them), each link's change of velocity (Featherstone's outward pass, in the
  // link's frame) and the pins' impulses on each link
  const int links = m_bodyA->getNumLinks(), ndof = m_bodyA->getNumDofs() + 6;
  rate_.assign((size_t)ndof, 0);
  std::fill(pull_.begin(), pull_.end(), btVector3(0, 0, 0));
  for (int i = bending; i < held; ++i) {
    const btMultiBodySolverConstraint& c = rows[row_[i]];
    const btScalar* dv = &data.m_deltaVelocitiesUnitImpulse[c.m_jacAindex];
    for (int k = 0; k < ndof; ++k) rate_[(size_t)k] += dv[k] * (btScalar)lambda_[i];
    pull_[(size_t)c.m_linkA + 1] += c.m_contactNormal1 * (btScalar)lambda_[i];
  }
  const btQuaternion toBase = m_bodyA->getWorldToBaseRot();
  omega_[0] = quatRotate(toBase, btVector3(rate_[0], rate_[1], rate_[2]));
  velocity_[0] = quatRotate(toBase, btVector3(rate_[3], rate_[4], rate_[5]));
  for (int link = 0; link < links; ++link) {
    const btMultibodyLink& l = m_bodyA->getLink(link);
    const btMatrix3x3 rot(l.m_cachedRotParentToThis);
    btVector3& w = omega_[(size_t)link + 1];
    btVector3& v = velocity_[(size_t)link + 1];
    w = rot * omega_[(size_t)l.m_parent + 1];
    v = rot * velocity_[(size_t)l.m_parent + 1] - l.m_cachedRVector.cross(w);
    for (int d = 0; d < l.m_dofCount; ++d) {
      w += rate_[(size_t)(6 + l.m_dofOffset + d)] * l.getAxisTop(d);
      v += rate_[(size_t)(6 + l.m_dofOffset + d)] * l.getAxisBottom(d);
    }
  }
  // a joint's share: the momentum its outer links gained less the pins' impulses on
  // them, over the tick, along its link (pulling the outer links in: tension)
  btVector3 outer(0, 0, 0);
  for (int link = links - 1; link >= 0; --link) {
    const btMatrix3x3& basis = m_bodyA->getLink(link).m_cachedWorldTransform.getBasis();
    outer += basis * velocity_[(size_t)link + 1] * m_bodyA->getLinkMass(link) - pull_[(size_t)link + 1];
    own_[(size_t)link] = -basis.getColumn(0).dot(outer) / dt;
  }
}

void ThreadBending::sumTension() {
  const int links = m_bodyA->getNumLinks();
  for (int link = 0; link < links; ++link)
    tension_[(size_t)link + 1] = free_[(size_t)link] + other_[(size_t)link] + own_[(size_t)link];
  tension_[0] = links > 0 ? tension_[1] : 0;
}

void ThreadBending::pullStiffness(const btMultiBodyConstraintArray& rows, int held, int m, btScalar dt) {
  sumTension();
  // a row under no tension (or compression) does nothing: its compliance is made huge
  const int links = m_bodyA->getNumLinks();
  for (int i = held; i < m; ++i) {
    const int s = (rows[row_[i]].m_orgDofIndex - 3 * links) / 2;
    const double k = std::max((double)tension_[(size_t)s] * segmentLength_, 1e-20);
    gamma_[i] = 1 / (k * dt * dt);
  }
}

ThreadPin::ThreadPin(ThreadBending* bending, int link, btRigidBody* body, const btVector3& pivotInLink,
                     const btVector3& pivotInBody)
    : btMultiBodyPoint2Point(bending->getMultiBodyA(), link, body, pivotInLink, pivotInBody), bending_(bending) {
  bending->pins_.push_back(this);
}

ThreadPin::~ThreadPin() {
  if (bending_) bending_->pins_.erase(std::find(bending_->pins_.begin(), bending_->pins_.end(), this));
}

void ThreadPin::createConstraintRows(btMultiBodyConstraintArray& rows, btMultiBodyJacobianData& data,
                                     const btContactSolverInfo& info) {
  if (!bending_) btMultiBodyPoint2Point::createConstraintRows(rows, data, info);
}

}  // namespace mpm::bullet
