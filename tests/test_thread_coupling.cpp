// A suture thread coupled to tissue (Coupler::addThread): momentum across the coupling, a
// thread anchored, drawn through and laid in tissue, the added-mass coupling and a stitch
// pulled tight. Every check is against an analytic value or a conservation law, with its
// tolerance stated. CPU backend.
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

/// Linear momentum of a multibody (sum over its links of m v of the centre of mass).
btVector3 multiBodyMomentum(const btMultiBody* mb) {
  const int n = mb->getNumLinks() + 1;
  btAlignedObjectArray<btVector3> omega, vel;
  omega.resize(n);
  vel.resize(n);
  mb->compTreeLinkVelocities(&omega[0], &vel[0]);
  btVector3 p = mb->getBaseMass() * mb->getBaseVel();
  for (int s = 1; s < n; ++s)
    p += mb->getLink(s - 1).m_mass * (bullet::threadSegmentTransform(mb, s).getBasis() * vel[s]);
  return p;
}

// (d) A Bullet thread (makeSutureThread: 3 cm in 6 segments of 5 mm, 1e-2 kg/m) lying
// straight inside a free soft block (4 x 2 x 1.25 cm, E 30 kPa, dx 2.5 mm), coupled with
// addThread, thrown sideways at 5 cm/s, gravity off in both worlds: over 25 ms the block
// gains the momentum the thread loses (Bullet's link velocities), 1e-4 relative to the
// thread's initial momentum (measured 2e-6), and the thread has lost most of it.
// Limits found (coupler.h, addThread): segments of one cell (2.5 mm) or lighter threads
// (1e-3 kg/m) blow up within a few ticks; the scene alone amplifies a zigzag of adjacent
// light segments (reported to the core). With half the thread outside the block the
// bending chain's Featherstone momentum is off by 1e-2 of the throw across it (Bullet's
// semi-implicit step of a bending chain does not conserve linear momentum), so the thread
// lies inside here. The same with the tissue advanced once every 4 ticks
// (Coupler::setTissueInterval; each segment's impulse spread over the 4 ticks), compared
// at the end of the intervals.
class ThreadCouplingInterval : public ::testing::TestWithParam<int> {};

TEST_P(ThreadCouplingInterval, BlockGainsWhatTheThreadLoses) {
  BulletWorld bw(WorldType::MultiBody, 0.f);
  bw.world->getSolverInfo().m_numIterations = kThreadIterations;
  Scene scene(threadTissueSettings());
  ParticleObjectDesc block = tissueBlock({0.02f, 0.01f, 0.00625f}, {0.f, 0.01f, 0.f}, 3e4f, 0.3f, 1000.f);
  const ParticleObjectId blockId = scene.addParticleObject(block);
  bullet::SutureThreadDesc d = testThread(btVector3(-0.015f, 0.01f, 0.0011f), btVector3(1, 0, 0), 0.f);
  d.length = 0.03f;
  d.segments = 6;
  d.linearDensity = 1e-2f;
  btMultiBody* thread = bullet::makeSutureThread(bw.multiWorld, d);
  const btVector3 v0(0, 0, 0.05f);
  thread->setBaseVel(v0);  // every link moves with the base: the joints are at rest
  bullet::Coupler coupler(bw.world.get(), scene);
  const CurveId curve = coupler.addThread(thread);
  coupler.setTissueInterval(GetParam());
  EXPECT_TRUE(scene.isValid(curve));
  auto blockMomentum = [&] {
    const ObjectSummary s = scene.summary(blockId);
    return btVector3((btScalar)s.momentum[0], (btScalar)s.momentum[1], (btScalar)s.momentum[2]);
  };
  const btVector3 thrown = multiBodyMomentum(thread), pb0 = blockMomentum();
  for (int k = 0; k < 24; ++k) {  // 25 ms
    bw.world->stepSimulation(kThreadTick, 0);
    coupler.rethrowError();
  }
  const btVector3 lost = thrown - multiBodyMomentum(thread), gained = blockMomentum() - pb0;
  std::printf("thread thrown with (%.4e, %.4e, %.4e), lost (%.4e, %.4e, %.4e); block gained (%.4e, %.4e, %.4e) kg m/s; "
              "|gained - lost| / |thrown| %.2e\n",
              thrown.x(), thrown.y(), thrown.z(), lost.x(), lost.y(), lost.z(), gained.x(), gained.y(), gained.z(),
              (gained - lost).length() / thrown.length());
  EXPECT_GT(lost.z(), 0.5f * thrown.z()) << "the block stops the thread";
  EXPECT_LT((gained - lost).length(), 1e-4 * thrown.length());
  coupler.removeThread(thread);
  EXPECT_FALSE(scene.isValid(curve));
  bullet::destroySutureThread(bw.multiWorld, thread);
}

