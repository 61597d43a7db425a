// Suturing on the Bullet side with a needle (Coupler::addNeedle): the needle's pass drawing
// its thread through two blocks, the momentum a thrown needle gives the tissue, and
// checkpoints refused with curves. CPU backend.
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
using test::kThreadTick;
using test::testThread;
using test::ThreadWatch;
using test::threadTissueSettings;
using test::tissueBlock;

// (e) The pass (the demo's set-up on the blocks of PullingTheStitch,
// 1.25 cm deep, and a faster turn): a half-circle needle of 12 mm (a 100 g body driven by
// a NeedleDriver, coupled with addNeedle; toughness G_c 200 J/m^2, puncture force 0.03 N)
// turns 365 degrees about its centre 6 mm above the tops in 2.5 s: in through block 1,
// under the 6 mm gap, out of block 2, until the eye 5 mm behind its tail is out. Its eye
// draws a 3-0 thread (30 one-cell links, 0.05 g/m, added mass) from a knot over the wound.
// After the pass: the tip broke in; the thread runs through both blocks (at least 3 segment
// midpoints inside each block's box, measured 6 and 4); links within 1 % of their length, the eye's pin
// within 1 % of a segment, nothing NaN; the kinetic energy of tissue and thread never
// exceeds what all of it would have moving at the needle's fastest point (the needle is
// the only thing that moves them); the needle and thread cut nothing: each block is one
// piece.
TEST(NeedlePass, DrawsTheThreadThroughBothBlocks) {
  BulletWorld bw(WorldType::MultiBody, 0.f);
  bw.world->getSolverInfo().m_numIterations = kThreadIterations;
  const float tick = 1.f / 9600;
  SceneSettings settings = threadTissueSettings();
  settings.domain.upper.y = 0.05f;
  settings.domain.lower.z = -0.03f;
  settings.domain.upper.z = 0.03f;
  Scene scene(settings);
  const Vec3f half{0.01f, 0.01f, 0.00625f};
  ParticleObjectDesc block = tissueBlock(half, {-0.013f, 0.01f, 0.f}, 4e4f, 0.4f, 1060.f);
  block.material.model = MaterialModel::NeoHookeanDecoupled;
  block.material.fractureToughness = 200.f;
  const ParticleObjectId left = scene.addParticleObject(block);
  block.center.x = 0.013f;
  const ParticleObjectId right = scene.addParticleObject(block);
  scene.addShape(test::basePlate());

  // the needle: the body's centre of mass at the arc's centre, turning about +z
  const float R = 0.012f, top = 0.02f, t0 = 0.05f, t1 = 2.5f, turn = 365.f * (float)M_PI / 180.f;
  const btVector3 centre(0.f, top + 0.006f, 0.f);
  auto angleAt = [&](float t) {
    const float a = std::clamp((t - t0) / (t1 - t0), 0.f, 1.f);
    return turn * a * a * (3 - 2 * a);
  };
  btRigidBody* needle = bw.addBody(new btSphereShape(0.001f), 0.1f, btTransform(btQuaternion::getIdentity(), centre));
  needle->setMassProps(0.1f, btVector3(1e-4f, 1e-4f, 1e-4f));  // with the holder's inertia, as in the demo
  needle->updateInertiaTensor();
  needle->setCollisionFlags(needle->getCollisionFlags() | btCollisionObject::CF_NO_CONTACT_RESPONSE);
  ArcDesc arc;
  arc.radius = R;
  arc.startAngle = 0.f;
  arc.endAngle = (float)M_PI;
  arc.wireRadius = 0.25e-3f;
  arc.friction = 0.2f;
  arc.punctureForce = 0.03f;
  bullet::Coupler coupler(bw.world.get(), scene);
  const CurveId needleCurve = coupler.addNeedle(needle, arc);
  bullet::NeedleDriveLimits limits;
  limits.maxForce = 5.f;
  limits.maxTorque = 5.f * R;
  limits.timeConstant = 0.005f;
  bullet::NeedleDriver driver(needle, limits);

  // the thread: knot over the wound (Bullet's fixed base), laid up from the eye, back,
  // across and down to the knot, in the air; its other end pinned at the eye
  bullet::SutureThreadDesc d = testThread(btVector3(0, 0, 0), btVector3(1, 0, 0), 1.f);
  d.length = 0.075f;
  d.segments = 30;
  d.linearDensity = 5e-5f;
  d.fixedBase = true;
  d.maxTension = 10.f;
  d.tick = tick;
  const float eyeAngle = -0.005f / R;
  const btVector3 eyeInNeedle(R * std::cos(eyeAngle), R * std::sin(eyeAngle), 0);
  const btVector3 eye = centre + eyeInNeedle;
  const float up = top + 0.014f, back = -0.024f;
  std::vector<btVector3> path = bullet::threadPointsAlong(
      {eye, btVector3(eye.x(), up, 0), btVector3(eye.x(), up, back), btVector3(-0.003f, up, back),
       btVector3(-0.003f, up, -0.006f), btVector3(-0.003f, top + 0.004f, -0.006f)},
      d.length / d.segments, d.segments);
  std::reverse(path.begin(), path.end());  // knot first
  d.start = path[0];
  d.direction = path[1] - path[0];
  btMultiBody* thread = bullet::makeSutureThread(bw.multiWorld, d);
  bullet::layThreadAlong(thread, path);
  bullet::pinThreadPoint(bw.multiWorld, thread, d.segments, needle, eyeInNeedle);
  bullet::ThreadCoupling tc;
  tc.friction = 0.1f;
  tc.dynamic = true;
  tc.addedMass = true;
  coupler.addThread(thread, tc);
  // the velocities the tick's advance moves the needle and the thread's points with
  btVector3 needleV, needleW;
  std::vector<btVector3> threadP, threadV;
  coupler.setPreTickCallback([&](float dt) {
    const float t = (float)scene.time() + dt;
    const float w = (angleAt(t + 1e-3f) - angleAt(t - 1e-3f)) / 2e-3f;
    driver.setTarget(btTransform(btQuaternion(btVector3(0, 0, 1), angleAt(t)), centre), btVector3(0, 0, 0),
                     btVector3(0, 0, w));
    driver.tick(dt);
    needleV = needle->getLinearVelocity();
    needleW = needle->getAngularVelocity();
    threadP = bullet::threadPoints(thread);
    threadV = bullet::threadPointVelocities(thread);
  });
  const CurveId threadCurve = coupler.threadOf(thread);
  auto toBt = [](const Vec3f& v) { return btVector3(v.x, v.y, v.z); };
  // the work needle and thread do on the tissue in a tick: minus the power of the momentum
  // the grid gave them (each segment's about its midpoint, turning with its points)
  auto workOnTissue = [&] {
    const ShapeImpulse J = scene.curveImpulse(needleCurve);  // about the arc's centre, the body's
    double w = -(toBt(J.linear).dot(needleV) + toBt(J.angular).dot(needleW));
    const std::vector<ShapeImpulse> Js = scene.segmentImpulses(threadCurve);
    for (size_t s = 0; s < Js.size(); ++s) {
      const btVector3 d = threadP[s + 1] - threadP[s];
      const btVector3 omega = d.cross(threadV[s + 1] - threadV[s]) / d.length2();
      w -= toBt(Js[s].linear).dot(0.5f * (threadV[s] + threadV[s + 1])) + toBt(Js[s].angular).dot(omega);
    }
    return w;
  };

  const float L = d.length / d.segments;
  ThreadWatch watch;
  bool brokeIn = false;
  double pin = 0, fastestNeedle = 0, energy = 0, energyAt = 0, energyBound = 0, work = 0, energyOver = -1;
  const int ticks = (int)std::lround((t1 + 0.1f) / tick);
  for (int k = 0; k < ticks; ++k) {
    bw.world->stepSimulation(tick, 0);
    coupler.rethrowError();
    watch.check(thread, d);
    brokeIn = brokeIn || scene.tipInside(needleCurve);
    pin = std::max(pin, (double)((bullet::threadPoints(thread).back() - needle->getWorldTransform() * eyeInNeedle).length() / L));
    fastestNeedle = std::max(fastestNeedle, (double)(needle->getLinearVelocity().length() +
                                                     needle->getAngularVelocity().length() * R));
    work += workOnTissue();
    const double e = scene.summary(left).kineticEnergy + scene.summary(right).kineticEnergy;
    if (e > energy) {
      energy = e;
      energyAt = scene.time();
      energyBound = work;
    }
    energyOver = std::max(energyOver, e - work);
    if (!watch.finite || pin > d.segments) break;
  }
  // segment midpoints inside each block's box
  int inLeft = 0, inRight = 0;
  const std::vector<btVector3> p = bullet::threadPoints(thread);
  for (size_t s = 0; s + 1 < p.size(); ++s) {
    const btVector3 m = 0.5f * (p[s] + p[s + 1]);
    const bool inBlock = m.y() > 0.f && m.y() < top && std::fabs(m.z()) < half.z;
    inLeft += inBlock && m.x() > -0.023f && m.x() < -0.003f;
    inRight += inBlock && m.x() > 0.003f && m.x() < 0.023f;
  }
  std::vector<Vec3f> xl, xr;
  scene.readPositions(left, xl);
  scene.readPositions(right, xr);
  const float spacing = 0.5f * settings.dx;
  const int piecesLeft = test::pieces(xl, spacing), piecesRight = test::pieces(xr, spacing);
  std::printf("needle pass (%.2f s): tip broke in %d; thread segments inside block 1: %d, block 2: %d; links %.2e, "
              "eye pin %.2e of a segment; the tissue's kinetic energy %.3e J at the most (%.3f s; the work done on it "
              "by then %.3e J, %.3e J by the end; kinetic energy minus work at the most %.3e J); needle's fastest "
              "point %.3f m/s; pieces %d and %d\n",
              scene.time(), (int)brokeIn, inLeft, inRight, watch.length, pin, energy, energyAt, energyBound, work,
              energyOver, fastestNeedle, piecesLeft, piecesRight);
  EXPECT_TRUE(brokeIn);
  EXPECT_TRUE(watch.finite);
  // the arc runs about 4 segments' length through each block under its top: a thread
  // that only caught a corner, or slipped back out, would leave fewer there
  EXPECT_GE(inLeft, 3);
  EXPECT_GE(inRight, 3);
  EXPECT_LT(watch.length, 0.01);
  EXPECT_LT(pin, 0.01);
  EXPECT_LE(energyOver, 1e-9) << "the tissue's kinetic energy exceeded the work done on it";
  EXPECT_EQ(piecesLeft, 1);
  EXPECT_EQ(piecesRight, 1);
  coupler.removeThread(thread);
  coupler.remove(needle);
  bullet::destroySutureThread(bw.multiWorld, thread);
}

