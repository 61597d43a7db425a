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

ThreadBending::ThreadBending(btMultiBody* thread, btScalar stiffness, btScalar segmentLength)
    : btMultiBodyConstraint(thread, thread, -1, -1, rowCount(thread), false, MULTIBODY_CONSTRAINT_SPHERICAL_MOTOR),
      stiffness_(stiffness),
      segmentLength_(segmentLength),
      feedback_((size_t)thread->getNumLinks()),
      tension_((size_t)thread->getNumLinks() + 1, 0),
      free_((size_t)thread->getNumLinks(), 0),
      pinned_((size_t)thread->getNumLinks(), 0),
      motion_((size_t)thread->getNumLinks(), 0),
      saved_((size_t)thread->getNumLinks()) {
  m_maxAppliedImpulse = BT_LARGE_FLOAT;
  for (int link = 0; link < thread->getNumLinks(); ++link) {
    feedback_[(size_t)link].m_reactionForces.setZero();
    thread->getLink(link).m_jointFeedback = &feedback_[(size_t)link];
  }
}

ThreadBending::~ThreadBending() {
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
}

btScalar ThreadBending::jointTension(int link) const {
  return -feedback_[(size_t)link].m_reactionForces.m_topVec.x();
}

void ThreadBending::createConstraintRows(btMultiBodyConstraintArray& rows, btMultiBodyJacobianData& data,
                                         const btContactSolverInfo& info) {
  if (m_numDofsFinalized != m_jacSizeBoth) finalizeMultiDof();
  const btScalar dt = info.m_timeStep;
  if (!(dt > 0)) return;
  const int links = m_bodyA->getNumLinks(), ndof = m_bodyA->getNumDofs() + 6;
  // which rows act this tick, and each one's stiffness
  active_.clear();
  stiff_.clear();
  if (stiffness_ > 0)
    for (int r = 0; r < 3 * links; ++r) active_.push_back(r), stiff_.push_back(stiffness_);
  // each segment's tension: its inner joint's force along it, the forces' share of this
  // tick (the unconstrained pass) and the constraints' of the last (the base: its outer
  // joint's)
  for (int link = 0; link < links; ++link) {
    free_[(size_t)link] = jointTension(link);
    tension_[(size_t)link + 1] = free_[(size_t)link] + pinned_[(size_t)link];
  }
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
  // The tension's rows only when a turn would outrun the tick (below). A thread whose
  // segments alone turn 3 times slower than that (omega dt < 1/6, omega^2 = T_s L / I_s,
  // I_s a segment's transverse moment) pays for none: the chain's turns couple
  // neighbouring segments, but measured no further (a pinned thread whipping under
  // gravity gained 6 M g length / 2 with the cut at 1/2).
  const int firstPulled = m_bodyA->hasFixedBase() ? 1 : 0;
  double alone = 0;
  for (int s = firstPulled; s <= links; ++s)
    alone = std::max(alone, (double)(tension_[(size_t)s] * segmentLength_ * dt * dt / transverseMoment(m_bodyA, s)));
  for (int s = firstPulled; s <= links && alone > 0.25 / 9; ++s) {
    const btScalar k = tension_[(size_t)s] * segmentLength_;
    if (!(k > 0)) continue;
    const btMatrix3x3 basis = segmentBasis(m_bodyA, s);
    for (int a = 0; a < 2; ++a) {
      const int r = 3 * links + 2 * s + a;
      btScalar* jac = jacobianA(r);
      for (int i = 0; i < ndof; ++i) jac[i] = 0;
      m_bodyA->fillConstraintJacobianMultiDof(s - 1, btVector3(0, 0, 0), basis.getColumn(a + 1), btVector3(0, 0, 0), jac,
                                              scratchR_, scratchV_, scratchM_);
      active_.push_back(r), stiff_.push_back(k);
    }
  }
  const int candidates = (int)active_.size();
  if (candidates == 0) return;
  const int first = rows.size();
  rhs_.resize(candidates);
  response_.resize(candidates);
  const btVector3 zero(0, 0, 0);
  btVector3 turn(0, 0, 0);
  for (int i = 0; i < candidates; ++i) {
    const int r = active_[i];
    btMultiBodySolverConstraint& c = rows.expandNonInitializing();
    c.m_orgConstraint = this;
    c.m_orgDofIndex = r;
    // the row's rate after the unconstrained step, and its unit response
    const btScalar u = fillMultiBodyConstraint(c, data, jacobianA(r), jacobianB(r), zero, zero, zero, zero, 0, info,
                                               -m_maxAppliedImpulse, m_maxAppliedImpulse);
    response_[i] = c.m_jacAindex;
    btScalar x = 0;  // the spring's stretch: a joint's turn; the tension's rows act on the rate alone
    if (r < 3 * links) {
      if (r % 3 == 0) turn = jointTurn(m_bodyA, r / 3);
      x = turn[r % 3];
    }
    rhs_[i] = -(x / dt + u);
  }
  int m = candidates;
  // A: row i's rate after a unit impulse on row j (symmetric: J M^-1 J^T); a bending
  // row's Jacobian is one joint axis, so its rate is read off the response
  A_.resize(m, m);
  for (int j = 0; j < m; ++j) {
    const btScalar* dv = &data.m_deltaVelocitiesUnitImpulse[response_[j]];
    for (int i = 0; i < m; ++i) {
      const int r = active_[i];
      if (r < 3 * links) {
        A_(i, j) = dv[6 + m_bodyA->getLink(r / 3).m_dofOffset + r % 3];
        continue;
      }
      const btScalar* J = &data.m_jacobians[rows[first + i].m_jacAindex];
      double s = 0;
      for (int k = 0; k < ndof; ++k) s += (double)J[k] * dv[k];
      A_(i, j) = s;
    }
  }
  // The tension's rows only when a turn would outrun the tick: omega dt > 1/2 for some
  // mode, omega^2 the eigenvalues of K S (K the rows' stiffness, S their response with the
  // bending springs answering: a Schur complement), bounded above by the largest row sum
  // (Gershgorin). Slower turns Bullet integrates explicitly (symplectic Euler keeps their
  // energy; the implicit rows take (omega dt)^2 of it a tick).
  const int bending = stiffness_ > 0 ? 3 * links : 0, pulled = m - bending;
  if (pulled > 0) {
    S_ = A_.bottomRightCorner(pulled, pulled);
    if (bending > 0) {
      B_ = A_.topLeftCorner(bending, bending);
      B_.diagonal().array() += 1 / (stiffness_ * dt * dt);
      ldlt_.compute(B_);
      BinvC_ = ldlt_.solve(A_.topRightCorner(bending, pulled));
      product_.noalias() = A_.bottomLeftCorner(pulled, bending) * BinvC_;
      S_ -= product_;
    }
    double fastest = 0;
    for (int i = 0; i < pulled; ++i) fastest = std::max(fastest, stiff_[bending + i] * dt * dt * S_.row(i).cwiseAbs().sum());
    if (fastest < 0.25) {
      m = bending;
      rows.resize(first + m);
      A_.conservativeResize(m, m);
      rhs_.conservativeResize(m);
      if (m == 0) return;
    }
  }
  gamma_.resize(m);
  for (int i = 0; i < m; ++i) gamma_[i] = 1 / (stiff_[i] * dt * dt);
  A_.diagonal() += gamma_;
  ldlt_.compute(A_);
  lambda_ = ldlt_.solve(rhs_);
  // The chain's own solution is applied as Bullet's warm start applies an impulse (to the
  // body after the solve, and to the solver's accumulator now); each row then carries a
  // correction mu, a soft row (c.m_cfm = gamma c.m_jacDiagABInv) whose fixed point is
  //   (A (lambda + mu))_r + gamma (lambda_r + mu_r) + (pins', contacts' share)_r = rhs_r,
  // so the solver's iterations add what the pins and contacts change, from a start that is
  // already the exact solution for the free chain (the solver zeroes a row's own start).
  for (int i = 0; i < m; ++i) {
    btMultiBodySolverConstraint& c = rows[first + i];
    const btScalar gamma = (btScalar)gamma_[i];
    const btScalar D = c.m_jacDiagABInv > 0 ? 1 / c.m_jacDiagABInv : 0;
    c.m_jacDiagABInv = 1 / (D + gamma);
    c.m_rhs = (btScalar)(rhs_[i] - gamma_[i] * lambda_[i]) * c.m_jacDiagABInv;
    c.m_rhsPenetration = 0;
    c.m_cfm = gamma * c.m_jacDiagABInv;
    btScalar* dv = &data.m_deltaVelocitiesUnitImpulse[response_[i]];
    const btScalar impulse = (btScalar)lambda_[i];
    m_bodyA->applyDeltaVeeMultiDof2(dv, impulse);
    for (int k = 0; k < ndof; ++k) data.m_deltaVelocities[c.m_deltaVelAindex + k] += dv[k] * impulse;
  }
}

}  // namespace mpm::bullet