INSTANTIATE_TEST_SUITE_P(TicksPerAdvance, ThreadCouplingInterval, ::testing::Values(1, 4),
                         [](const auto& info) { return "Every" + std::to_string(info.param) + "Ticks"; });

// (d) A thread anchored at one end (SutureThreadDesc::fixedBase: its first segment is
// Bullet's fixed base, outside the tissue) with the rest lying in a free soft block moving
// at 5 cm/s across it, coupled both ways (addThread takes a fixed base: the anchor holds
// what the tissue gives the base). Over 25 ms the tissue drags the free links along
// (their momentum rises toward the block's motion) while the anchored end stays exactly
// where it was built (1e-6 of a segment) and nothing is NaN.
TEST(ThreadCoupling, AnchoredThreadIsDraggedByTheTissueAndKeepsItsAnchor) {
  BulletWorld bw(WorldType::MultiBody, 0.f);
  bw.world->getSolverInfo().m_numIterations = kThreadIterations;
  Scene scene(threadTissueSettings());
  ParticleObjectDesc block = tissueBlock({0.015f, 0.01f, 0.00625f}, {0.005f, 0.01f, 0.f}, 3e4f, 0.3f, 1000.f);
  block.velocity = {0.f, 0.f, 0.05f};
  scene.addParticleObject(block);
  // 3 cm in 6 segments from x = -1.5 cm: the anchored first segment lies outside the block
  // (which starts at x = -1 cm), the other five inside
  bullet::SutureThreadDesc d = testThread(btVector3(-0.015f, 0.01f, 0.0011f), btVector3(1, 0, 0), 0.f);
  d.length = 0.03f;
  d.segments = 6;
  d.linearDensity = 1e-2f;
  d.fixedBase = true;
  btMultiBody* thread = bullet::makeSutureThread(bw.multiWorld, d);
  bullet::Coupler coupler(bw.world.get(), scene);
  bullet::ThreadCoupling options;
  options.dynamic = true;
  const CurveId curve = coupler.addThread(thread, options);
  EXPECT_TRUE(scene.isValid(curve));
  ThreadWatch watch;
  for (int k = 0; k < 24; ++k) {  // 25 ms
    bw.world->stepSimulation(kThreadTick, 0);
    coupler.rethrowError();
    watch.check(thread, d);
  }
  const btVector3 p = multiBodyMomentum(thread), end = bullet::threadPoints(thread).back();
  const float Mfree = d.linearDensity * d.length * 5 / 6;
  std::printf("anchored thread: momentum of the links (%.3e, %.3e, %.3e) kg m/s (free links at the block's speed: "
              "%.3e), free end moved %.3f mm along z, anchor gap / L %.2e, links %.2e\n",
              p.x(), p.y(), p.z(), Mfree * 0.05f, (end.z() - 0.0011f) * 1e3, watch.pin, watch.length);
  EXPECT_TRUE(watch.finite);
  EXPECT_LT(watch.pin, 1e-6) << "the anchor holds";
  EXPECT_LT(watch.length, 0.01);
  EXPECT_GT(p.z(), 0.2f * Mfree * 0.05f) << "the tissue drags the free links";
  EXPECT_LT(p.z(), 1.01f * Mfree * 0.05f) << "but not faster than it moves";
  EXPECT_GT(end.z(), 0.0011f) << "the free end follows the block";
  coupler.removeThread(thread);
  bullet::destroySutureThread(bw.multiWorld, thread);
}

