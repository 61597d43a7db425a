// A suture thread's bending stiffness (SutureThreadDesc::youngsModulus, ThreadBending):
// checked against Euler-Bernoulli beam theory, with the tolerances stated. Bullet only.
#include <gtest/gtest.h>

#include <btBulletDynamicsCommon.h>
#include <BulletDynamics/Featherstone/btMultiBody.h>
#include <BulletDynamics/Featherstone/btMultiBodyDynamicsWorld.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "bullet_test_world.h"
#include "mpm_bullet/suture.h"
#include "suture_thread.h"

namespace mpm {
namespace {

using test::BulletWorld;
using test::WorldType;
using test::kThreadIterations;
using test::testThread;

/// A 3-0 polypropylene suture: E 2 GPa, diameter 0.2 mm, EI = E pi r^4 / 4 [N m^2].
constexpr float kPolypropylene = 2e9f, kRadius = 0.1e-3f;
const double kEI = kPolypropylene * M_PI * std::pow((double)kRadius, 4) / 4;

/// A cantilevered thread: 6 cm, 30 segments of a 3-0 suture of Young's modulus `E`, its
/// first segment Bullet's fixed base along +x, gravity off, a force `load` (along -y) on
/// its last segment's outer end for `seconds` at ticks of `tick`, with drag so it settles.
struct Cantilever {
  BulletWorld bw{WorldType::MultiBody, 0.f};
  bullet::SutureThreadDesc d;
  btMultiBody* thread = nullptr;
  double length = 0;  ///< the free length, from the first joint [m]
  bool finite = true;

