// A suture thread on its own (mpm_bullet/suture.h): the thread as a Featherstone chain,
// its validation, and the needle driver. Every check is against an analytic value or a
// conservation law, with its tolerance stated. CPU backend.
#include <gtest/gtest.h>

#include <btBulletDynamicsCommon.h>
#include <BulletDynamics/Featherstone/btMultiBody.h>
#include <BulletDynamics/Featherstone/btMultiBodyConstraintSolver.h>
#include <BulletDynamics/Featherstone/btMultiBodyDynamicsWorld.h>
#include <BulletDynamics/Featherstone/btMultiBodyLinkCollider.h>
#include <BulletDynamics/Featherstone/btMultiBodyPoint2Point.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <string>
#include <tuple>
#include <vector>

#include "bullet_test_world.h"
#include "mpm/scene.h"
#include "mpm_bullet/coupler.h"
#include "mpm_bullet/suture.h"
#include "pieces.h"
#include "suture_thread.h"
#include "wound_gap.h"

namespace mpm {
namespace {

using test::BulletWorld;
using test::WorldType;
using test::finite;
using test::kThreadIterations;
using test::multiBodyEnergy;
using test::kThreadTick;
using test::testThread;
using test::ThreadWatch;
using test::threadTissueSettings;
using test::tissueBlock;

constexpr float kTick = 1.f / 240;

// (a) A 6 cm thread of 30 segments held at one end, released straight 30 degrees from
// vertical, swings for 2 s under gravity; held by a pin to a fixed point, or built with
// its first segment as Bullet's fixed base (SutureThreadDesc::fixedBase, no pin).
// Featherstone joints cannot stretch, so the checks are that nothing else does:
// consecutive points stay a segment length apart and each joint's two sides coincide (1 %
// of a segment), the held end keeps its point (1 % of a segment; a fixed base exactly,
// 1e-6 of a segment), nothing is NaN. Energy: without drag it is conserved within 2 % of
// M g length / 2; with drag it never rises (1e-4 of that per tick) and has fallen.
class HangingThread : public ::testing::TestWithParam<std::tuple<float, bool>> {};

TEST_P(HangingThread, KeepsItsLinksAndConservesEnergy) {
  const float damping = std::get<0>(GetParam()), g = 9.81f;
  const bool fixedBase = std::get<1>(GetParam());
  BulletWorld bw(WorldType::MultiBody, g);
  bw.world->getSolverInfo().m_numIterations = kThreadIterations;
  const float a = (float)(M_PI / 6);
  bullet::SutureThreadDesc d = testThread(btVector3(0, 0.1f, 0), btVector3(std::sin(a), -std::cos(a), 0), damping);
  d.fixedBase = fixedBase;
  btMultiBody* thread = bullet::makeSutureThread(bw.multiWorld, d);
  if (!fixedBase) bullet::pinThreadPoint(bw.multiWorld, thread, 0, nullptr, d.start);
  const float M = d.linearDensity * d.length;
  const double e0 = multiBodyEnergy(thread, g), scale = M * g * d.length / 2;
  double worstDrift = 0, worstGain = 0, previous = e0;
  ThreadWatch watch;
  for (int k = 0; k < 1920; ++k) {  // 2 s
    bw.world->stepSimulation(kThreadTick, 0);
    watch.check(thread, d);
    const double e = multiBodyEnergy(thread, g);
    worstDrift = std::max(worstDrift, std::fabs(e - e0) / scale);
    worstGain = std::max(worstGain, (e - previous) / scale);
    previous = e;
  }
  const std::vector<btVector3> p = bullet::threadPoints(thread);
  std::printf("drag %.1f /s, %s: worst |segment - L| / L %.2e, joint gap / L %.2e, pin gap / L %.2e; energy (of M g "
              "length / 2): worst drift %.4f, worst gain per tick %.2e, at 2 s %+.4f; free end at (%.4f, %.4f)\n",
              damping, fixedBase ? "fixed base" : "pinned", watch.length, watch.joint, watch.pin, worstDrift, worstGain, (previous - e0) / scale,
              p.back().x(), p.back().y());
  EXPECT_TRUE(watch.finite);
  EXPECT_LT(watch.length, 0.01);
  EXPECT_LT(watch.joint, 0.01);
  EXPECT_LT(watch.pin, fixedBase ? 1e-6 : 0.01);
  if (damping == 0.f) {
    EXPECT_LT(worstDrift, 0.02) << "energy conserved without drag";
  } else {
    EXPECT_LT(worstGain, 1e-4) << "with drag the energy never rises";
    EXPECT_LT(previous, e0 - 0.1 * scale) << "and has fallen";
  }
  bullet::destroySutureThread(bw.multiWorld, thread);
  EXPECT_EQ(bw.multiWorld->getNumMultibodies(), 0);
  EXPECT_EQ(bw.multiWorld->getNumMultiBodyConstraints(), 0) << "the pin went with the thread";
  EXPECT_EQ(bw.multiWorld->getNumCollisionObjects(), 0);
}

INSTANTIATE_TEST_SUITE_P(DragAndHold, HangingThread, ::testing::Combine(::testing::Values(0.f, 1.f), ::testing::Bool()),
                         [](const auto& info) {
                           return std::string(std::get<0>(info.param) == 0.f ? "NoDrag" : "Drag") +
                                  (std::get<1>(info.param) ? "FixedBase" : "Pinned");
                         });

// (a) The worst case: released horizontally, the thread whips (its free end is the tip of
// a falling chain). The whip's tension turns the segments faster than the tick, which
// ThreadBending answers implicitly, and implicit Euler takes energy out (measured: at
// 2 s -0.50 M g length / 2; the highest +0.029 on the way, against +0.35 when Bullet's
// 100 rad/s clamp did it). Checked: no NaN, links within 1 %, the free end never further
// from the pin than the thread's length (0.1 %), the energy never more than 0.1 M g
// length / 2 above its start.
TEST(SutureThread, WhipsWithoutComingApart) {
  const float g = 9.81f;
  BulletWorld bw(WorldType::MultiBody, g);
  bw.world->getSolverInfo().m_numIterations = kThreadIterations;
  const bullet::SutureThreadDesc d = testThread(btVector3(0, 0.1f, 0), btVector3(1, 0, 0), 0.f);
  btMultiBody* thread = bullet::makeSutureThread(bw.multiWorld, d);
  bullet::pinThreadPoint(bw.multiWorld, thread, 0, nullptr, d.start);
  const double e0 = multiBodyEnergy(thread, g), scale = d.linearDensity * d.length * g * d.length / 2;
  double highest = e0, reach = 0;
  ThreadWatch watch;
  for (int k = 0; k < 1920; ++k) {
    bw.world->stepSimulation(kThreadTick, 0);
    watch.check(thread, d);
    highest = std::max(highest, multiBodyEnergy(thread, g));
    reach = std::max(reach, (double)(bullet::threadPoints(thread).back() - d.start).length());
  }
  std::printf("whip: worst |segment - L| / L %.2e, joint gap / L %.2e, pin gap / L %.2e, reach %.5f m of %.3f, "
              "highest energy %+.4f, at 2 s %+.4f (of M g length / 2)\n",
              watch.length, watch.joint, watch.pin, reach, d.length, (highest - e0) / scale,
              (multiBodyEnergy(thread, g) - e0) / scale);
  EXPECT_TRUE(watch.finite);
  EXPECT_LT(watch.length, 0.01);
  EXPECT_LT(watch.joint, 0.01);
  EXPECT_LT(reach, d.length * 1.001);
  EXPECT_LT(highest - e0, 0.1 * scale) << "measured +0.029";
  bullet::destroySutureThread(bw.multiWorld, thread);
}

// (a) The pin carries the weight: a thread hanging straight down at rest stays at rest,
// and its pin holds M g (0.5 %).
TEST(SutureThread, PinCarriesTheWeight) {
  const float g = 9.81f;
  BulletWorld bw(WorldType::MultiBody, g);
  bw.world->getSolverInfo().m_numIterations = kThreadIterations;
  const bullet::SutureThreadDesc d = testThread(btVector3(0, 0.1f, 0), btVector3(0, -1, 0), 0.f);
  btMultiBody* thread = bullet::makeSutureThread(bw.multiWorld, d);
  btMultiBodyPoint2Point* pin = bullet::pinThreadPoint(bw.multiWorld, thread, 0, nullptr, d.start);
  const float M = d.linearDensity * d.length;
  btVector3 force(0, 0, 0);
  for (int k = 0; k < 240; ++k) {
    bw.world->stepSimulation(kThreadTick, 0);
    force += bullet::pinForce(pin, kThreadTick) / 240;
  }
  const btVector3 end = bullet::threadPoints(thread).back();
  std::printf("hanging straight: pin force (%.4e, %.4e, %.4e) N, weight %.4e N; free end at y %.5f (%.5f at rest)\n",
              force.x(), force.y(), force.z(), M * g, end.y(), d.start.y() - d.length);
  EXPECT_NEAR(force.y(), M * g, 0.005 * M * g);
  EXPECT_NEAR(force.x(), 0, 0.005 * M * g);
  EXPECT_NEAR(force.z(), 0, 0.005 * M * g);
  EXPECT_NEAR(end.y(), d.start.y() - d.length, 1e-3 * d.length);
  bullet::destroySutureThread(bw.multiWorld, thread);
}

// (a) The drag is Bullet's link damping as suture.h says: a free thread (no gravity)
// moving at v0 along itself slows as dv/dt = -k v (1 + |v|), v(t) = 1 / ((1 / v0 + 1)
// e^(k t) - 1) (1 %), and keeps its direction.
TEST(SutureThread, DragFollowsBulletsDampingLaw) {
  BulletWorld bw(WorldType::MultiBody, 0.f);
  const float k = 2.f, v0 = 1.f;
  const bullet::SutureThreadDesc d = testThread(btVector3(0, 0, 0), btVector3(1, 0, 0), k);
  btMultiBody* thread = bullet::makeSutureThread(bw.multiWorld, d);
  thread->setBaseVel(btVector3(v0, 0, 0));
  const double t = 0.5;
  for (int i = 0; i < (int)std::lround(t / kThreadTick); ++i) bw.world->stepSimulation(kThreadTick, 0);
  const std::vector<btVector3> v = bullet::threadPointVelocities(thread);
  const double expected = 1 / ((1 / v0 + 1) * std::exp(k * t) - 1);
  double worst = 0;
  for (const btVector3& u : v) worst = std::max(worst, (double)(u - btVector3((btScalar)expected, 0, 0)).length());
  std::printf("drag %.1f /s: after %.1f s the points move at %.5f m/s (analytic %.5f), worst deviation %.2e m/s\n", k, t,
              v[0].x(), expected, worst);
  EXPECT_LT(worst, 0.01 * expected);
  bullet::destroySutureThread(bw.multiWorld, thread);
}

/// Largest sideways offset of a thread's points from the x axis after pulling its free end
/// along +x with `tension` [N] for 0.05 s at ticks of `tick`: a 3-0 thread (5e-5 kg/m, 12
/// segments of 2.5 mm), its first segment Bullet's fixed base on the x axis, laid in a
/// zigzag of +-1e-3 rad (the mode in which every segment turns about its own centre).
double zigzagAfterPull(float tension, float tick, float maxTension) {
  BulletWorld bw(WorldType::MultiBody, 0.f);
  bw.world->getSolverInfo().m_numIterations = kThreadIterations;
  bullet::SutureThreadDesc d = testThread(btVector3(0, 0, 0), btVector3(1, 0, 0), 0.f);
  d.segments = 12;
  d.length = 0.03f;
  d.linearDensity = 5e-5f;
  d.fixedBase = true;
  d.maxTension = maxTension;
  d.tick = tick;
  btMultiBody* thread = bullet::makeSutureThread(bw.multiWorld, d);
  std::vector<btVector3> zigzag;
  const float L = d.length / d.segments, a = 1e-3f;
  for (int i = 0; i <= d.segments; ++i) zigzag.emplace_back(L * std::cos(a) * i, i % 2 ? L * std::sin(a) : 0.f, 0.f);
  bullet::layThreadAlong(thread, zigzag);
  double worst = 0;
  for (int k = 0; k < (int)std::lround(0.05f / tick) && std::isfinite(worst) && worst < 1; ++k) {
    thread->addLinkForce(d.segments - 2, btVector3(tension, 0, 0));
    bw.world->stepSimulation(tick, 0);
    for (const btVector3& p : bullet::threadPoints(thread))
      worst = std::isfinite(p.y()) ? std::max(worst, (double)std::fabs(p.y())) : INFINITY;
  }
  bullet::destroySutureThread(bw.multiWorld, thread);
  return worst;
}

// (a) A taut thread's segments turn within Bullet's tick. Under tension T each segment of
// a zigzag turns about its centre with omega^2 = T L / I, and Bullet integrates it
// explicitly: stable while omega tick < 2. A 3-0 thread (I = 1e-12 kg m^2, the floor) at
// ticks of 1/9600 s: T < 4 I / (L tick^2) = 0.147 N; past it the zigzag laid at 2.5e-6 m
// grew to 2.7e-3 m at 0.2 N in 0.05 s. ThreadBending answers the tension's turn
// implicitly (its geometric stiffness) once it would outrun the tick; maxTension raises
// the moments instead. Measured: 3.6e-6 m at 0.1 N, 3.4e-6 m at 0.2 N, 2.8e-6 m at 2 N,
// 4.0e-6 m at 0.2 N with maxTension 0.5 N. Bound: 8 times the laid zigzag.
TEST(SutureThread, TautSegmentsTurnWithinTheTick) {
  const float tick = 1.f / 9600;
  const double below = zigzagAfterPull(0.1f, tick, 0.f), above = zigzagAfterPull(0.2f, tick, 0.f),
               far = zigzagAfterPull(2.f, tick, 0.f), raised = zigzagAfterPull(0.2f, tick, 0.5f);
  std::printf("zigzag of 2.5e-6 m pulled 0.05 s: at 0.1 N %.2e m, at 0.2 N %.2e m, at 2 N %.2e m, at 0.2 N with "
              "maxTension 0.5 N %.2e m\n", below, above, far, raised);
  EXPECT_LT(below, 2e-5);
  EXPECT_LT(above, 2e-5);
  EXPECT_LT(far, 2e-5);
  EXPECT_LT(raised, 2e-5);
}

// (b) A bad description throws InvalidArgument naming the field and adds nothing.
TEST(SutureThread, ValidationNamesTheField) {
  BulletWorld bw(WorldType::MultiBody, 9.81f);
  struct Case {
    std::function<void(bullet::SutureThreadDesc&)> spoil;
    std::string field;
  };
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<Case> cases = {
      {[](auto& d) { d.segments = 0; }, "SutureThreadDesc.segments"},
      {[](auto& d) { d.segments = 1; }, "SutureThreadDesc.segments"},
      {[](auto& d) { d.length = -0.01f; }, "SutureThreadDesc.length"},
      {[&](auto& d) { d.length = nan; }, "SutureThreadDesc.length"},
      {[](auto& d) { d.radius = 0.f; }, "SutureThreadDesc.radius"},
      {[](auto& d) { d.radius = 0.002f; }, "SutureThreadDesc.radius"},  // 2 r >= a 2 mm segment
      {[](auto& d) { d.linearDensity = 0.f; }, "SutureThreadDesc.linearDensity"},
      {[](auto& d) { d.damping = -0.1f; }, "SutureThreadDesc.damping"},
      {[&](auto& d) { d.damping = nan; }, "SutureThreadDesc.damping"},
      {[](auto& d) { d.direction = btVector3(0, 0, 0); }, "SutureThreadDesc.direction"},
      {[&](auto& d) { d.start = btVector3(nan, 0, 0); }, "SutureThreadDesc.start"},
      {[](auto& d) { d.friction = -1.f; }, "SutureThreadDesc.friction"},
      {[](auto& d) { d.maxTension = -1.f; }, "SutureThreadDesc.maxTension"},
      {[](auto& d) { d.youngsModulus = -1.f; }, "SutureThreadDesc.youngsModulus"},
      {[&](auto& d) { d.youngsModulus = nan; }, "SutureThreadDesc.youngsModulus"},
      {[&](auto& d) { d.maxTension = nan; }, "SutureThreadDesc.maxTension"},
      {[](auto& d) { d.tick = 0.f; }, "SutureThreadDesc.tick"},
  };
  for (const Case& c : cases) {
    bullet::SutureThreadDesc d;
    c.spoil(d);
    try {
      bullet::makeSutureThread(bw.multiWorld, d);
      ADD_FAILURE() << c.field << ": no exception";
    } catch (const InvalidArgument& e) {
      EXPECT_EQ(e.field(), c.field) << e.what();
      EXPECT_NE(std::string(e.what()).find(c.field), std::string::npos) << e.what();
    }
  }
  bullet::SutureThreadDesc d;
  d.segments = 0;
  try {
    bullet::makeSutureThread(bw.multiWorld, d);
  } catch (const InvalidArgument& e) {
    EXPECT_STREQ(e.what(), "SutureThreadDesc.segments = 0: must be >= 2");
  }
  EXPECT_EQ(bw.multiWorld->getNumMultibodies(), 0) << "a refused thread adds nothing";
  EXPECT_EQ(bw.multiWorld->getNumCollisionObjects(), 0);
  EXPECT_THROW(bullet::makeSutureThread(nullptr, bullet::SutureThreadDesc{}), InvalidArgument);

  btMultiBody* thread = bullet::makeSutureThread(bw.multiWorld, bullet::SutureThreadDesc{});
  try {
    bullet::pinThreadPoint(bw.multiWorld, thread, 31, nullptr, btVector3(0, 0, 0));
    ADD_FAILURE() << "point 31 of 0..30 accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_EQ(e.field(), "pinThreadPoint point");
  }
  EXPECT_EQ(bw.multiWorld->getNumMultiBodyConstraints(), 1) << "no pin added (the one is the thread's ThreadBending)";
  bullet::destroySutureThread(bw.multiWorld, thread);

  btSphereShape sphere(0.001f);
  btRigidBody body(0.02f, nullptr, &sphere, btVector3(1e-8f, 1e-8f, 1e-8f));
  for (auto [spoil, field] : std::vector<std::pair<std::function<void(bullet::NeedleDriveLimits&)>, std::string>>{
           {[](auto& l) { l.maxForce = -1.f; }, "NeedleDriveLimits.maxForce"},
           {[nan](auto& l) { l.maxTorque = nan; }, "NeedleDriveLimits.maxTorque"},
           {[](auto& l) { l.timeConstant = 0.f; }, "NeedleDriveLimits.timeConstant"}}) {
    bullet::NeedleDriveLimits limits;
    spoil(limits);
    try {
      bullet::NeedleDriver driver(&body, limits);
      ADD_FAILURE() << field << ": no exception";
    } catch (const InvalidArgument& e) {
      EXPECT_EQ(e.field(), field) << e.what();
    }
  }
}

/// Rotation angle between two orientations [rad].
double angleBetween(const btQuaternion& a, const btQuaternion& b) {
  btQuaternion q = a * b.inverse();
  return 2 * std::atan2(btVector3(q.x(), q.y(), q.z()).length(), std::fabs(q.w()));
}

// (c) A driven needle body (20 g, gravity on) sent 5 cm away and turned 120 degrees about
// an oblique axis: the force and torque never exceed their limits (checked every tick,
// relative 1e-6), the first tick's velocity change is exactly (J + m g dt) / m (momentum,
// 1e-4 relative), and after 1.5 s it sits at the target (0.01 mm, 0.01 degrees). Then the
// target moves at 1 cm/s and a constant 0.2 N pushes the body sideways: the steady error
// is the controller's analytic F dt tau / m (1 %).
TEST(NeedleDriver, ReachesItsTargetWithinItsLimits) {
  const float g = 9.81f, m = 0.02f;
  BulletWorld bw(WorldType::Discrete, g);
  btRigidBody* needle = bw.addBody(new btBoxShape(btVector3(0.012f, 0.006f, 0.001f)), m,
                                   btTransform(btQuaternion::getIdentity(), btVector3(0, 0.1f, 0)));
  bullet::NeedleDriveLimits limits;
  limits.maxForce = 0.5f;
  limits.maxTorque = 2e-4f;
  limits.timeConstant = 0.02f;
  bullet::NeedleDriver driver(needle, limits);
  const btTransform target(btQuaternion(btVector3(1, 2, 3).normalized(), 2.0944f), btVector3(0.05f, 0.12f, -0.01f));
  driver.setTarget(target);
  double worstForce = 0, worstTorque = 0;
  for (int k = 0; k < 360; ++k) {  // 1.5 s
    const btVector3 v0 = needle->getLinearVelocity();
    driver.tick(kTick);
    bw.world->stepSimulation(kTick, 0);
    worstForce = std::max(worstForce, (double)driver.lastForce().length() / limits.maxForce);
    worstTorque = std::max(worstTorque, (double)driver.lastTorque().length() / limits.maxTorque);
    if (k == 0) {
      const btVector3 expected = v0 + (driver.lastForce() * kTick + m * btVector3(0, -g, 0) * kTick) / m;
      EXPECT_LT((needle->getLinearVelocity() - expected).length(), 1e-4 * expected.length())
          << "the first tick's momentum change is the driver's impulse plus gravity's";
      EXPECT_NEAR(driver.lastForce().length(), limits.maxForce, 1e-6 * limits.maxForce) << "saturated at first";
    }
  }
  const double posError = (needle->getCenterOfMassPosition() - target.getOrigin()).length();
  const double angError = angleBetween(needle->getOrientation(), target.getRotation());
  std::printf("driven needle: worst |F| / maxForce %.6f, |tau| / maxTorque %.6f; after 1.5 s position error %.2e m, "
              "angle error %.2e rad\n",
              worstForce, worstTorque, posError, angError);
  EXPECT_LE(worstForce, 1 + 1e-6);
  EXPECT_LE(worstTorque, 1 + 1e-6);
  EXPECT_LT(posError, 1e-5);
  EXPECT_LT(angError, 0.01 * M_PI / 180);

  // tracking a moving target against a constant disturbance F: e = -F dt tau / m
  const btVector3 v(0.01f, 0, 0), F(0, 0, -0.2f);
  btTransform moving = target;
  for (int k = 0; k < 240; ++k) {
    moving.setOrigin(target.getOrigin() + v * (k * kTick));
    driver.setTarget(moving, v);
    driver.tick(kTick);
    needle->applyCentralImpulse(F * kTick);  // the disturbance over this tick
    bw.world->stepSimulation(kTick, 0);
  }
  // the target of the last tick moved on by v dt while Bullet stepped
  const btVector3 error = moving.getOrigin() + v * kTick - needle->getCenterOfMassPosition();
  const btVector3 expected = -F * (kTick * limits.timeConstant / m);
  std::printf("disturbed: steady error (%.4e, %.4e, %.4e) m, analytic (%.4e, %.4e, %.4e) m\n", error.x(), error.y(),
              error.z(), expected.x(), expected.y(), expected.z());
  EXPECT_LT((error - expected).length(), 0.01 * expected.length());

  // a kinematic body is moved to the target with the target's velocity
  btRigidBody* kinematic = bw.addBody(new btSphereShape(0.001f), 0.f, btTransform::getIdentity());
  kinematic->setCollisionFlags(kinematic->getCollisionFlags() | btCollisionObject::CF_KINEMATIC_OBJECT);
  bullet::NeedleDriver mover(kinematic, limits);
  mover.setTarget(target, v);
  mover.tick(kTick);
  EXPECT_LT((kinematic->getWorldTransform().getOrigin() - target.getOrigin()).length(), 1e-7);
  EXPECT_LT((kinematic->getLinearVelocity() - v).length(), 1e-7);
}

}  // namespace
}  // namespace mpm