// (d) The demo's eye in the tissue: a real suture (3-0: 0.05 g/m, radius 0.15 mm) of six
// one-cell segments (2.5 mm), its first point pinned to a holder (a 100 g body, as the
// demo's needle) that moves at 17 mm/s (the demo's eye) through a block glued to its base,
// along the thread or sideways (from z = 1.1 mm, or from 2.35 mm inside the block's back
// face); coupled both ways, for 0.2 s. The pin holds within 1 % of a segment, links stay
// within 1 % of their length, and the tissue gives the light thread no speed of its own:
// no point of the thread moves faster than the holder or the fastest tissue particle (1 %).
// Drawn sideways the band (1.5 dx) drags the tissue ahead of the thread, which bursts
// where the band's edge sweeps node layers near a face: tissue at up to 0.17 m/s (0.23
// from the back), the thread following it at 0.05 m/s (3 times the holder; with the band
// 0.75 dx the thread stayed under twice the holder's speed). Sideways the segments turn
// against the material; before their angular exchange changed (contact/rigid_body.h,
// settleBodyVelocity) the links took hundreds of times their share: points at 7.8 m/s and
// the pin 8.4 mm open within 3 ticks; from the back face, before every segment was asked
// for a node's nearest (nearerSegment), the lead segment and one two further on both took
// the nodes between them: points at 2.5 m/s, the pin 0.53 mm open.
class ThreadDrawnThroughTissue : public ::testing::TestWithParam<std::tuple<bool, float>> {};

TEST_P(ThreadDrawnThroughTissue, StaysOnItsPin) {
  const bool sideways = std::get<0>(GetParam());
  BulletWorld bw(WorldType::MultiBody, 0.f);
  bw.world->getSolverInfo().m_numIterations = kThreadIterations;
  Scene scene(threadTissueSettings());
  ParticleObjectDesc block = tissueBlock({0.02f, 0.01f, 0.00625f}, {0.f, 0.01f, 0.f}, 4e4f, 0.4f, 1060.f);
  const ParticleObjectId blockId = scene.addParticleObject(block);
  scene.addShape(test::basePlate());
  const btVector3 eye(0.005f, 0.01f, std::get<1>(GetParam()));
  btRigidBody* holder = bw.addBody(new btSphereShape(0.001f), 0.1f, btTransform(btQuaternion::getIdentity(), eye));
  holder->setCollisionFlags(holder->getCollisionFlags() | btCollisionObject::CF_NO_CONTACT_RESPONSE);
  bullet::SutureThreadDesc d = testThread(eye, btVector3(-1, 0, 0), 1.f);
  d.segments = 6;
  d.length = 0.015f;
  d.linearDensity = 5e-5f;
  btMultiBody* thread = bullet::makeSutureThread(bw.multiWorld, d);
  bullet::pinThreadPoint(bw.multiWorld, thread, 0, holder, btVector3(0, 0, 0));
  bullet::Coupler coupler(bw.world.get(), scene);
  coupler.addThread(thread);
  const float speed = 0.017f;
  const btVector3 v = sideways ? btVector3(0, 0, speed) : btVector3(speed, 0, 0);
  coupler.setPreTickCallback([&](float) {
    holder->setLinearVelocity(v);
    holder->setAngularVelocity(btVector3(0, 0, 0));
  });
  ThreadWatch watch;
  double pin = 0, fastest = 0, tissue = 0;
  std::vector<Vec3f> velocities;
  for (int k = 0; k < 192; ++k) {  // 0.2 s
    bw.world->stepSimulation(kThreadTick, 0);
    coupler.rethrowError();
    watch.check(thread, d);
    pin = std::max(pin, (double)(bullet::threadPoints(thread)[0] - holder->getCenterOfMassPosition()).length());
    for (const btVector3& q : bullet::threadPointVelocities(thread)) fastest = std::max(fastest, (double)q.length());
    scene.readVelocities(blockId, velocities);
    for (const Vec3f& u : velocities) tissue = std::max(tissue, (double)norm(u));
    if (!watch.finite || pin > d.length) break;
  }
  const float L = d.length / d.segments;
  std::printf("thread drawn %s at %.3f m/s from z = %.1f mm: pin gap %.2e m (%.2e of a segment), links %.2e, fastest "
              "point %.4f m/s, fastest tissue %.4f m/s\n", sideways ? "sideways" : "along itself", speed,
              1e3f * eye.z(), pin, pin / L, watch.length, fastest, tissue);
  EXPECT_TRUE(watch.finite);
  EXPECT_LT(pin, 0.01 * L);
  EXPECT_LT(watch.length, 0.01);
  EXPECT_LE(fastest, 1.01 * std::max((double)speed, tissue));
  coupler.removeThread(thread);
  bullet::destroySutureThread(bw.multiWorld, thread);
}

