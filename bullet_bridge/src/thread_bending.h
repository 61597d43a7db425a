#pragma once
// A suture thread's bending stiffness and its tension's geometric stiffness, solved
// implicitly each tick and handed to Bullet's constraint solver as the impulses it must
// apply.
#include <BulletDynamics/Featherstone/btMultiBody.h>
#include <BulletDynamics/Featherstone/btMultiBodyDynamicsWorld.h>
#include <BulletDynamics/Dynamics/btActionInterface.h>
#include <BulletDynamics/Featherstone/btMultiBodyConstraint.h>
#include <BulletDynamics/Featherstone/btMultiBodyJointFeedback.h>
#include <BulletDynamics/Featherstone/btMultiBodyPoint2Point.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <vector>

namespace mpm::bullet {

/// The turn of `q` as a rotation vector (axis times angle), the shorter way round.
btVector3 rotationVector(btQuaternion q);

/// The bending springs of a thread's spherical joints, k = `stiffness` [N m/rad] each
/// (EI / L): every joint resists its turn theta (a rotation vector) with the moment
/// -k theta. Implicit Euler over the tick, for all the joints at once:
///   (A + gamma I) lambda = -(theta / dt + u),  gamma = 1 / (k dt^2),
/// u the joints' rates after Bullet's unconstrained step, A their response to unit
/// impulses (Featherstone's articulated inverse inertia, the rows' unit responses), lambda
/// the joints' impulses. lambda is applied as Bullet's warm start applies an impulse, and
/// each joint axis keeps a soft row (CFM gamma) whose fixed point is the same equation
/// with the pins' and contacts' impulses: the solver's iterations add only what they change.
///
/// Why not Bullet's explicit joint torques: a 2 mm polypropylene 3-0 segment (EI 1.6e-7
/// N m^2, its floored moment 1e-12 kg m^2) turns at sqrt(4 k / I) = 1.8e4 rad/s, 17 times
/// past a 1/960 s tick's bound of 2. Why not the soft rows alone (ODE's CFM): the solver's
/// Gauss-Seidel iterations over a chain of coupled joints did not converge: a cantilever
/// sagged 2.7 times the rod's deflection with 50 iterations a tick, 1.2 times with 200 and
/// 1.05 (the chain's exact value) only with 1000. Why not lambda alone (rows that apply
/// exactly it): the pins then met it only on the next tick, and a pinned thread's pin
/// opened by 3 segments at 1/240 s.
///
/// The tension's turn (geometric stiffness; Tournier et al., "Stable Constrained
/// Dynamics", ACM TOG 2015): under tension T_s a segment between its neighbours turns
/// about its centre with omega^2 = T_s L / I, explicit in Bullet (8 N on a 3-0 segment:
/// omega tick = 130 at 1/960 s). Two more rows a segment, its angular rate about its
/// transverse axes, stiffness T_s L and no stretch (the turn is measured from this tick's
/// pose), join the same solve when a segment's turn would outrun the tick. T_s comes
/// from Bullet's joint feedback (the thread's links' m_jointFeedback are this object's):
/// the unconstrained pass of this tick, plus the contacts' share of the last (being an
/// action too, it reads that share after the step: updateAction), plus the pins' share of
/// this tick, read from their impulses in the solve (below).
///
/// The thread's pins (ThreadPin) join the same solve as hard rows: a thread held by a pin
/// carries its tension only through the pin, and the solver's Gauss-Seidel iterations
/// between one pin and a chain of stiff rows did not converge (a thread pinned at its
/// start and pulled with 1 N at 1/960 s whipped with 50 iterations a tick and held 8 N
/// with 1000). The pins' impulses found are applied like the rows' (the solver's
/// iterations add what the contacts change) and added to what each pin reports. A pin's
/// rows to a rigid body take in that body's forces of the tick, which Bullet's rows
/// between a multibody and a rigid body leave out.
class ThreadPin;
class ThreadBending : public btMultiBodyConstraint, public btActionInterface {
 public:
  ThreadBending(btMultiBodyDynamicsWorld* world, btMultiBody* thread, btScalar stiffness, btScalar segmentLength);
  ~ThreadBending() override;
  void updateAction(btCollisionWorld*, btScalar) override;
  void finalizeMultiDof() override;
  int getIslandIdA() const override;
  int getIslandIdB() const override;
  void createConstraintRows(btMultiBodyConstraintArray& rows, btMultiBodyJacobianData& data,
                            const btContactSolverInfo& info) override;
  void debugDraw(btIDebugDraw*) override {}