  explicit Cantilever(float E) {
    bw.world->getSolverInfo().m_numIterations = kThreadIterations;
    d = testThread(btVector3(0, 0, 0), btVector3(1, 0, 0), 40.f);
    d.radius = kRadius;
    d.youngsModulus = E;
    d.fixedBase = true;
    thread = bullet::makeSutureThread(bw.multiWorld, d);
    length = d.length - d.length / d.segments;
  }
  ~Cantilever() { bullet::destroySutureThread(bw.multiWorld, thread); }
  /// One tick with `load` on the free end; the free end's deflection along -y after it.
  double tick(float load, float dt) {
    // at the outer end: the force and its moment about the link's centre (Bullet clears
    // both when stepSimulation returns)
    const btTransform t = bullet::threadSegmentTransform(thread, d.segments - 1);
    const btVector3 f(0, -load, 0), arm = t.getBasis() * btVector3(d.length / d.segments / 2, 0, 0);
    thread->addLinkForce(thread->getNumLinks() - 1, f);
    thread->addLinkTorque(thread->getNumLinks() - 1, arm.cross(f));
    bw.world->stepSimulation(dt, 0);
    const std::vector<btVector3> p = bullet::threadPoints(thread);
    for (const btVector3& q : p) finite = finite && test::finite(q);
    return -p.back().y();
  }
  double hold(float load, float dt, double seconds) {
    double delta = 0;
    for (int k = 0; k < (int)std::lround(seconds / dt); ++k) delta = tick(load, dt);
    return delta;
  }
};

/// The tip load that bends the cantilever's free length `l` by `deflection` as a rod.
float rodLoad(double deflection, double l) { return (float)(3 * kEI * deflection / (l * l * l)); }

// A cantilevered polypropylene 3-0 thread under a tip load deflects F l^3 / (3 EI)
// (Euler-Bernoulli): within 10 % at a deflection of 2 % of its length. The chain of 29
// joint springs EI / L is stiffer than the rod only through its discreteness: its tip
// deflection is F L^3 / EI (1^2 + ... + 29^2) = 1.052 times the rod's (l = 29 L).
// The same at Bullet ticks of 1/960 s and 1/240 s: the springs are implicit rows.
TEST(ThreadBending, ACantileverDeflectsAsAnEulerBernoulliRod) {
  for (float tick : {1.f / 960, 1.f / 240}) {
    Cantilever c(kPolypropylene);
    const double l = c.length;
    const float F = rodLoad(0.02 * l, l);  // 2 % of the free length
    const double delta = c.hold(F, tick, 2.0), rod = F * l * l * l / (3 * kEI);
    std::printf("cantilever, tick 1/%.0f s: EI %.3e N m^2, F %.3e N, tip deflection %.4e m, F l^3 / (3 EI) %.4e m "
                "(%+.1f %%)\n", 1 / tick, kEI, F, delta, rod, 100 * (delta / rod - 1));
    EXPECT_TRUE(c.finite);
    EXPECT_NEAR(delta, rod, 0.10 * rod) << "tick 1/" << 1 / tick;
  }
}

// Released, the cantilever swings at its first bending mode, omega_1 = 1.8751^2
// sqrt(EI / (mu l^4)) (Euler-Bernoulli; mu the thread's mass per length): the period
// between upward crossings of the rest line within 5 % over three periods, at 1/960 s
// ticks. The bending is solved with the thread's own inertia, not a raised one.
TEST(ThreadBending, AReleasedCantileverSwingsAtItsFirstMode) {
  const float tick = 1.f / 960;
  Cantilever c(kPolypropylene);
  const double l = c.length;
  c.hold(rodLoad(0.02 * l, l), tick, 2.0);
  c.thread->setLinearDamping(0);
  c.thread->setAngularDamping(0);
  std::vector<double> upward;  // times the free end crossed the rest line going up
  double before = c.tick(0.f, tick);
  for (int k = 1; k < 960 && upward.size() < 4; ++k) {
    const double now = c.tick(0.f, tick);
    if (before > 0 && now <= 0) upward.push_back(tick * (k - 1 + before / (before - now)));
    before = now;
  }
  ASSERT_EQ(upward.size(), 4u) << "fewer than four upward crossings in 1 s";
  const double period = (upward[3] - upward[0]) / 3;
  const double omega1 = 1.8751 * 1.8751 * std::sqrt(kEI / (c.d.linearDensity * l * l * l * l));
  const double analytic = 2 * M_PI / omega1;
  std::printf("released cantilever: period %.4f s, Euler-Bernoulli first mode %.4f s (%+.1f %%)\n", period, analytic,
              100 * (period / analytic - 1));
  EXPECT_TRUE(c.finite);
  EXPECT_NEAR(period, analytic, 0.05 * analytic);
}

// Without a Young's modulus the thread is limp: the same load swings the free end far
// past the rod's deflection (more than 5 times it): the stiffness is what held it.
TEST(ThreadBending, ALimpThreadDoesNotHoldTheLoad) {
  Cantilever c(0.f);
  const double l = c.length;
  const float F = rodLoad(0.02 * l, l);
  const double delta = c.hold(F, 1.f / 960, 2.0);
  std::printf("limp cantilever: tip deflection %.4e m under the load that bends the suture %.4e m\n", delta, 0.02 * l);
  EXPECT_TRUE(c.finite);
  EXPECT_GT(delta, 5 * 0.02 * l);
}

// A stiff thread pinned at one end and released horizontally under gravity swings down
// bending as it goes (no drag). The bending rows share the tick with the pin's: at Bullet
// ticks of 1/960 s and 1/240 s nothing is NaN, the segments keep their length and joints
// (1 % of a segment), the pin holds (2 % of a segment; the limp thread's pin opens 1.75 %
// at 1/240 s), and the free end after 1 s is where it is at the shorter tick within 2 mm.
TEST(ThreadBending, APinnedStiffThreadSwingsAlikeAtLongAndShortTicks) {
  btVector3 end[2];
  int k = 0;
  for (float tick : {1.f / 960, 1.f / 240}) {
    BulletWorld bw(WorldType::MultiBody, 9.81f);
    bw.world->getSolverInfo().m_numIterations = kThreadIterations;
    bullet::SutureThreadDesc d = testThread(btVector3(0, 0.1f, 0), btVector3(1, 0, 0), 0.f);
    d.radius = kRadius;
    d.youngsModulus = kPolypropylene;
    btMultiBody* thread = bullet::makeSutureThread(bw.multiWorld, d);
    bullet::pinThreadPoint(bw.multiWorld, thread, 0, nullptr, d.start);
    test::ThreadWatch watch;
    for (int i = 0; i < (int)std::lround(1.0 / tick); ++i) {
      bw.world->stepSimulation(tick, 0);
      watch.check(thread, d);
    }
    end[k] = bullet::threadPoints(thread).back();
    std::printf("stiff thread swinging from its pin, tick 1/%.0f s: worst |segment - L| / L %.2e, joint gap / L %.2e, "
                "pin gap / L %.2e, free end at 1 s (%.4f, %.4f) m\n", 1 / tick, watch.length, watch.joint, watch.pin,
                end[k].x(), end[k].y());
    EXPECT_TRUE(watch.finite);
    EXPECT_LT(watch.length, 0.01);
    EXPECT_LT(watch.joint, 0.01);
    EXPECT_LT(watch.pin, 0.02);
    bullet::destroySutureThread(bw.multiWorld, thread);
    ++k;
  }
  EXPECT_LT((end[1] - end[0]).length(), 2e-3f);
}

}  // namespace
}  // namespace mpm