INSTANTIATE_TEST_SUITE_P(Direction, ThreadDrawnThroughTissue,
                         ::testing::Values(std::make_tuple(false, 0.0011f), std::make_tuple(true, 0.0011f),
                                           std::make_tuple(true, -0.0039f)),
                         [](const auto& info) {
                           return std::string(!std::get<0>(info.param) ? "AlongItself"
                                              : std::get<1>(info.param) > 0.f ? "Sideways"
                                                                               : "SidewaysFromTheBack");
                         });

/// A stitch's loop for a thread of 2.5 mm segments: down through the left block at x = -7.5 mm
/// from 10.5 mm above its top, 6 segments under the gap at y = 8 mm, up through the right
/// block at +7.5 mm to as high (24 segments, 6 cm).
std::vector<btVector3> stitchLoop() {
  std::vector<btVector3> p;
  const float L = 0.0025f, top = 0.0205f, bottom = top - 5 * L, z = 0.0011f, step = L * (float)M_SQRT1_2;
  for (int i = 3; i >= 1; --i) p.emplace_back(-0.0075f + step * i, top + step * i, z);  // knot to the left exit
  for (int i = 0; i <= 5; ++i) p.emplace_back(-0.0075f, top - L * i, z);                // down the left bite
  for (int i = 1; i <= 6; ++i) p.emplace_back(-0.0075f + L * i, bottom, z);             // across, under the gap
  for (int i = 1; i <= 5; ++i) p.emplace_back(0.0075f, bottom + L * i, z);              // up the right bite
  for (int i = 1; i <= 3; ++i) p.emplace_back(0.0075f - step * i, top + step * i, z);   // to the free end
  return p;
}