// (d) A needle (ArcDesc: a half circle of 12 mm) on a free dynamic Bullet body (20 g),
// coupled with addNeedle, thrown tip first down into a free soft block at 0.2 m/s, gravity
// off: over 50 ms the block gains the momentum the needle body loses (1e-4 of the throw;
// measured 4e-7), and the tissue has slowed the needle. The needle is kinematic inside the
// scene (ArcDesc has no mass), so its coupling is explicit: the body must be heavier than
// the material it drags (measured: 10, 20 and 50 g conserve; a 5 g body diverged, the
// block reaching 0.5 kg m/s).
TEST(NeedleCoupling, BlockGainsWhatTheNeedleLoses) {
  BulletWorld bw(WorldType::Discrete, 0.f);
  SceneSettings settings = threadTissueSettings();
  settings.domain.upper.y = 0.05f;
  Scene scene(settings);
  ParticleObjectDesc block = tissueBlock({0.02f, 0.01f, 0.00625f}, {0.f, 0.01f, 0.f}, 3e4f, 0.3f, 1000.f);
  block.material.fractureToughness = 25.f;
  const ParticleObjectId blockId = scene.addParticleObject(block);
  // the arc's centre 2 mm above the block's top at x = 12 mm: the tip (angle pi) 2 mm
  // above the top at x = 0, the tail (angle 0) to its right; thrown down at 0.2 m/s
  const float m = 0.02f;
  btRigidBody* body = bw.addBody(new btSphereShape(0.001f), m,
                                 btTransform(btQuaternion::getIdentity(), btVector3(0.012f, 0.022f, 0.f)));
  body->setCollisionFlags(body->getCollisionFlags() | btCollisionObject::CF_NO_CONTACT_RESPONSE);
  const btVector3 v0(0, -0.2f, 0);
  body->setLinearVelocity(v0);
  body->setActivationState(DISABLE_DEACTIVATION);
  ArcDesc arc;
  arc.radius = 0.012f;
  arc.startAngle = 0.f;
  arc.endAngle = 3.1415927f;
  arc.pose.position = {0.f, 0.f, 0.f};  // the arc's centre at the body's centre of mass
  bullet::Coupler coupler(bw.world.get(), scene);
  const CurveId id = coupler.addNeedle(body, arc);
  EXPECT_EQ(coupler.needleOf(body).index, id.index);
  auto blockMomentum = [&] {
    const ObjectSummary s = scene.summary(blockId);
    return btVector3((btScalar)s.momentum[0], (btScalar)s.momentum[1], (btScalar)s.momentum[2]);
  };
  const btVector3 pb0 = blockMomentum();
  for (int k = 0; k < 48; ++k) {  // 50 ms
    bw.world->stepSimulation(kThreadTick, 0);
    coupler.rethrowError();
  }
  const btVector3 lost = m * (v0 - body->getLinearVelocity()), gained = blockMomentum() - pb0;
  std::printf("needle thrown with %.4e kg m/s, lost (%.4e, %.4e, %.4e); block gained (%.4e, %.4e, %.4e); "
              "|gained - lost| / throw %.2e; tip inside %d\n",
              m * v0.length(), lost.x(), lost.y(), lost.z(), gained.x(), gained.y(), gained.z(),
              (gained - lost).length() / (m * v0.length()), (int)scene.tipInside(id));
  EXPECT_GT(lost.length(), 0.01 * m * v0.length()) << "the tissue slowed the needle";
  EXPECT_LT((gained - lost).length(), 1e-4 * m * v0.length());
  coupler.remove(body);
  EXPECT_FALSE(scene.isValid(id));
}

