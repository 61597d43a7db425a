#pragma once
// A suture thread's bending stiffness, solved implicitly each tick and handed to Bullet's
// constraint solver as the impulses it must apply.
#include <BulletDynamics/Featherstone/btMultiBody.h>
#include <BulletDynamics/Featherstone/btMultiBodyConstraint.h>

namespace mpm::bullet {

/// The bending springs of a thread's spherical joints, k = `stiffness` [N m/rad] each
/// (EI / L): every joint resists its turn theta (a rotation vector) with the moment
/// -k theta. Implicit Euler over the tick, for all the joints at once:
///   (A + gamma I) lambda = -(theta / dt + u),  gamma = 1 / (k dt^2),
/// u the joints' rates after Bullet's unconstrained step, A their response to unit
/// impulses (Featherstone's articulated inverse inertia, the rows' unit responses), lambda
/// the joints' impulses; then one row per joint axis whose bounds are both lambda, so the
/// solver applies exactly that while it resolves pins and contacts.
///
/// Why not Bullet's explicit joint torques: a 2 mm polypropylene 3-0 segment (EI 1.6e-7
/// N m^2, its floored moment 1e-12 kg m^2) turns at sqrt(4 k / I) = 1.8e4 rad/s, 17 times
/// past a 1/960 s tick's bound of 2. Why not soft rows left to the solver (ODE's CFM):
/// its Gauss-Seidel iterations over a chain of coupled joints did not converge: a
/// cantilever sagged 2.7 times the rod's deflection with 50 iterations a tick, 1.2 times
/// with 200 and 1.05 (the chain's exact value) only with 1000.
class ThreadBending : public btMultiBodyConstraint {
 public:
  ThreadBending(btMultiBody* thread, btScalar stiffness);
  void finalizeMultiDof() override;
  int getIslandIdA() const override;
  int getIslandIdB() const override;
  void createConstraintRows(btMultiBodyConstraintArray& rows, btMultiBodyJacobianData& data,
                            const btContactSolverInfo& info) override;
  void debugDraw(btIDebugDraw*) override {}
  btScalar stiffness() const { return stiffness_; }

 private:
  btScalar stiffness_;
};

}  // namespace mpm::bullet