// layThreadAlong: a fixed-base thread laid along a stitch's loop (five straight runs, two
// right-angle turns and two of 135 degrees) has its points where asked (1e-6 m: float transforms over 6 cm) and
// stays there, at rest, over 0.1 s without forces (a fixed base and no gravity: nothing
// moves it; 1e-6 m); a list of the wrong length or spacing is refused naming the point.
TEST(SutureThread, LaidAlongALoopStaysThere) {
  BulletWorld bw(WorldType::MultiBody, 0.f);
  bw.world->getSolverInfo().m_numIterations = kThreadIterations;
  const std::vector<btVector3> loop = stitchLoop();
  bullet::SutureThreadDesc d = testThread(loop.front(), btVector3(0, -1, 0), 0.f);
  d.segments = (int)loop.size() - 1;
  d.length = 0.0025f * d.segments;
  d.fixedBase = true;
  btMultiBody* thread = bullet::makeSutureThread(bw.multiWorld, d);
  bullet::layThreadAlong(thread, loop);
  auto worst = [&] {
    const std::vector<btVector3> p = bullet::threadPoints(thread);
    double e = 0;
    for (size_t i = 0; i < p.size(); ++i) e = std::max(e, (double)(p[i] - loop[i]).length());
    return e;
  };
  const double laid = worst();
  for (int k = 0; k < 96; ++k) bw.world->stepSimulation(kThreadTick, 0);
  const double after = worst();
  std::printf("thread laid along a loop: points off by %.2e m, after 0.1 s %.2e m\n", laid, after);
  EXPECT_LT(laid, 1e-6);
  EXPECT_LT(after, 1e-6);
  std::vector<btVector3> shortList(loop.begin(), loop.end() - 1);
  EXPECT_THROW(bullet::layThreadAlong(thread, shortList), InvalidArgument);
  std::vector<btVector3> stretched = loop;
  stretched[5].setY(stretched[5].y() - 0.001f);
  try {
    bullet::layThreadAlong(thread, stretched);
    ADD_FAILURE() << "a point off the spacing was taken";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("layThreadAlong points[5]"), std::string::npos) << e.what();
  }
  bullet::destroySutureThread(bw.multiWorld, thread);
}


/// What a pulled stitch did (PullingTheStitch).
struct StitchPull {
  float gap0 = 0, gap = 0;       ///< [m] across the wound, before and after
  double tension = 0;            ///< [N] the largest force of the holder's pin over a tick
  double pin = 0, pinEnd = 0;    ///< the pin's gap, its largest and at the end, per segment length
  double links = 0;              ///< the links' largest stretch, per segment length
  /// [m] the largest rise of the left block's particles that start within 2.5 mm of its
  /// glued base: whether the base plate (Bonded) holds it
  float baseRise = 0;
  bool finite = true;
};