// Checkpoints of a coupler with needles or threads are refused, naming why.
TEST(NeedleCoupling, CheckpointsAreRefusedWithCurves) {
  BulletWorld bw(WorldType::Discrete, 9.81f);
  SceneSettings settings;
  settings.domain.lower = {-0.04f, -0.02f, -0.02f};
  settings.domain.upper = {0.04f, 0.05f, 0.02f};
  settings.dx = 0.005f;
  settings.backend = Backend::Cpu;
  Scene scene(settings);
  btRigidBody* body = bw.addBody(new btSphereShape(0.001f), 0.005f,
                                 btTransform(btQuaternion::getIdentity(), btVector3(0, 0.03f, 0)));
  bullet::Coupler coupler(bw.world.get(), scene);
  const std::vector<uint8_t> before = coupler.saveToMemory();  // no curves yet: fine
  coupler.addNeedle(body, ArcDesc{});
  try {
    coupler.saveToMemory();
    ADD_FAILURE() << "saved a coupler with a needle";
  } catch (const CheckpointError& e) {
    EXPECT_EQ(e.reason(), CheckpointError::Reason::Unsupported);
    EXPECT_NE(std::string(e.what()).find("needles or threads"), std::string::npos) << e.what();
  }
  EXPECT_THROW(coupler.loadFromMemory(before), CheckpointError);
  coupler.remove(body);
  EXPECT_NO_THROW(coupler.saveToMemory());
}

}  // namespace
}  // namespace mpm
