#include "thread_bending.h"

#include <BulletDynamics/Featherstone/btMultiBodyLinkCollider.h>

#include <cmath>

namespace mpm::bullet {

namespace {

/// The rows: three a joint, along its degrees of freedom.
int rowCount(const btMultiBody* mb) { return 3 * mb->getNumLinks(); }

/// A spherical joint's turn.
btVector3 jointTurn(const btMultiBody* mb, int link) {
  const btScalar* q = mb->getJointPosMultiDof(link);
  return rotationVector(btQuaternion(q[0], q[1], q[2], q[3]));
}

}  // namespace

btVector3 rotationVector(btQuaternion q) {
  if (q.w() < 0) q = -q;
  const btVector3 v(q.x(), q.y(), q.z());
  const btScalar s = v.length();
  return s > 1e-9f ? v * (2 * std::atan2(s, q.w()) / s) : 2 * v;
}

ThreadBending::ThreadBending(btMultiBody* thread, btScalar stiffness)
    : btMultiBodyConstraint(thread, thread, -1, -1, rowCount(thread), false, MULTIBODY_CONSTRAINT_SPHERICAL_MOTOR),
      stiffness_(stiffness) {
  m_maxAppliedImpulse = BT_LARGE_FLOAT;
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

void ThreadBending::createConstraintRows(btMultiBodyConstraintArray& rows, btMultiBodyJacobianData& data,
                                         const btContactSolverInfo& info) {
  if (m_numDofsFinalized != m_jacSizeBoth) finalizeMultiDof();
  const btScalar dt = info.m_timeStep;
  const int m = getNumRows();
  if (!(stiffness_ > 0) || !(dt > 0) || m == 0) return;
  const int first = rows.size();
  rhs_.resize(m);
  response_.resize(m);
  const btVector3 zero(0, 0, 0);
  btVector3 turn;
  for (int r = 0; r < m; ++r) {
    btMultiBodySolverConstraint& c = rows.expandNonInitializing();
    c.m_orgConstraint = this;
    c.m_orgDofIndex = r;
    // the joint's rate after the unconstrained step, and its unit response
    const btScalar u = fillMultiBodyConstraint(c, data, jacobianA(r), jacobianB(r), zero, zero, zero, zero, 0, info,
                                               -m_maxAppliedImpulse, m_maxAppliedImpulse);
    response_[r] = c.m_jacAindex;
    if (r % 3 == 0) turn = jointTurn(m_bodyA, r / 3);
    rhs_[r] = -(turn[r % 3] / dt + u);
  }
  // A: row r's rate after a unit impulse on row s (symmetric: the articulated inverse inertia)
  const btScalar gamma = 1 / (stiffness_ * dt * dt);
  A_.resize(m, m);
  for (int s = 0; s < m; ++s) {
    const btScalar* dv = &data.m_deltaVelocitiesUnitImpulse[response_[s]];
    for (int r = 0; r < m; ++r) A_(r, s) = dv[6 + m_bodyA->getLink(r / 3).m_dofOffset + r % 3];
  }
  A_.diagonal().array() += gamma;
  ldlt_.compute(A_);
  lambda_ = ldlt_.solve(rhs_);
  // The chain's own solution is applied as Bullet's warm start applies an impulse (to the
  // body after the solve, and to the solver's accumulator now); each row then carries a
  // correction mu, a soft row (c.m_cfm = gamma c.m_jacDiagABInv) whose fixed point is
  //   (A (lambda + mu))_r + gamma (lambda_r + mu_r) + (pins', contacts' share)_r = rhs_r,
  // so the solver's iterations add what the pins and contacts change, from a start that is
  // already the exact bending of the free chain (the solver zeroes a row's own start).
  const int ndof = m_bodyA->getNumDofs() + 6;
  for (int r = 0; r < m; ++r) {
    btMultiBodySolverConstraint& c = rows[first + r];
    const btScalar D = c.m_jacDiagABInv > 0 ? 1 / c.m_jacDiagABInv : 0;
    c.m_jacDiagABInv = 1 / (D + gamma);
    c.m_rhs = (btScalar)(rhs_[r] - gamma * lambda_[r]) * c.m_jacDiagABInv;
    c.m_rhsPenetration = 0;
    c.m_cfm = gamma * c.m_jacDiagABInv;
    btScalar* dv = &data.m_deltaVelocitiesUnitImpulse[response_[r]];
    const btScalar impulse = (btScalar)lambda_[r];
    m_bodyA->applyDeltaVeeMultiDof2(dv, impulse);
    for (int i = 0; i < ndof; ++i) data.m_deltaVelocities[c.m_deltaVelAindex + i] += dv[i] * impulse;
  }
}

}  // namespace mpm::bullet