/// Two blocks 2 x 2 x 1.25 cm 6 mm apart (E 30 kPa, nu 0.3, the blocks of
/// Suturing.TighteningAStitchClosesTheGap), glued at their bases; a 3-0 thread (0.05 g/m, 22
/// links of 2.5 mm) laid through both as a stitch being tied (stitchLoop), its knot end
/// Bullet's fixed base above the left block's edge, its other end pinned to a 100 g holder
/// above the right block's edge, drawn straight up at 1 cm/s for `seconds`, in Bullet
/// ticks of `tick`, the tissue advanced once every `interval` ticks; coupled both ways, with
/// or without the added-mass coupling. The thread carries up to 10 N stably at that tick
/// (SutureThreadDesc::maxTension: half a 3-0 suture's breaking load). Prints the gap and
/// the tension every 0.5 s.
StitchPull pullStitch(SolverType solver, bool addedMass, float seconds, float tick, int interval = 1) {
  BulletWorld bw(WorldType::MultiBody, 0.f);
  bw.world->getSolverInfo().m_numIterations = kThreadIterations;
  SceneSettings settings = threadTissueSettings();
  settings.domain.upper.y = 0.06f;
  settings.solver = solver;
  Scene scene(settings);
  const ParticleObjectId left = scene.addParticleObject(tissueBlock({0.01f, 0.01f, 0.00625f}, {-0.013f, 0.01f, 0.f}, 3e4f, 0.3f, 1000.f));
  const ParticleObjectId right = scene.addParticleObject(tissueBlock({0.01f, 0.01f, 0.00625f}, {0.013f, 0.01f, 0.f}, 3e4f, 0.3f, 1000.f));
  scene.addShape(test::basePlate());
  const std::vector<btVector3> loop = stitchLoop();
  bullet::SutureThreadDesc d = testThread(loop.front(), btVector3(0, -1, 0), 1.f);
  d.segments = (int)loop.size() - 1;
  d.length = 0.0025f * d.segments;
  d.linearDensity = 5e-5f;
  d.maxTension = 10.f;
  d.tick = tick;
  d.fixedBase = true;
  btMultiBody* thread = bullet::makeSutureThread(bw.multiWorld, d);
  bullet::layThreadAlong(thread, loop);
  btRigidBody* holder = bw.addBody(new btSphereShape(0.001f), 0.1f, btTransform(btQuaternion::getIdentity(), loop.back()));
  holder->setCollisionFlags(holder->getCollisionFlags() | btCollisionObject::CF_NO_CONTACT_RESPONSE);
  btMultiBodyPoint2Point* pin = bullet::pinThreadPoint(bw.multiWorld, thread, d.segments, holder, btVector3(0, 0, 0));
  bullet::Coupler coupler(bw.world.get(), scene);
  bullet::ThreadCoupling options;
  options.dynamic = true;
  options.addedMass = addedMass;
  coupler.addThread(thread, options);
  coupler.setTissueInterval(interval);
  const btVector3 v(0.f, 0.01f, 0.f);
  coupler.setPreTickCallback([&](float) {
    holder->setLinearVelocity(v);
    holder->setAngularVelocity(btVector3(0, 0, 0));
  });
  StitchPull r;
  r.gap0 = test::woundGap(scene, left, right);
  std::vector<Vec3f> start;
  scene.readPositions(left, start);
  ThreadWatch watch;
  const float L = d.length / d.segments;
  const int ticks = (int)std::lround(seconds / tick);
  for (int k = 0; k < ticks; ++k) {
    bw.world->stepSimulation(tick, 0);
    coupler.rethrowError();
    watch.check(thread, d);
    r.pinEnd = (bullet::threadPoints(thread).back() - holder->getCenterOfMassPosition()).length() / L;
    r.pin = std::max(r.pin, r.pinEnd);
    r.tension = std::max(r.tension, (double)bullet::pinForce(pin, tick).length());
    if ((k + 1) % (int)std::lround(0.5f / tick) == 0)
    {
      std::printf("  %.1f s: gap %.2f mm, tension %.3f N, pin gap %.2e of a segment\n", (k + 1) * tick,
                  1e3f * test::woundGap(scene, left, right), (double)bullet::pinForce(pin, tick).length(), r.pinEnd);
    }
    if (!watch.finite || r.pin > d.segments) break;
  }
  r.gap = test::woundGap(scene, left, right);
  std::vector<Vec3f> end;
  scene.readPositions(left, end);
  for (size_t i = 0; i < end.size(); ++i)
    if (start[i].y < 0.0025f) r.baseRise = std::max(r.baseRise, end[i].y - start[i].y);
  r.links = watch.length;
  r.finite = watch.finite;
  std::printf("stitch pulled %.2f s (%s, %s, ticks of 1/%.0f s): gap %.2f -> %.2f mm, peak tension %.2e N, pin gap "
              "%.2e of a segment at the most, %.2e at the end, links %.2e; the left block's base rose %.2f mm\n", seconds,
              solver == SolverType::MlsMpm ? "MLS-MPM" : "PB-MPM", addedMass ? "added mass" : "segment momentum only",
              1.f / tick, 1e3f * r.gap0, 1e3f * r.gap, r.tension, r.pin, r.pinEnd, r.links, 1e3f * r.baseRise);
  coupler.removeThread(thread);
  bullet::destroySutureThread(bw.multiWorld, thread);
  return r;
}