 private:
  friend class ThreadPin;
  btMultiBodyDynamicsWorld* world_;
  std::vector<ThreadPin*> pins_;  ///< the thread's pins, in the world or not
  std::vector<std::pair<ThreadPin*, int>> pinRows_;  ///< this tick's: each pin row's pin and its first row
  void makePinRows(btMultiBodyConstraintArray& rows, btMultiBodyJacobianData& data, const btContactSolverInfo& info);
  btScalar stiffness_, segmentLength_;  ///< EI / L [N m/rad] (0: limp), L [m]
  std::vector<btMultiBodyJointFeedback> feedback_;  ///< each link's, Bullet's to fill
  /// per segment: its tension [N]; per joint: the force along the link from this tick's
  /// unconstrained pass, from the pins and contacts on the last tick, and the velocity
  /// products Bullet's constraint pass counts again
  std::vector<btScalar> tension_, free_, pinned_, motion_;
  /// per joint: the contacts' share (the last tick's constraints' less the pins'), the
  /// pins' share (this tick's solve)
  std::vector<btScalar> other_, own_;
  std::vector<btScalar> rate_;                   ///< the pins' change of the chain's rates
  std::vector<btVector3> pull_, omega_, velocity_;  ///< per segment: the pins' impulse, its change of rate
  void pinShare(const btMultiBodyConstraintArray& rows, const btMultiBodyJacobianData& data, int bending, int held,
                btScalar dt);
  /// Makes this object's row r in the solver's array; returns its rate after the
  /// unconstrained step.
  btScalar ownRow(btMultiBodyConstraintArray& rows, btMultiBodyJacobianData& data, const btContactSolverInfo& info,
                  int r);
  void response(const btMultiBodyConstraintArray& rows, const btMultiBodyJacobianData& data, int from, int to);
  /// Each segment's tension: this tick's unconstrained pass, the contacts' share, the pins'.
  void sumTension();
  void pullStiffness(const btMultiBodyConstraintArray& rows, int held, int m, btScalar dt);
  /// The bending springs' rows: 3 a joint, none for a limp thread.
  int bendingRows() const { return stiffness_ > 0 ? 3 * m_bodyA->getNumLinks() : 0; }
  std::vector<btSpatialForceVector> saved_;
  btScalar jointTension(int link) const;
  // the tick's solve, kept between ticks so the step allocates nothing once sized
  std::vector<int> row_;         ///< the solve's unknowns: their rows in the solver's array (bending, pins, tension)
  Eigen::VectorXd gamma_;
  btAlignedObjectArray<btScalar> scratchR_;
  btAlignedObjectArray<btVector3> scratchV_;
  btAlignedObjectArray<btMatrix3x3> scratchM_;
  Eigen::MatrixXd A_, S_, B_, BinvC_, product_;  ///< S_: the Schur complement of B_ (bending)
  Eigen::VectorXd rhs_, lambda_;
  Eigen::LDLT<Eigen::MatrixXd> ldlt_;
};

/// A point of a thread held to a rigid body (or to the world: no body) whose rows are
/// made and solved by the thread's ThreadBending, with the chain's own (above); a plain
/// btMultiBodyPoint2Point once that ThreadBending is gone. Its applied impulses, read
/// after the step, are the whole of what it applied.
class ThreadPin : public btMultiBodyPoint2Point {
 public:
  ThreadPin(ThreadBending* bending, int link, btRigidBody* body, const btVector3& pivotInLink,
            const btVector3& pivotInBody);
  ~ThreadPin() override;
  void createConstraintRows(btMultiBodyConstraintArray& rows, btMultiBodyJacobianData& data,
                            const btContactSolverInfo& info) override;

 private:
  friend class ThreadBending;
  ThreadBending* bending_;
  btScalar applied_[3] = {0, 0, 0};  ///< what ThreadBending applied on each row this tick
};

}  // namespace mpm::bullet
