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
#include <cstring>
#include <functional>
#include <limits>
#include <string>
#include <tuple>
#include <vector>

#include "bullet_test_world.h"
#include "mpm/scene.h"
#include "mpm_bullet/coupler.h"
#include "mpm_bullet/scene_file.h"
#include "mpm_bullet/suture.h"
#include "pieces.h"
#include "suture_thread.h"
#include "test_paths.h"
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

/// The needle pass's patch of the suturing scene (NeedlePass): smaller blocks, gravity off,
/// the turn in 2.45 s, one tick a frame.
constexpr const char* kNeedlePass = R"({
    "settings": {"domain": {"lower": [-0.04, -0.02, -0.03], "upper": [0.04, 0.05, 0.03]}, "gravity": [0, 0, 0]},
    "objects": [{"name": "left", "center": [-0.013, 0.01, 0], "halfExtents": [0.01, 0.01, 0.00625]},
                {"name": "right", "center": [0.013, 0.01, 0], "halfExtents": [0.01, 0.01, 0.00625]}],
    "bodies": [{"name": "needle", "motion": {"keyframes": [
      {"time": 0.05, "position": [0, 0.026, 0], "rotation": {"axis": [0, 0, 1], "angle": 0}},
      {"time": 2.5, "position": [0, 0.026, 0], "rotation": {"axis": [0, 0, 1], "angle": 6.3704517697793035}}]}}],
    "output": {"frameTime": 1.0416666666666667e-4}})";

// (e) The pass: the suturing scene (assets/scenes/suturing.json, patched: the blocks of
// PullingTheStitch, 1.25 cm deep, in its grid, gravity off, and a faster turn; the needle,
// its driver, the thread and its path are the file's): a half-circle needle of 12 mm (a 100 g body driven by
// a NeedleDriver, coupled with addNeedle; toughness G_c 200 J/m^2, puncture force 0.3 N)
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
  auto loaded = bullet::LoadedScene::fromFile(test::assetPath("scenes/suturing.json"), kNeedlePass);
  Scene& scene = loaded->scene();
  const SceneSettings& settings = scene.settings();
  const ParticleObjectId left = loaded->object("left"), right = loaded->object("right");
  const Vec3f half{0.01f, 0.01f, 0.00625f};
  const float R = 0.012f, top = 0.02f, t1 = 2.5f;  // the arc's radius, the blocks' tops, the turn's end
  btRigidBody* needle = loaded->body("needle");
  btMultiBody* thread = loaded->thread("thread");
  const CurveId needleCurve = loaded->coupler().needleOf(needle);
  bullet::SutureThreadDesc d;  // what ThreadWatch checks against: its links, and its knot where it was laid
  d.length = 0.075f;
  d.segments = 30;
  d.start = bullet::threadPoints(thread).front();
  const btVector3 eyeInNeedle = loaded->threadPin("thread", d.segments)->getPivotInB();
  // the velocities the tick's advance moves the needle and the thread's points with
  btVector3 needleV, needleW;
  std::vector<btVector3> threadP, threadV;
  loaded->setPreTickCallback([&](float) {
    needleV = needle->getLinearVelocity();
    needleW = needle->getAngularVelocity();
    threadP = bullet::threadPoints(thread);
    threadV = bullet::threadPointVelocities(thread);
  });
  bullet::Coupler& coupler = loaded->coupler();
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
  const int ticks = (int)std::lround((t1 + 0.1f) / loaded->tick());
  for (int k = 0; k < ticks; ++k) {
    loaded->advanceFrame();  // one tick
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

/// What a resumed stitch must reproduce: the tissue's positions and velocities, the needle
/// body's pose and velocities, every segment's transform and the thread's point velocities.
std::vector<float> stitchState(bullet::LoadedScene& loaded) {
  std::vector<float> out;
  auto add = [&](const btVector3& v) { out.insert(out.end(), {(float)v.x(), (float)v.y(), (float)v.z()}); };
  for (const char* name : {"left", "right"}) {
    std::vector<Vec3f> x, v;
    loaded.scene().readPositions(loaded.object(name), x);
    loaded.scene().readVelocities(loaded.object(name), v);
    for (const Vec3f& p : x) out.insert(out.end(), {p.x, p.y, p.z});
    for (const Vec3f& p : v) out.insert(out.end(), {p.x, p.y, p.z});
  }
  const btRigidBody* needle = loaded.body("needle");
  for (int r = 0; r < 3; ++r) add(needle->getWorldTransform().getBasis()[r]);
  add(needle->getWorldTransform().getOrigin());
  add(needle->getLinearVelocity());
  add(needle->getAngularVelocity());
  const btMultiBody* thread = loaded.thread("thread");
  for (int s = 0; s <= thread->getNumLinks(); ++s) {
    const btTransform t = bullet::threadSegmentTransform(thread, s);
    for (int r = 0; r < 3; ++r) add(t.getBasis()[r]);
    add(t.getOrigin());
  }
  for (const btVector3& v : bullet::threadPointVelocities(thread)) add(v);
  return out;
}

// A stitch saved half way, the needle in the tissue and the thread drawn in behind it
// (the needle pass at 1.6 s), loaded into a fresh world built from the same file, steps
// on bit for bit as the run that was saved: the tissue, the needle and every link after
// 240 more ticks. Before, a coupler with needles or threads refused checkpoints.
TEST(StitchCheckpoint, ResumesBitForBitInAFreshWorld) {
  auto saved = bullet::LoadedScene::fromFile(test::assetPath("scenes/suturing.json"), kNeedlePass);
  const int before = (int)std::lround(1.6 / saved->tick()), after = 240;
  for (int k = 0; k < before; ++k) saved->advanceFrame();
  const CurveId needle = saved->coupler().needleOf(saved->body("needle"));
  int inside = 0;  // thread segment midpoints in the left block
  const std::vector<btVector3> p = bullet::threadPoints(saved->thread("thread"));
  for (size_t s = 0; s + 1 < p.size(); ++s) {
    const btVector3 m = 0.5f * (p[s] + p[s + 1]);
    inside += m.y() > 0.f && m.y() < 0.02f && std::fabs(m.z()) < 0.00625f && m.x() > -0.023f && m.x() < -0.003f;
  }
  std::printf("stitch saved at %.3f s: the tip inside %d, thread segments in block 1: %d\n", saved->scene().time(),
              (int)saved->scene().tipInside(needle), inside);
  ASSERT_GE(inside, 1) << "the thread is not drawn into the tissue yet: not a stitch half way";
  const std::string path = ::testing::TempDir() + "mid_stitch.ckpt";
  saved->saveCheckpoint(path);
  for (int k = 0; k < after; ++k) saved->advanceFrame();
  auto fresh = bullet::LoadedScene::fromFile(test::assetPath("scenes/suturing.json"), kNeedlePass);
  fresh->loadCheckpoint(path);
  for (int k = 0; k < after; ++k) fresh->advanceFrame();
  std::remove(path.c_str());
  EXPECT_EQ(fresh->scene().time(), saved->scene().time());
  const std::vector<float> a = stitchState(*saved), b = stitchState(*fresh);
  ASSERT_EQ(a.size(), b.size());
  size_t differ = 0;
  for (size_t i = 0; i < a.size(); ++i) differ += std::memcmp(&a[i], &b[i], sizeof(float)) != 0;
  EXPECT_EQ(differ, 0u) << "of " << a.size() << " values";
}

}  // namespace
}  // namespace mpm