// (e) The tissue holds a pulled thread only with the added-mass coupling
// (ThreadCoupling::addedMass). A dynamic segment's link otherwise receives only the
// segment's own momentum change, so the tissue holds it with at most m v_rel / dt (3-0,
// 2.5 mm, 1 cm/s: about 1e-5 N): the thread slides through the tissue, the gap stays and
// the thread carries no tension (measured: 7.25 -> 7.22 mm, 5.8e-4 N at the most). With the
// added mass (the held nodes' mass on each link in Bullet, only the tissue's elastic push
// explicit) the pull reaches the tissue: over 0.6 s (MLS-MPM, ticks of 1/9600 s: the
// explicit elastic force on links of about 5e-5 kg wants ticks that short; at 1/960 s it
// blew up within 0.03 s) the tension builds (0.114 N at its peak; 0.055 N with the band
// 0.75 dx) and the stitch draws the blocks 1.94 mm together (0.95 mm). Bounds: under 1 mN
// without; with, at least 0.35 mm of closing and 0.025 N.
TEST(ThreadCoupling, AddedMassLetsAPulledThreadDrawTheTissue) {
  const StitchPull before = pullStitch(SolverType::MlsMpm, false, 0.6f, 1.f / 9600);
  const StitchPull after = pullStitch(SolverType::MlsMpm, true, 0.6f, 1.f / 9600);
  EXPECT_TRUE(before.finite && after.finite);
  EXPECT_LT(before.tension, 1e-3) << "the tissue does not hold a light segment's link";
  EXPECT_LT(std::fabs(before.gap - before.gap0), 1e-4f);
  EXPECT_GT(after.tension, 0.025) << "the tissue holds the thread: the pull builds tension";
  EXPECT_LT(after.gap, after.gap0 - 0.35e-3f) << "and the loop draws the blocks together";
  EXPECT_LT(after.links, 0.01);
}

// (e) The added-mass coupling's bookkeeping: it needs a dynamic coupling (refused naming the
// field otherwise); while coupled in tissue each link carries its own mass plus the nodes'
// its segment holds (Scene::segmentContactMasses: for a 3-0 thread's 2.5 mm segment, 750
// times its own); removed, its own mass again.
TEST(ThreadCoupling, AddedMassIsTheHeldNodesAndLeavesWithTheThread) {
  BulletWorld bw(WorldType::MultiBody, 0.f);
  Scene scene(threadTissueSettings());
  scene.addParticleObject(tissueBlock({0.02f, 0.01f, 0.00625f}, {0.f, 0.01f, 0.f}, 3e4f, 0.3f, 1000.f));
  bullet::SutureThreadDesc d = testThread(btVector3(-0.0075f, 0.011f, 0.0011f), btVector3(1, 0, 0), 0.f);
  d.segments = 6;
  d.length = 0.015f;
  d.linearDensity = 5e-5f;
  btMultiBody* thread = bullet::makeSutureThread(bw.multiWorld, d);
  bullet::Coupler coupler(bw.world.get(), scene);
  bullet::ThreadCoupling options;
  options.dynamic = false;
  options.addedMass = true;
  try {
    coupler.addThread(thread, options);
    ADD_FAILURE() << "added mass without the dynamic coupling was taken";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("ThreadCoupling.addedMass"), std::string::npos) << e.what();
  }
  options.dynamic = true;
  const CurveId curve = coupler.addThread(thread, options);
  const btScalar own = thread->getLink(2).m_mass;
  bw.world->stepSimulation(kThreadTick, 0);
  coupler.rethrowError();
  const std::vector<float> Mc = scene.segmentContactMasses(curve);
  std::printf("link 2: own mass %.3e kg, held nodes %.3e kg, in Bullet %.3e kg\n", own, Mc[3], thread->getLink(2).m_mass);
  // off the node lines by 0.4 and 0.44 dx, six node lines pass within the band's 1.5 dx
  // (0.595, 0.688, 0.744, 0.821, 1.468 and 1.495 dx off it; the next, 1.51 dx), and a
  // segment one cell long holds one node of each (Suturing.SegmentContactMassesAreTheNodesTheyHold):
  // 6 rho dx^3, 750 times its own
  const float dx = 0.0025f;
  EXPECT_NEAR(Mc[3], 6 * 1000.f * dx * dx * dx, 1e-4f * Mc[3]);
  EXPECT_NEAR(thread->getLink(2).m_mass, own + Mc[3], 1e-6 * Mc[3]);
  coupler.removeThread(thread);
  EXPECT_EQ(thread->getLink(2).m_mass, own);
  bullet::destroySutureThread(bw.multiWorld, thread);
}

