#pragma once
/// Suturing on the Bullet side (CRESSim-MPM, section IV-C): a thread as a Featherstone
/// chain of capsules, pins for its points (to the needle's tail, to a fixed knot), and a
/// driver that moves a needle body toward a target pose with bounded force and torque.
/// The coupling to the tissue is in coupler.h (Coupler::addNeedle, Coupler::addThread).
///
///   mpm::bullet::SutureThreadDesc t;                       // 6 cm, 30 segments
///   btMultiBody* thread = makeSutureThread(world, t);     // a btMultiBodyDynamicsWorld*
///   attachThreadToNeedle(world, thread, needle, tailInNeedleFrame);
///   coupler.addThread(thread, {});
///   ...
///   destroySutureThread(world, thread);                   // its colliders, motors, pins
#include <LinearMath/btTransform.h>
#include <LinearMath/btVector3.h>

#include <vector>

class btMultiBody;
class btMultiBodyDynamicsWorld;
class btMultiBodyPoint2Point;
class btRigidBody;

namespace mpm::bullet {

/// A suture thread: `segments` equal capsules end to end, straight from `start` along
/// `direction`. The first segment is the multibody's floating base, segment i > 0 its link
/// i - 1, joined to the segment before by a spherical joint at their shared end.
struct SutureThreadDesc {
  float length = 0.06f;           ///< [m], > 0
  int segments = 30;              ///< >= 2
  float radius = 0.15e-3f;        ///< [m] of each capsule, > 0 and < half a segment
  float linearDensity = 1e-4f;    ///< [kg/m], > 0 (nylon 3-0: about 1e-4)
  /// [1/s] drag on each segment: Bullet's btMultiBody linear and angular damping (both
  /// set to this), a force -m v (k + k |v|) and a torque -I w (k + k |w|) on every link
  /// (absolute velocities: air drag, not joint damping). >= 0; 0: none (Bullet's default
  /// would be 0.04). Why not joint damping: Bullet 3.24 ignores btMultibodyLink::
  /// m_jointDamping ("todo: implement"), and btMultiBodySphericalJointMotor with position
  /// gain 0 as a damper (its rows remove a fraction of each joint's relative angular
  /// velocity) made a pinned, swinging 30-segment thread gain energy (measured: 15 times
  /// M g length / 2 within 2 s), so neither is used.
  float damping = 0.f;
  /// [Pa] Young's modulus of the suture's material: the thread resists bending with the
  /// flexural rigidity EI = E pi r^4 / 4 (r: `radius`), each joint with the moment EI / L
  /// times its turn (L the segment length), so the chain bends as an Euler-Bernoulli rod
  /// (a cantilever's tip deflects F l^3 / (3 EI) as the segments get short). Polypropylene
  /// (Prolene) 1.5-3 GPa, nylon 2-4 GPa; a 3-0 suture's diameter is 0.2-0.25 mm.
  /// Solved implicitly in Bullet's constraint solver (ThreadBending), stable at any tick
  /// and with no raise of the segments' moments. 0: a limp thread. >= 0.
  float youngsModulus = 0.f;
  btVector3 start{0, 0, 0};       ///< [m] the first point (base segment's outer end)
  btVector3 direction{1, 0, 0};   ///< from `start` toward the last point; normalised, non-zero
  /// The first segment fixed in the world where it is built (a knot or an anchor): Bullet's
  /// fixed base, so no btMultiBodyPoint2Point holds that end. Bullet's tracker lists such
  /// pins on long Featherstone chains as a source of instability (bullet3#471, #4242),
  /// and a chain pinned at both ends closes a loop the articulated solve does not see.
  bool fixedBase = false;
  float friction = 0.3f;          ///< Bullet friction of the colliders (thread on other Bullet bodies)
  /// [N] A tension the thread must carry stably at Bullet ticks of `tick` [s] with its
  /// segments' moments raised, for a thread whose tension reaches it through a pin.
  /// Under tension T a segment between its neighbours turns about its centre like a
  /// torsion pendulum, omega^2 = T L / I (L the segment's length, I its transverse
  /// moment), which Bullet integrates explicitly (omega tick < 2: a 3-0 suture's 2.5 mm
  /// segment, I = 1e-12 kg m^2, to 0.15 N at 1/9600 s). Every thread answers that turn
  /// implicitly (ThreadBending, the tension's geometric stiffness; docs/physics.md): a
  /// fixed-base thread pulled at its end carries 8 N at 1/960 s with its own inertia. A
  /// pin's share of the tension arrives a tick late, though, and a thread pulled through a
  /// pin holds only about 0.3 N at 1/960 s without this raise: every moment is raised to at
  /// least tension L tick^2 (omega tick <= 1). 0: no raise. It makes the thread resist
  /// bending faster than a real one would, which a stitch pulled slowly does not feel.
  float maxTension = 0.f;
  float tick = 1.f / 960;          ///< [s] Bullet's fixed tick for `maxTension`, > 0
  /// Collision filter of the colliders (Bullet's group and mask); mask 0: the thread
  /// touches no other Bullet body (it still touches the tissue through the coupler).
  int collisionGroup = 1;         ///< btBroadphaseProxy::DefaultFilter
  int collisionMask = -1;         ///< btBroadphaseProxy::AllFilter
};

/// Builds the thread in `world` (added to it, with a btMultiBodyLinkCollider per segment).
/// Each segment
/// has mass m = linearDensity x length / segments and a solid rod's inertia with a floor
/// (suture.cpp): every principal moment is at least max(m L^2 / 12, 1e-12 kg m^2,
/// maxTension L tick^2) (L the segment length; the last: SutureThreadDesc::maxTension). The first raises the axial moment m r^2 / 2 to the rod's transverse
/// moment (a thin thread's is 1e-2 to 1e-3 of it: badly conditioned articulated
/// inertias; spin about the thread's own axis is not resolved anyway). The second keeps
/// Bullet's float inverse of a joint's 3 x 3 inertia above FLT_MIN: a real suture (1e-4
/// kg/m in 2 mm segments, moments 6.7e-14) gives NaN in the first tick without it; it
/// raises that thread's moments 15 times (a thread of 1.5e-3 kg/m or more in 2 mm
/// segments is not floored). Throws mpm::InvalidArgument
/// naming the field ("SutureThreadDesc.segments") for a bad description. The caller owns
/// the result: release it with destroySutureThread. Its links' m_jointFeedback are the
/// thread's own (the tension is read from them): leave them as they are.
///
/// Stepping (measured, tests/test_suturing_bullet.cpp): Bullet's Featherstone chain of 30
/// spherical joints is stable only with short ticks and enough solver iterations once a
/// pin (btMultiBodyPoint2Point) holds it. A 6 cm thread pinned at one end and released 30
/// degrees from vertical: at 1/240 s and 10 iterations the pin opened by 25 % of a segment;
/// at 1/960 s and 50 iterations (world->getSolverInfo().m_numIterations) it stays within
/// 1e-3 of a segment and the energy within 1 %. Released horizontally the thread whips and
/// comes through whole. Bullet's clamp on a joint's rate (btMultiBody::
/// setMaxCoordinateVelocity, 100 rad/s) is lifted to 1e6 rad/s: it cut short the turns the
/// tension's implicit rows answer. Use ticks of 1/960 s or shorter and 50 iterations for
/// a thread.
btMultiBody* makeSutureThread(btMultiBodyDynamicsWorld* world, const SutureThreadDesc& desc);

/// Removes a thread made by makeSutureThread from `world` and deletes it with its
/// colliders, shape and every btMultiBodyConstraint in `world` that uses it
/// (pins from pinThreadPoint / attachThreadToNeedle included). Uncouple it first
/// (Coupler::remove).
void destroySutureThread(btMultiBodyDynamicsWorld* world, btMultiBody* thread);

/// The thread's points: the first segment's outer end, each joint, the last segment's outer
/// end (segments + 1 points, world frame), from the links' current transforms. Works for
/// any chain whose link i has parent i - 1 and whose base is symmetric about its centre.
std::vector<btVector3> threadPoints(const btMultiBody* thread);
/// Lays the thread along `points` (segments + 1 of them, world frame, consecutive points a
/// segment length apart within 1e-3 of it), at rest: the base where its segment goes
/// (a fixed base too: call it before the first tick), each spherical joint turned so its
/// segment points from points[s] to points[s + 1], each turn the shortest from the segment
/// before (no twist about the thread). For a thread already through tissue, a stitch's
/// loop, or slack. Throws mpm::InvalidArgument naming the point for a bad list.
void layThreadAlong(btMultiBody* thread, const std::vector<btVector3>& points);
/// Velocities of the points above: point k from segment k's motion (v + w x r), the last
/// point from the last segment's.
/// `segments` + 1 points along the polyline `corners` from its first, each `segmentLength`
/// from the one before (straight-line distance, so a thread laid along them with
/// layThreadAlong has its segments' length): from each point the next is where the
/// polyline first leaves the sphere of that radius about it. Throws mpm::InvalidArgument
/// when the polyline is too short for the thread or a corner is not finite.
std::vector<btVector3> threadPointsAlong(const std::vector<btVector3>& corners, float segmentLength, int segments);
std::vector<btVector3> threadPointVelocities(const btMultiBody* thread);
/// World transform of segment i (0: the base, i: link i - 1), centre of mass frame.
btTransform threadSegmentTransform(const btMultiBody* thread, int segment);

/// Pins point `point` (0 .. segments, as threadPoints) of the thread to `body` at
/// `pivotInBody` (its centre-of-mass frame), or to the fixed world point `pivotInBody`
/// when `body` is null, with a btMultiBodyPoint2Point added to `world` (returned; it is
/// deleted by destroySutureThread, or remove and delete it yourself). Its getAppliedImpulse
/// (0..2) are the impulses of the last tick along -x, -y, -z: pinForce gives the force.
/// On a thread from makeSutureThread the pin is solved with the thread's own implicit rows
/// (bending, the tension's turn) in one direct solve each tick, not left to the solver's
/// iterations: a thread pinned at its start holds 8 N at 1/960 s.
btMultiBodyPoint2Point* pinThreadPoint(btMultiBodyDynamicsWorld* world, btMultiBody* thread, int point,
                                      btRigidBody* body, const btVector3& pivotInBody);
/// The thread's first point to the needle body's tail: pinThreadPoint(world, thread, 0,
/// needle, tailInNeedleFrame).
btMultiBodyPoint2Point* attachThreadToNeedle(btMultiBodyDynamicsWorld* world, btMultiBody* thread,
                                            btRigidBody* needle, const btVector3& tailInNeedleFrame);
/// Force [N] a pin exerted on the thread over the last tick of length `dt`.
btVector3 pinForce(btMultiBodyPoint2Point* pin, float dt);

/// Limits and response of a NeedleDriver.
struct NeedleDriveLimits {
  float maxForce = 5.f;        ///< [N] bound on |force| the driver applies (gravity compensation included)
  float maxTorque = 0.05f;     ///< [N m] bound on |torque|
  /// [s] the position and orientation errors decay as exp(-t / timeConstant) while the
  /// limits are not reached (> 0; below one tick, one tick is used).
  float timeConstant = 0.02f;
};

/// Drives a btRigidBody toward a target pose and velocity, like a hand holding a needle
/// holder. Call tick(dt) before each Bullet internal tick (with a Coupler:
/// `coupler.setPreTickCallback([&](float dt) { driver.tick(dt); })`, or once per
/// stepSimulation(dt, 0) with one tick per step).
///
/// A dynamic body receives, at the start of the tick, the impulse that sets its velocity
/// to the target velocity plus the error over the time constant,
///   J = m (v* + e / tau - v) - m g dt,   L = I (w* + theta / tau - w)
/// (e: target position minus the centre of mass position, theta: rotation vector from the
/// body's to the target orientation, I: the world inertia tensor), clamped to
/// |J| <= maxForce dt and |L| <= maxTorque dt. An impulse at the start of a tick is what a
/// constant force over it does in Bullet's symplectic Euler step (and it needs no take-back:
/// Bullet keeps forces until stepSimulation returns, not per tick). The gravity term
/// cancels the body's own gravity, so a held needle does not sag. A constant disturbance
/// F (the tissue) leaves a steady position error of F dt tau / m: a light needle should be
/// given the mass of what holds it (the holder's jaw), or a short time constant.
/// A static or kinematic body is moved: transform, interpolation transform, motion state
/// and velocities are set to the target (the coupler reads them).
class NeedleDriver {
 public:
  NeedleDriver(btRigidBody* body, const NeedleDriveLimits& limits);
  /// Target pose of the body's centre of mass and its velocities (world).
  void setTarget(const btTransform& pose, const btVector3& linearVelocity = btVector3(0, 0, 0),
                 const btVector3& angularVelocity = btVector3(0, 0, 0));
  void tick(float dt);
  /// Force and torque applied in the last tick (impulse / dt) [N], [N m].
  const btVector3& lastForce() const { return force_; }
  const btVector3& lastTorque() const { return torque_; }
  btRigidBody* body() const { return body_; }
  const NeedleDriveLimits& limits() const { return limits_; }

 private:
  btRigidBody* body_;
  NeedleDriveLimits limits_;
  btTransform target_;
  btVector3 targetV_{0, 0, 0}, targetW_{0, 0, 0};
  btVector3 force_{0, 0, 0}, torque_{0, 0, 0};
};

}  // namespace mpm::bullet