// (e) A stitch pulled tight (the wound's gap closes to under a third of
// its width, with MLS-MPM and with PB-MPM). Added mass, Bullet ticks of 1/9600 s, the holder
// drawn straight up at 1 cm/s. The loop between the knot and the holder draws the edges
// together and, the knot being 5.8 mm above the tissue, lifts the tissue inside the loop
// toward the line from knot to holder (the wound everts); pulled on, the lifted left edge
// is drawn over the right block. Bounds: the gap between 0 (the facing sides meet, not
// pass each other) and a third of its width; the holder's pin within 1 % of a segment at
// the end and never open a quarter of one; links within 1 %; the blocks stay glued to their
// base plate (its particles rise under 1 mm, 0.4 dx). Before glued material stayed glued
// (push_out.h) the left block peeled off its base as the loop lifted it (its base rose
// 2.3 mm with MLS-MPM, 9.0 mm with PB-MPM), and that let the wound close further.
void expectStitchClosed(const StitchPull& r) {
  EXPECT_TRUE(r.finite);
  EXPECT_LE(r.gap, r.gap0 / 3.f);
  EXPECT_GE(r.gap, 0.f) << "the facing sides passed each other";
  EXPECT_LT(r.pinEnd, 0.01);
  EXPECT_LT(r.pin, 0.25);
  EXPECT_LT(r.links, 0.01);
  EXPECT_LT(r.baseRise, 1e-3f) << "the left block came off its glued base";
}

// MLS-MPM, 3.5 s (measured: 7.25 -> 1.94 mm, a third being 2.42 mm; tension 0.27 N at 1 s,
// 0.69 N at 2 s, 0.91 N at the peak; the pin 5.9 % of a segment at the most, 0.07 % at the
// end; the base rose 0.38 mm). Before the thread's contact band was widened to 1.5 dx (kThreadReach) the tissue
// streamed through the thread and the stitch stalled at 4.4 mm at 0.2 N; before
// SutureThreadDesc::maxTension the pin let go entirely at 0.15 N
// (TautSegmentsTurnWithinTheTick).
TEST(PullingTheStitch, ClosesTheGapMlsMpm) { expectStitchClosed(pullStitch(SolverType::MlsMpm, true, 3.5f, 1.f / 9600)); }

// PB-MPM has no Young's modulus: its stiffness is its iterations per unit time
// (solvers/pb_mpm.h). Advanced at every 1/9600 s tick its 10 iterations made the blocks
// nearly rigid (4.9 N by 0.75 s, then the holder's pin let go at 69 N), so the thread is
// coupled across a tissue interval (Coupler::setTissueInterval): Bullet ticks at 1/9600 s,
// PB-MPM advances once every 6 ticks (1/1600 s). At that step it carries the MLS-MPM
// tissue's tension at the same pull (0.36 N at 1 s, 0.70 N at 2 s; MLS-MPM 0.27 and 0.70
// N); measured over the intervals, 1/800 s gave 0.09 and 0.21 N, 1/1200 s 0.21 and 0.44 N.
// Pulled 3.5 s like MLS-MPM (measured: 7.25 -> 2.68 mm at 2.5 s, 2.29 mm at 3 s, 2.20 mm at
// 3.5 s; tension 0.75 N at 2 s and 0.67 N at the end, 1.14 N at the peak; the pin 12.1 % of
// a segment at the most, 0.26 % at the end; the base rose 0.38 mm). While the left block
// peeled off its base (it rose 9 mm), its edge rose between 2 and 2.5 s and passed over
// the right block by 3 s, and this stitch was pulled only 2.5 s (1.43-2.19 mm, moving with
// float rounding). At 1/400 s with 30 iterations the explicit exchange blew up (179 N, the
// pin let go).
TEST(PullingTheStitch, ClosesTheGapPbMpm) { expectStitchClosed(pullStitch(SolverType::PbMpm, true, 3.5f, 1.f / 9600, 6)); }

}  // namespace
}  // namespace mpm
