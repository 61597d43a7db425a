// Physics through the Bullet coupling against closed forms: Coulomb sliding of tissue on a
// tilted static Bullet box, momentum conservation when a Bullet sphere hits free tissue, a
// Featherstone chain (btMultiBody links) following its links' velocities and resting on
// tissue with its weight, and Bullet shapes with local scaling and compounds converted to
// MPM geometry. The coupled cases run in a btDiscreteDynamicsWorld and a
// btMultiBodyDynamicsWorld where both apply, and with each solver, with the same bounds.
#include <gtest/gtest.h>

#include <btBulletDynamicsCommon.h>
#include <BulletDynamics/Featherstone/btMultiBody.h>
#include <BulletDynamics/Featherstone/btMultiBodyConstraintSolver.h>
#include <BulletDynamics/Featherstone/btMultiBodyDynamicsWorld.h>
#include <BulletDynamics/Featherstone/btMultiBodyLinkCollider.h>
#include <BulletCollision/CollisionShapes/btConvexPointCloudShape.h>
#include <BulletCollision/CollisionShapes/btConvexPolyhedron.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "bullet_test_world.h"
#include "mpm/scene.h"
#include "mpm_bullet/coupler.h"
#include "mpm_bullet/shape_conversion.h"
#include "shapes/sdf_primitives.h"
#include "incline.h"
#include "solver_cases.h"

namespace mpm {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr float kG = 9.81f;

using test::BulletWorld;
using test::WorldType;

Material softTissue() {
  Material m;
  m.model = MaterialModel::NeoHookeanDecoupled;
  m.youngsModulus = 2e5f;
  m.poissonRatio = 0.3f;
  m.density = 1000.f;
  return m;
}

using test::BodySum;
using test::sumOf;

class BulletPhysics : public test::WorldAndSolver {};

// ---------------------------------------------------------------------------------------
// 1. Incline. The ramp is a static btRigidBody with a btBoxShape tilted by theta about z
// (top face descending along +x: outward normal n = (sin, cos, 0), downhill s = (cos, -sin,
// 0)), coupled with friction mu. Bullet's and the scene's gravity are both (0, -g, 0). The
// tissue is a parallelogram of vertical columns one particle wide, each starting half a
// particle spacing above the face (the API samples axis-aligned boxes only), as in
// test_contact. Closed form: a = g (sin theta - mu cos theta) if tan theta > mu, else rest.

struct InclineResult {
  double acceleration = 0;  ///< (v_s(t2) - v_s(t1)) / (t2 - t1) [m/s^2]
  double fitted = 0;        ///< least-squares slope of v_s(t) over [t1, t2] [m/s^2]
  double maxSpeed = 0;      ///< largest |v_s| over [t1, t2] [m/s]
  double travel = 0;        ///< CoM displacement along s over [t1, t2] [m]
  double t1 = 0, t2 = 0;    ///< [s]
};

/// Where the ramp's friction mu comes from: CouplingOptions (an explicit override), the
/// ramp body's own btCollisionObject::setFriction (no override), or, multibody world only,
/// the friction of the base collider of a fixed-base btMultiBody that is the ramp.
enum class FrictionFrom { Options, Body, MultiBodyCollider };

InclineResult runIncline(WorldType type, SolverType solver, double theta, float mu,
                         FrictionFrom from = FrictionFrom::Options) {
  BulletWorld bw(type, kG);
  const test::Incline incline{theta};
  SceneSettings st;
  st.solver = solver;
  incline.configure(st);
  st.gravity = {0.f, -kG, 0.f};
  Scene scene(st);

  const Vec3f centre = incline.rampCentre();
  const btTransform rampPose(btQuaternion(btVector3(0, 0, 1), (btScalar)-theta),
                             btVector3(centre.x, centre.y, centre.z));
  const float* half = test::Incline::kRampHalf;
  bullet::Coupler coupler(bw.world.get(), scene);
  if (from == FrictionFrom::MultiBodyCollider) {
    btBoxShape* box = new btBoxShape(btVector3(half[0], half[1], half[2]));
    bw.shapes.emplace_back(box);
    bw.multiBodies.emplace_back(new btMultiBody(0, 0.f, btVector3(0, 0, 0), true, false));
    btMultiBody* mb = bw.multiBodies.back().get();
    mb->finalizeMultiDof();
    mb->setBasePos(rampPose.getOrigin());
    mb->setWorldToBaseRot(rampPose.getRotation().inverse());  // Bullet stores world-to-base
    bw.multiWorld->addMultiBody(mb);
    bw.colliders.emplace_back(new btMultiBodyLinkCollider(mb, -1));
    btMultiBodyLinkCollider* c = bw.colliders.back().get();
    c->setCollisionShape(box);
    c->setWorldTransform(rampPose);
    c->setFriction(mu);
    bw.world->addCollisionObject(c, btBroadphaseProxy::StaticFilter, btBroadphaseProxy::AllFilter);
    mb->setBaseCollider(c);
    coupler.addMultiBody(mb);
  } else {
    btRigidBody* ramp = bw.addBody(new btBoxShape(btVector3(half[0], half[1], half[2])), 0.f, rampPose);
    bullet::CouplingOptions opts;
    if (from == FrictionFrom::Options)
      opts.contact.friction = mu;
    else
      ramp->setFriction(mu);
    coupler.addRigidBody(ramp, opts);
  }
  const std::vector<ParticleObjectId> ids = incline.addTissue(scene, softTissue());

  // settle 50 ms, then follow v_s(t) over 200 ms, frame by frame
  const float frame = 1.f / 60;
  for (int f = 0; f < 3; ++f) bw.world->stepSimulation(frame, 10, 1.f / 240);
  InclineResult r;
  BodySum b = sumOf(scene, ids);
  r.t1 = scene.time();
  const double v1 = incline.slopeSpeed(b), start = incline.along(b.com);
  test::LineFit fit;
  fit.add(r.t1, v1);
  double v2 = v1;
  r.maxSpeed = std::fabs(v1);
  for (int f = 0; f < 12; ++f) {
    bw.world->stepSimulation(frame, 10, 1.f / 240);
    b = sumOf(scene, ids);
    v2 = incline.slopeSpeed(b);
    fit.add(scene.time(), v2);
    r.maxSpeed = std::fmax(r.maxSpeed, std::fabs(v2));
    r.travel = incline.along(b.com) - start;
  }
  r.t2 = scene.time();
  r.acceleration = (v2 - v1) / (r.t2 - r.t1);
  r.fitted = fit.slope();
  return r;
}

// tan 25 deg = 0.466 > mu = 0.25: a = 9.81 (0.4226 - 0.25 * 0.9063) = 1.923 m/s^2
TEST_P(BulletPhysics, TissueSlidesDownTiltedBulletBoxWithCoulombAcceleration) {
  const double theta = 25.0 * kPi / 180.0;
  const float mu = 0.25f;
  const InclineResult r = runIncline(world(), solver(), theta, mu);
  const double expected = kG * (std::sin(theta) - mu * std::cos(theta));
  std::printf("%s: incline 25 deg, mu %.2f: a = %.4f m/s^2 from v_s at t = %.3f and %.3f s "
              "(least squares %.4f), closed form %.4f\n",
              name().c_str(), mu, r.acceleration, r.t1, r.t2, r.fitted, expected);
  EXPECT_NEAR(r.acceleration, expected, 0.05 * expected);
  EXPECT_NEAR(r.fitted, expected, 0.05 * expected);
}

// tan 25 deg = 0.466 < mu = 0.7: at rest. Sliding at even a tenth of the closed-form
// acceleration above would reach 0.04 m/s within the window.
TEST_P(BulletPhysics, TissueHoldsOnTiltedBulletBoxBelowTheFrictionAngle) {
  const double theta = 25.0 * kPi / 180.0;
  const InclineResult r = runIncline(world(), solver(), theta, 0.7f);
  std::printf("%s: incline 25 deg, mu 0.70: max |v_s| = %.5f m/s, travel %.2e m over %.3f-%.3f s\n",
              name().c_str(), r.maxSpeed, r.travel, r.t1, r.t2);
  EXPECT_LT(r.maxSpeed, 0.01);
  EXPECT_LT(std::fabs(r.travel), 1e-3);
}

// The ramp's own Bullet friction, no override: tan 25 deg = 0.466 lies between mu = 0.2,
// which slides with a = 9.81 (0.4226 - 0.2 * 0.9063) = 2.368 m/s^2 (same 5 % bound as
// above), and mu = 0.8, which holds (same bounds as above). Rigid-body ramps in both world
// types and a fixed-base multibody whose base collider is the ramp; MLS-MPM on the CPU.
TEST(BulletFriction, BodysOwnFrictionDecidesSlideOrHold) {
  const double theta = 25.0 * kPi / 180.0;
  struct Case {
    WorldType world;
    FrictionFrom from;
    const char* name;
  };
  for (const Case& c : {Case{WorldType::Discrete, FrictionFrom::Body, "Discrete rigid body"},
                        Case{WorldType::MultiBody, FrictionFrom::Body, "MultiBody rigid body"},
                        Case{WorldType::MultiBody, FrictionFrom::MultiBodyCollider, "MultiBody base collider"}}) {
    const float slip = 0.2f, grip = 0.8f;
    const InclineResult slide = runIncline(c.world, SolverType::MlsMpm, theta, slip, c.from);
    const double expected = kG * (std::sin(theta) - slip * std::cos(theta));
    std::printf("%s friction %.1f: a = %.4f m/s^2 (least squares %.4f), closed form %.4f\n", c.name, slip,
                slide.acceleration, slide.fitted, expected);
    EXPECT_NEAR(slide.acceleration, expected, 0.05 * expected) << c.name;
    EXPECT_NEAR(slide.fitted, expected, 0.05 * expected) << c.name;
    const InclineResult hold = runIncline(c.world, SolverType::MlsMpm, theta, grip, c.from);
    std::printf("%s friction %.1f: max |v_s| = %.5f m/s, travel %.2e m\n", c.name, grip, hold.maxSpeed, hold.travel);
    EXPECT_LT(hold.maxSpeed, 0.01) << c.name;
    EXPECT_LT(std::fabs(hold.travel), 1e-3) << c.name;
  }
}

// The override is explicit: unset takes the body's friction, any value set (0 included)
// replaces it, and a full ContactParams given is taken as is. A friction that is not a
// coefficient is refused naming where it came from.
TEST(BulletFriction, OverrideIsExplicitAndBadFrictionIsNamed) {
  bullet::CouplingContact c;
  EXPECT_FLOAT_EQ(c.resolve(0.7f).friction, 0.7f) << "unset: the body's";
  c.friction = 0.f;
  EXPECT_FLOAT_EQ(c.resolve(0.7f).friction, 0.f) << "an explicit 0 overrides";
  ContactParams p;
  p.mode = ContactMode::Sticky;
  p.friction = 0.3f;
  p.drag = 0.5f;
  p.band = 0.01f;
  const ContactParams r = bullet::CouplingContact(p).resolve(0.7f);
  EXPECT_EQ(r.mode, ContactMode::Sticky);
  EXPECT_FLOAT_EQ(r.friction, 0.3f);
  EXPECT_FLOAT_EQ(r.drag, 0.5f);
  EXPECT_FLOAT_EQ(r.band, 0.01f);

  BulletWorld bw(WorldType::Discrete, kG);
  SceneSettings st;
  st.dx = 0.05f;
  Scene scene(st);
  bullet::Coupler coupler(bw.world.get(), scene);
  btRigidBody* body = bw.addBody(new btSphereShape(0.05f), 0.f, btTransform::getIdentity());
  body->setFriction(-1.f);
  try {
    coupler.addRigidBody(body);
    ADD_FAILURE() << "a negative body friction was accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("getFriction()"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("-1"), std::string::npos) << e.what();
  }
  bullet::CouplingOptions opts;
  opts.contact.friction = std::nanf("");
  try {
    coupler.addRigidBody(body, opts);
    ADD_FAILURE() << "a NaN friction was accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("CouplingOptions.contact.friction"), std::string::npos) << e.what();
  }
  opts.contact.friction = 0.4f;  // the override makes the body's own value irrelevant
  EXPECT_NO_THROW(coupler.addRigidBody(body, opts));
}

// ---------------------------------------------------------------------------------------
// 2. Zero gravity, no walls: a dynamic Bullet sphere (0.2 kg, 2 m/s, 1 cm off the block's
// axis) hits a free 6 cm block of tissue (0.216 kg). Nothing else acts, so the total
// momentum m v (Bullet) + sum m_p v_p (particles) is constant through the collision. The
// momentum the grid gives the sphere reaches Bullet as an impulse each tick, so the drift
// is float rounding only; 1% of |p0| is the stated bound.

TEST_P(BulletPhysics, SphereHittingFreeTissueConservesTotalMomentum) {
  BulletWorld bw(world(), 0.f);
  SceneSettings st;
  st.solver = solver();
  st.domain.lower = {-0.3f, -0.3f, -0.3f};
  st.domain.upper = {0.3f, 0.3f, 0.3f};
  st.domain.walls = false;
  st.dx = 0.01f;
  st.gravity = {0.f, 0.f, 0.f};
  Scene scene(st);
  ParticleObjectDesc d;
  d.halfExtents = {0.03f, 0.03f, 0.03f};
  d.material = softTissue();
  const ParticleObjectId block = scene.addParticleObject(d);

  const float radius = 0.02f, mass = 0.2f, speed = 2.f;
  btRigidBody* sphere = bw.addBody(new btSphereShape(radius), mass,
                                   btTransform(btQuaternion::getIdentity(), btVector3(-0.03f - radius - 0.01f, 0.01f, 0)));
  sphere->setLinearVelocity(btVector3(speed, 0, 0));
  bullet::Coupler coupler(bw.world.get(), scene);
  bullet::CouplingOptions opts;
  opts.contact.friction = 0.3f;
  coupler.addRigidBody(sphere, opts);

  auto total = [&](double p[3]) {
    const ObjectSummary s = scene.summary(block);
    const btVector3 v = sphere->getLinearVelocity();
    for (int a = 0; a < 3; ++a) p[a] = mass * v[a] + s.momentum[a];
  };
  double p0[3];
  total(p0);
  const double p0Norm = std::sqrt(p0[0] * p0[0] + p0[1] * p0[1] + p0[2] * p0[2]);
  double drift = 0;
  int ticks = 0;
  coupler.setUserTickCallback([&](float) {
    double p[3];
    total(p);
    drift = std::fmax(drift, std::sqrt((p[0] - p0[0]) * (p[0] - p0[0]) + (p[1] - p0[1]) * (p[1] - p0[1]) +
                                       (p[2] - p0[2]) * (p[2] - p0[2])));
    ++ticks;
  });
  for (int f = 0; f < 5; ++f) bw.world->stepSimulation(1.f / 60, 10, 1.f / 240);  // 83 ms

  const ObjectSummary s = scene.summary(block);
  const double sphereP = mass * sphere->getLinearVelocity().x();
  std::printf("%s: sphere on free tissue over %d ticks: p0 = (%.5f, %.5f, %.5f) kg m/s; sphere p_x %.5f, "
              "tissue p = (%.5f, %.5f, %.5f); largest |p - p0| = %.2e (%.4f%% of |p0|)\n",
              name().c_str(), ticks, p0[0], p0[1], p0[2], sphereP, s.momentum[0], s.momentum[1],
              s.momentum[2], drift, 100 * drift / p0Norm);
  EXPECT_LT(drift, 0.01 * p0Norm) << "total momentum drift";
  EXPECT_GT(s.momentum[0], 0.5 * p0[0]) << "the sphere hit and handed on most of its momentum";
  EXPECT_LT(sphereP, 0.5 * p0[0]);
}

INSTANTIATE_TEST_SUITE_P(WorldTypesAndSolvers, BulletPhysics,
                         test::worldTypesAndSolvers(),
                         test::pairParamName(test::worldTypeName));

// ---------------------------------------------------------------------------------------
// 3. Featherstone links (btMultiBodyDynamicsWorld only): a floating-base chain of three
// boxes joined by revolute joints about z, each box a btMultiBodyLinkCollider coupled
// through Coupler::addMultiBody.

/// Rotation angle [rad] of a quaternion (from its vector part: exact for small angles).
double angleOf(const btQuaternion& q) {
  const double v = std::sqrt((double)q.x() * q.x() + (double)q.y() * q.y() + (double)q.z() * q.z());
  return 2 * std::atan2(v, std::fabs((double)q.w()));
}

// (a) In zero gravity, away from any tissue, the chain spins and flexes. Each link's shape
// moves through the tick with the velocity the coupler gave it, so after the tick the
// shape's pose must match the link collider's pose Bullet integrated, to O(a dt^2): a link
// velocity in the wrong frame or of the wrong link would be off by O(v dt).
TEST(BulletMultiBodyLinks, ShapesFollowLinkVelocities) {
  BulletWorld bw(WorldType::MultiBody, 0.f);
  SceneSettings st;
  st.domain.lower = {-0.5f, -0.5f, -0.5f};
  st.domain.upper = {0.5f, 0.5f, 0.5f};
  st.dx = 0.02f;
  st.gravity = {0.f, 0.f, 0.f};
  Scene scene(st);
  ParticleObjectDesc speck;  // a little tissue far from the chain
  speck.center = {0.f, -0.4f, 0.f};
  speck.halfExtents = {0.02f, 0.02f, 0.02f};
  speck.material = softTissue();
  scene.addParticleObject(speck);

  btMultiBody* chain = bw.addBoxChain(3, btVector3(0.035f, 0.015f, 0.05f), 0.01f, 0.5f, btVector3(-0.08f, 0.1f, 0));
  chain->setLinearDamping(0.f);
  chain->setAngularDamping(0.f);
  chain->setBaseVel(btVector3(0.2f, 0.1f, -0.1f));
  chain->setBaseOmega(btVector3(0.5f, 3.f, 1.f));
  chain->setJointVel(0, 2.f);
  chain->setJointVel(1, -3.f);
  bullet::Coupler coupler(bw.world.get(), scene);
  const std::vector<btCollisionObject*> links = bw.chainColliders(chain);
  const std::vector<ShapeId> ids = coupler.addMultiBody(chain);
  ASSERT_EQ(ids.size(), links.size());

  std::vector<btTransform> before;
  for (const btCollisionObject* c : links) before.push_back(c->getWorldTransform());
  double worstMove = 0, worstTurn = 0;  // largest error / motion over a tick
  int ticks = 0;
  coupler.setUserTickCallback([&](float) {
    for (size_t i = 0; i < links.size(); ++i) {
      const btTransform& now = links[i]->getWorldTransform();
      const ShapeState s = scene.shapeState(ids[i]);
      const btVector3 shapePos(s.pose.position.x, s.pose.position.y, s.pose.position.z);
      const btQuaternion shapeRot(s.pose.rotation.x, s.pose.rotation.y, s.pose.rotation.z, s.pose.rotation.w);
      const double move = (now.getOrigin() - before[i].getOrigin()).length();
      const double turn = angleOf(before[i].getRotation().inverse() * now.getRotation());
      worstMove = std::fmax(worstMove, (shapePos - now.getOrigin()).length() / move);
      worstTurn = std::fmax(worstTurn, angleOf(shapeRot.inverse() * now.getRotation()) / turn);
      before[i] = now;
    }
    ++ticks;
  });
  for (int f = 0; f < 4; ++f) bw.world->stepSimulation(1.f / 60, 10, 1.f / 240);
  std::printf("chain in zero gravity over %d ticks: shape pose vs link pose after a tick, largest position error "
              "%.2f%% of the link's motion, rotation error %.2f%% of its turn\n",
              ticks, 100 * worstMove, 100 * worstTurn);
  ASSERT_GT(ticks, 0);
  EXPECT_LT(worstMove, 0.05);
  EXPECT_LT(worstTurn, 0.05);
}

// (b) The chain (three 0.5 kg boxes) dropped from 5 mm onto a soft slab lying on Bullet's
// ground, run for `seconds`.

struct ChainOnTissue {
  double force = 0;              ///< coupling force on all colliders, averaged from 0.4 s [N]
  double averagedOver = 0;       ///< [s]
  double weight = 0;             ///< [N]
  double sinkSpeed = 0;          ///< downward speed of the base, mean from 0.4 s to the end [m/s]
  double baseSpeed = 0;          ///< at the end [m/s]
  double jointRate[2] = {0, 0};  ///< at the end [rad/s]
  float bottom[3], surface[3];   ///< lowest corner of each box; highest particle under it [m]
  float top = 0;                 ///< tissue top at the start [m]
};

ChainOnTissue runChainOnTissue(SolverType solver, double seconds) {
  BulletWorld bw(WorldType::MultiBody, kG);
  SceneSettings st;
  st.solver = solver;
  st.domain.lower = {-0.24f, -0.1f, -0.14f};
  st.domain.upper = {0.24f, 0.3f, 0.14f};
  st.dx = 0.02f;
  st.gravity = {0.f, -kG, 0.f};
  Scene scene(st);
  ParticleObjectDesc slab;
  slab.center = {0.f, 0.03f + 0.002f, 0.f};
  slab.halfExtents = {0.15f, 0.03f, 0.08f};
  slab.material = softTissue();
  const ParticleObjectId tissue = scene.addParticleObject(slab);
  ChainOnTissue r;
  r.top = slab.center.y + slab.halfExtents.y;

  btRigidBody* ground = bw.addGround();
  const btVector3 half(0.035f, 0.015f, 0.05f);
  const float massEach = 0.5f;
  btMultiBody* chain = bw.addBoxChain(3, half, 0.01f, massEach, btVector3(-0.08f, r.top + half.y() + 0.005f, 0));
  bullet::Coupler coupler(bw.world.get(), scene);
  bullet::CouplingOptions opts;
  opts.contact.friction = 0.5f;
  coupler.addRigidBody(ground);
  const std::vector<btCollisionObject*> links = bw.chainColliders(chain);
  const std::vector<ShapeId> ids = coupler.addMultiBody(chain, opts);
  EXPECT_EQ(ids.size(), 3u);

  double impulse = 0, baseAt04 = 0;
  coupler.setUserTickCallback([&](float dt) {
    if (scene.time() > 0.4) {
      if (r.averagedOver == 0) baseAt04 = chain->getBasePos().y();
      for (const ShapeId id : ids) impulse += scene.shapeImpulse(id).linear.y;
      r.averagedOver += dt;
    }
  });
  const int frames = (int)std::lround(seconds * 60);
  for (int f = 0; f < frames; ++f) bw.world->stepSimulation(1.f / 60, 10, 1.f / 240);

  r.weight = 3 * massEach * kG;
  r.force = impulse / r.averagedOver;
  r.sinkSpeed = (baseAt04 - chain->getBasePos().y()) / r.averagedOver;
  r.baseSpeed = chain->getBaseVel().length();
  for (int i = 0; i < 2; ++i) r.jointRate[i] = chain->getJointVel(i);
  std::vector<Vec3f> x;
  scene.readPositions(tissue, x);
  for (size_t i = 0; i < links.size(); ++i) {
    const btVector3 c = links[i]->getWorldTransform().getOrigin();
    r.surface[i] = -1.f;
    for (const Vec3f& p : x)
      if (std::fabs(p.x - (float)c.x()) < half.x() && std::fabs(p.z - (float)c.z()) < half.z())
        r.surface[i] = std::fmax(r.surface[i], p.y);
    btVector3 lo, hi;
    links[i]->getCollisionShape()->getAabb(links[i]->getWorldTransform(), lo, hi);
    r.bottom[i] = (float)lo.y();
  }
  std::printf("%s: chain on tissue, %.1f s: time-averaged coupling force %.4f N over %.3f s, weight %.4f N (%+.2f%%); "
              "base sinking at %.2f mm/s; base speed %.4f m/s, joint rates %.4f, %.4f rad/s\n",
              test::solverName(solver).c_str(), seconds, r.force, r.averagedOver, r.weight, 100 * (r.force - r.weight) / r.weight, 1e3 * r.sinkSpeed,
              r.baseSpeed, r.jointRate[0], r.jointRate[1]);
  for (int i = 0; i < 3; ++i)
    std::printf("  box %d: bottom %.4f m, highest particle under it %.4f m, tissue top at start %.4f m\n", i,
                r.bottom[i], r.surface[i], r.top);
  return r;
}

// Over 0.8 s it comes to rest on the tissue, its boxes no more than half a cell into it
// (measured from the highest particle under each box and from the tissue's top), and
// averaged over 0.4-0.8 s the coupling forces on its colliders carry its weight within 3%.
class BulletMultiBodyChain : public ::testing::TestWithParam<SolverType> {};

TEST_P(BulletMultiBodyChain, ChainRestsOnTissueWithItsWeight) {
  const ChainOnTissue r = runChainOnTissue(GetParam(), 0.8);
  const float dx = 0.02f;
  ASSERT_GT(r.averagedOver, 0.3);
  EXPECT_NEAR(r.force, r.weight, 0.03 * r.weight) << "time-averaged coupling force [N]";
  for (int i = 0; i < 3; ++i) {
    EXPECT_GT(r.bottom[i] - r.surface[i], -0.5f * dx) << "box " << i << " sank more than half a cell into the tissue";
    EXPECT_LT(r.bottom[i] - r.surface[i], 0.5f * dx) << "box " << i << " rests on the tissue, not on a cushion of grid";
    EXPECT_GT(r.bottom[i], r.top - 0.5f * dx) << "box " << i << " below the tissue's top minus half a cell";
  }
  EXPECT_LT(r.baseSpeed, 0.05) << "the chain has come to rest";
  for (int i = 0; i < 2; ++i) EXPECT_LT(std::fabs(r.jointRate[i]), 0.5) << "joint " << i;
}

// A resting body must not creep into the tissue. With a dynamic shape's gravity added
// after the contact response (the first version of contact/rigid_body.h), a resting body
// stepped g h^2 into the tissue every substep h and sank at about g h (3.4 mm/s here,
// h = 0.35 ms); with gravity before the contact it stays (measured under 0.05 mm over 1.6 s).
TEST_P(BulletMultiBodyChain, RestingChainDoesNotSinkIntoTissue) {
  const ChainOnTissue r = runChainOnTissue(GetParam(), 2.0);
  EXPECT_LT(std::fabs(r.sinkSpeed), 0.5e-3) << "a resting chain must not keep moving into the tissue [m/s]";
  for (int i = 0; i < 3; ++i)
    EXPECT_GT(r.bottom[i] - r.surface[i], -0.25f * 0.02f) << "box " << i << " went into the tissue";
}

INSTANTIATE_TEST_SUITE_P(AllSolvers, BulletMultiBodyChain, test::allSolvers(), test::solverParamName());

// ---------------------------------------------------------------------------------------
// 4. Shape conversion with local scaling and compounds. Bullet's own answer for a convex
// part is its support function: for a convex set, the signed distance of p is
// max over unit n of (n . p - h(n)), h(n) = n . localGetSupportingVertex(n), outside and
// inside alike. Each converted part's signed distance (its primitive SDF at its local
// pose) must equal that of the Bullet child it came from.

/// Signed distance of p to a convex Bullet shape, from its support function: a dense
/// direction set, then a local ascent on the sphere.
double supportDistance(const btConvexShape& shape, const btVector3& p) {
  auto value = [&](const btVector3& n) { return (double)(n.dot(p) - n.dot(shape.localGetSupportingVertex(n))); };
  const int count = 2000;
  btVector3 best(0, 1, 0);
  double bestValue = -1e30;
  for (int i = 0; i < count; ++i) {  // Fibonacci sphere plus the six axes
    btVector3 n;
    if (i < 6) {
      n = btVector3(0, 0, 0);
      n[i / 2] = (i % 2) ? -1 : 1;
    } else {
      const double z = 1 - 2 * (i + 0.5) / count, r = std::sqrt(1 - z * z), phi = i * kPi * (3 - std::sqrt(5.0));
      n = btVector3((btScalar)(r * std::cos(phi)), (btScalar)(r * std::sin(phi)), (btScalar)z);
    }
    const double v = value(n);
    if (v > bestValue) bestValue = v, best = n;
  }
  for (double step = 0.05; step > 1e-5;) {
    btVector3 u = best.cross(std::fabs(best.x()) < 0.9 ? btVector3(1, 0, 0) : btVector3(0, 1, 0)).normalized();
    const btVector3 w = best.cross(u);
    bool improved = false;
    for (const btVector3& t : {u, -u, w, -w}) {
      const btVector3 n = (best + (btScalar)step * t).normalized();
      const double v = value(n);
      if (v > bestValue) bestValue = v, best = n, improved = true;
    }
    if (!improved) step *= 0.5;
  }
  return bestValue;
}

btTransform toBt(const Pose& p) {
  return btTransform(btQuaternion(p.rotation.x, p.rotation.y, p.rotation.z, p.rotation.w),
                     btVector3(p.position.x, p.position.y, p.position.z));
}

/// Signed distance of a converted part at p (the shape's frame).
float partDistance(const Geometry& g, const btVector3& p) {
  const btVector3 q = toBt(g.localPose).inverse() * p;
  const Vec3f l{(float)q.x(), (float)q.y(), (float)q.z()};
  Vec3f n;
  switch (g.type) {
    case GeometryType::Box: return sdfBox(l, g.halfExtents, n);
    case GeometryType::Capsule: return sdfCapsule(l, g.radius, g.halfHeight, g.axis, n);
    case GeometryType::Sphere: return sdfSphere(l, g.radius, n);
    case GeometryType::Cylinder: return sdfCylinder(l, g.radius, g.halfHeight, g.axis, n);
    default: ADD_FAILURE() << "unexpected part type"; return 0.f;
  }
}

/// Compares part `g` with the convex Bullet shape `child` placed at `childPose` in the
/// shape's frame, at random points of the child's own bounding box grown 1.5 times.
void expectPartMatches(const Geometry& g, const btConvexShape& child, const btTransform& childPose,
                       const std::string& what, unsigned seed) {
  btVector3 lo, hi;
  child.getAabb(btTransform::getIdentity(), lo, hi);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.5f, 1.5f);
  double worst = 0;
  int inside = 0;
  for (int k = 0; k < 300; ++k) {
    const btVector3 local = 0.5f * (lo + hi) + 0.5f * (hi - lo) * btVector3(u(rng), u(rng), u(rng));
    const btVector3 p = childPose * local;
    const double bullet = supportDistance(child, childPose.inverse() * p);
    const double ours = partDistance(g, p);
    worst = std::fmax(worst, std::fabs(ours - bullet));
    inside += bullet < 0;
    EXPECT_NEAR(ours, bullet, 1e-5) << what << " at (" << p.x() << ", " << p.y() << ", " << p.z() << ")";
  }
  std::printf("%s: largest |sdf - Bullet support distance| %.2e m over 300 points (%d inside)\n", what.c_str(), worst,
              inside);
  EXPECT_GT(inside, 30) << what << ": too few sample points inside";
}

void expectPoseNear(const Pose& p, const btTransform& t, const std::string& what) {
  const btVector3 o = t.getOrigin();
  EXPECT_NEAR(p.position.x, o.x(), 1e-6f) << what;
  EXPECT_NEAR(p.position.y, o.y(), 1e-6f) << what;
  EXPECT_NEAR(p.position.z, o.z(), 1e-6f) << what;
  const btQuaternion q(p.rotation.x, p.rotation.y, p.rotation.z, p.rotation.w);
  EXPECT_LT(angleOf(q.inverse() * t.getRotation()), 1e-5) << what << ": rotation";
}

// A compound of two boxes and a capsule, each child rotated and offset, scaled by
// (1.5, 0.8, 2) through btCompoundShape::setLocalScaling (Bullet scales each child in its
// own frame and the child offsets in the compound's frame).
TEST(BulletShapeConversion, ScaledCompoundOfBoxesAndCapsule) {
  btCompoundShape compound;
  btBoxShape boxA(btVector3(0.05f, 0.02f, 0.03f)), boxB(btVector3(0.02f, 0.06f, 0.02f));
  btCapsuleShape capsule(0.015f, 0.06f);  // along y: radius 1.5 cm, half height 3 cm
  const btTransform poseA(btQuaternion(btVector3(0, 1, 0), 0.5f), btVector3(0.04f, 0, 0));
  const btTransform poseB(btQuaternion(btVector3(1, 0, 0), 0.35f), btVector3(-0.03f, 0.02f, 0.01f));
  const btTransform poseC(btQuaternion(btVector3(0, 0, 1), 1.2f), btVector3(0.01f, -0.03f, -0.02f));
  compound.addChildShape(poseA, &boxA);
  compound.addChildShape(poseB, &boxB);
  compound.addChildShape(poseC, &capsule);
  const btVector3 scaling(1.5f, 0.8f, 2.f);
  compound.setLocalScaling(scaling);

  const std::vector<Geometry> parts = bullet::convertShape(&compound, 0.005f);
  ASSERT_EQ(parts.size(), 3u);
  EXPECT_EQ(parts[0].type, GeometryType::Box);
  EXPECT_EQ(parts[1].type, GeometryType::Box);
  EXPECT_EQ(parts[2].type, GeometryType::Capsule);
  // closed forms: child sizes times the scaling, child offsets times the scaling
  const btVector3 a = btVector3(0.05f, 0.02f, 0.03f) * scaling, b = btVector3(0.02f, 0.06f, 0.02f) * scaling;
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(parts[0].halfExtents[k], a[k], 1e-6f) << "box A half extent " << k;
    EXPECT_NEAR(parts[1].halfExtents[k], b[k], 1e-6f) << "box B half extent " << k;
  }
  EXPECT_EQ(parts[2].axis, 1);
  EXPECT_NEAR(parts[2].radius, 0.015f * scaling.x(), 1e-6f) << "Bullet scales a y capsule's radius by x";
  EXPECT_NEAR(parts[2].halfHeight, 0.03f * scaling.y(), 1e-6f);
  const btTransform poses[3] = {poseA, poseB, poseC};
  for (int i = 0; i < 3; ++i) {
    btTransform scaled = poses[i];
    scaled.setOrigin(poses[i].getOrigin() * scaling);
    expectPoseNear(parts[i].localPose, scaled, "part " + std::to_string(i) + " local pose");
    expectPoseNear(parts[i].localPose, compound.getChildTransform(i), "part " + std::to_string(i) + " vs Bullet child");
  }
  // Bullet's answer, child by child
  for (int i = 0; i < 3; ++i)
    expectPartMatches(parts[i], *static_cast<const btConvexShape*>(compound.getChildShape(i)),
                      compound.getChildTransform(i), "compound part " + std::to_string(i), 100 + i);
  // the union: inside a part exactly where Bullet's box test or capsule support says inside
  std::mt19937 rng(7);
  btVector3 lo, hi;
  compound.getAabb(btTransform::getIdentity(), lo, hi);
  std::uniform_real_distribution<float> ux(lo.x() - 0.01f, hi.x() + 0.01f), uy(lo.y() - 0.01f, hi.y() + 0.01f),
      uz(lo.z() - 0.01f, hi.z() + 0.01f);
  int agree = 0, tested = 0;
  for (int k = 0; k < 2000; ++k) {
    const btVector3 p(ux(rng), uy(rng), uz(rng));
    float ours = 1e30f;
    for (const Geometry& g : parts) ours = std::fmin(ours, partDistance(g, p));
    if (std::fabs(ours) < 1e-4f) continue;  // on a surface: either answer
    bool inBullet = false;
    for (int i = 0; i < 2; ++i) {
      const btBoxShape* box = static_cast<const btBoxShape*>(compound.getChildShape(i));
      inBullet |= box->isInside(compound.getChildTransform(i).inverse() * p, box->getMargin());
    }
    inBullet |= supportDistance(capsule, compound.getChildTransform(2).inverse() * p) < 0;
    ++tested;
    agree += inBullet == (ours < 0.f);
  }
  std::printf("compound union: %d of %d points on the same side as Bullet's isInside / support test\n", agree, tested);
  EXPECT_EQ(agree, tested);
}

// Capsules scaled on their own: along x, scaled (1.5, 2, 2), and along y, scaled (2, 0.5, 2).
// Bullet scales the half height by the up axis' factor and the radius by that of axis
// (up + 2) mod 3.
TEST(BulletShapeConversion, ScaledCapsules) {
  btCapsuleShapeX alongX(0.02f, 0.08f);
  alongX.setLocalScaling(btVector3(1.5f, 2.f, 2.f));
  btCapsuleShape alongY(0.02f, 0.08f);
  alongY.setLocalScaling(btVector3(2.f, 0.5f, 2.f));
  struct Case {
    const btCapsuleShape* shape;
    int axis;
    float radius, halfHeight;
    const char* name;
  };
  for (const Case& c : {Case{&alongX, 0, 0.04f, 0.06f, "capsule x scaled (1.5, 2, 2)"},
                        Case{&alongY, 1, 0.04f, 0.02f, "capsule y scaled (2, 0.5, 2)"}}) {
    const std::vector<Geometry> parts = bullet::convertShape(c.shape, 0.005f);
    ASSERT_EQ(parts.size(), 1u) << c.name;
    const Geometry& g = parts[0];
    EXPECT_EQ(g.type, GeometryType::Capsule) << c.name;
    EXPECT_EQ(g.axis, c.axis) << c.name;
    EXPECT_NEAR(g.radius, c.radius, 1e-6f) << c.name;
    EXPECT_NEAR(g.halfHeight, c.halfHeight, 1e-6f) << c.name;
    expectPoseNear(g.localPose, btTransform::getIdentity(), c.name);
    expectPartMatches(g, *c.shape, btTransform::getIdentity(), c.name, 200 + c.axis);
  }
}

// A capsule whose cylinder part has zero height is legal in Bullet and is a sphere: it
// converts to one, exactly (Bullet's support distance at 300 points, 1e-5 m), on each axis
// and when the height is scaled to zero.
TEST(BulletShapeConversion, ZeroHeightCapsuleIsASphere) {
  btCapsuleShape alongY(0.03f, 0.f);
  btCapsuleShapeX alongX(0.03f, 0.f);
  btCapsuleShapeZ alongZ(0.03f, 0.f);
  btCapsuleShape flattened(0.03f, 0.1f);  // half height 5 cm scaled to 0 along y
  flattened.setLocalScaling(btVector3(1.f, 0.f, 1.f));
  struct Case {
    const btCapsuleShape* shape;
    const char* name;
  };
  for (const Case& c : {Case{&alongY, "capsule y, height 0"}, Case{&alongX, "capsule x, height 0"},
                        Case{&alongZ, "capsule z, height 0"}, Case{&flattened, "capsule y scaled (1, 0, 1)"}}) {
    ASSERT_EQ(c.shape->getHalfHeight(), 0.f) << c.name;
    const std::vector<Geometry> parts = bullet::convertShape(c.shape, 0.005f);
    ASSERT_EQ(parts.size(), 1u) << c.name;
    EXPECT_EQ(parts[0].type, GeometryType::Sphere) << c.name;
    EXPECT_NEAR(parts[0].radius, 0.03f, 1e-6f) << c.name;
    expectPartMatches(parts[0], *c.shape, btTransform::getIdentity(), c.name, 300);
  }
}

// ... and it couples: a 0.5 kg zero-height capsule dropped 5 mm onto a soft slab (MLS-MPM,
// CPU) rests there, held up by its weight (time-averaged over the last 0.4 s of 0.8 s,
// within 2 %, the bound of the resting-box tests).
TEST(BulletShapeConversion, ZeroHeightCapsuleRestsOnTissue) {
  BulletWorld bw(WorldType::Discrete, kG);
  btRigidBody* ground = bw.addGround();
  SceneSettings st;
  st.domain.lower = {-0.14f, -0.1f, -0.14f};
  st.domain.upper = {0.14f, 0.3f, 0.14f};
  st.dx = 0.02f;
  st.gravity = {0.f, -kG, 0.f};
  Scene scene(st);
  ParticleObjectDesc slab;
  slab.center = {0.f, 0.052f, 0.f};
  slab.halfExtents = {0.08f, 0.05f, 0.08f};
  slab.material = softTissue();
  scene.addParticleObject(slab);
  const float r = 0.03f, mass = 0.5f;
  btRigidBody* ball = bw.addBody(new btCapsuleShape(r, 0.f), mass,
                                 btTransform(btQuaternion::getIdentity(), btVector3(0, 0.102f + r + 0.005f, 0)));
  bullet::Coupler coupler(bw.world.get(), scene);
  coupler.addRigidBody(ground);
  const ShapeId id = coupler.addRigidBody(ball);
  double impulse = 0, time = 0;
  coupler.setUserTickCallback([&](float dt) {
    if (scene.time() > 0.4) impulse += scene.shapeImpulse(id).linear.y, time += dt;
  });
  for (int f = 0; f < 48; ++f) bw.world->stepSimulation(1.f / 60, 10, 1.f / 240);
  ASSERT_GT(time, 0.3);
  std::printf("zero-height capsule on tissue: time-averaged force %.4f N, weight %.4f N; rests at y = %.4f m, speed "
              "%.4f m/s\n",
              impulse / time, mass * kG, ball->getCenterOfMassPosition().y(), ball->getLinearVelocity().length());
  EXPECT_NEAR(impulse / time, mass * kG, 0.02 * mass * kG);
  EXPECT_LT(ball->getLinearVelocity().length(), 0.05f) << "at rest";
  EXPECT_GT(ball->getCenterOfMassPosition().y(), 0.102f + r - 0.5f * st.dx) << "sinks less than half a cell";
}

// Bullet shapes of zero size have no inside for the tissue to touch: each is refused by the
// conversion with a message naming the Bullet shape and what is zero (before, they reached
// the scene and were refused there as "ShapeDesc.parts[0]...", or converted to nothing).
TEST(BulletShapeConversion, ZeroSizeShapesAreRefusedNamingWhat) {
  btBoxShape flatBox(btVector3(0.05f, 0.f, 0.05f));
  btBoxShape squashedBox(btVector3(0.05f, 0.05f, 0.05f));
  squashedBox.setLocalScaling(btVector3(1.f, 0.f, 1.f));
  btSphereShape point(0.f);
  btCapsuleShape segment(0.f, 0.1f);
  btCylinderShape disc(btVector3(0.05f, 0.f, 0.05f));
  btCylinderShape needle(btVector3(0.f, 0.05f, 0.f));
  btConeShape flatCone(0.05f, 0.f);
  flatCone.setMargin(0.f);  // with its default margin Bullet's flat cone is a rounded disc
  const btVector3 centre(0, 0, 0);
  const btScalar zero = 0.f;
  btMultiSphereShape pointSpheres(&centre, &zero, 1);
  btConvexHullShape flatHull;  // four points in the plane x + y + z = 0
  for (const btVector3& v : {btVector3(0.05f, -0.05f, 0), btVector3(-0.05f, 0.05f, 0), btVector3(0, 0.05f, -0.05f),
                             btVector3(0, -0.05f, 0.05f)})
    flatHull.addPoint(v);
  flatHull.setMargin(0.f);
  btCompoundShape compound;
  btBoxShape solid(btVector3(0.05f, 0.05f, 0.05f));
  compound.addChildShape(btTransform::getIdentity(), &solid);
  compound.addChildShape(btTransform::getIdentity(), &flatBox);
  struct Case {
    const btCollisionShape* shape;
    std::vector<const char*> words;  ///< the message must contain each
  };
  const std::vector<Case> cases = {
      {&flatBox, {"btBoxShape", "half extents", "y"}},
      {&squashedBox, {"btBoxShape", "half extents", "y"}},
      {&point, {"btSphereShape", "radius"}},
      {&segment, {"btCapsuleShape", "radius"}},
      {&disc, {"btCylinderShape", "half height"}},
      {&needle, {"btCylinderShape", "radius"}},
      {&flatCone, {"btConeShape"}},
      {&pointSpheres, {"btMultiSphereShape"}},
      {&flatHull, {"btConvexHullShape"}},
      {&compound, {"btCompoundShape child 1", "btBoxShape", "half extents"}},
  };
  for (const Case& c : cases) {
    try {
      bullet::convertShape(c.shape, 0.005f);
      ADD_FAILURE() << c.words[0] << ": converted";
    } catch (const InvalidArgument& e) {
      std::printf("%s\n", e.what());
      for (const char* w : c.words) EXPECT_NE(std::string(e.what()).find(w), std::string::npos) << e.what();
    }
  }
}

/// Signed distance to the solid cone with apex at (0, h/2, 0) and base of radius r at
/// y = -h/2, from its cross-section: the triangle (0, h/2), (r, -h/2), (0, -h/2) in the
/// (distance from the axis, y) plane; the axis side is inside the solid.
double coneDistance(double r, double h, const btVector3& p) {
  const double qx = std::sqrt((double)p.x() * p.x() + (double)p.z() * p.z()), qy = p.y();
  auto segment = [&](double ax, double ay, double bx, double by) {
    const double ex = bx - ax, ey = by - ay;
    const double t = std::clamp(((qx - ax) * ex + (qy - ay) * ey) / (ex * ex + ey * ey), 0.0, 1.0);
    return std::hypot(qx - ax - t * ex, qy - ay - t * ey);
  };
  const double d = std::min(segment(0, h / 2, r, -h / 2), segment(r, -h / 2, 0, -h / 2));
  const bool inside = qy > -h / 2 && qx * h < r * (h / 2 - qy);  // above the base, inside the slant
  return inside ? -d : d;
}

/// Signed distance to the convex hull of spheres (a, ra) and (b, rb) (Quilez's round cone).
double roundConeDistance(const btVector3& a, double ra, const btVector3& b, double rb, const btVector3& p) {
  const btVector3 ba = b - a, pa = p - a;
  const double l2 = ba.dot(ba), rr = ra - rb, a2 = l2 - rr * rr, il2 = 1.0 / l2;
  const double y = pa.dot(ba), z = y - l2;
  const btVector3 c = pa * (btScalar)l2 - ba * (btScalar)y;
  const double x2 = c.dot(c), y2 = y * y * l2, z2 = z * z * l2;
  const double k = (rr > 0 ? 1 : rr < 0 ? -1 : 0) * rr * rr * x2;
  if ((z > 0 ? 1 : -1) * a2 * z2 > k) return std::sqrt(x2 + z2) * il2 - rb;
  if ((y > 0 ? 1 : -1) * a2 * y2 < k) return std::sqrt(x2 + y2) * il2 - ra;
  return (std::sqrt(x2 * a2 * il2) + y * rr) * il2 - ra;
}

// Cones and multi-spheres have no primitive in the grid's contact: they become signed
// distance grids. Bullet collides with a cone of margin m as the solid cone grown by m
// (support vertex plus m times the direction), and with a multi-sphere as the convex hull
// of its spheres. Every sample must match those closed forms to 1e-6 m (float rounding)
// and the grid must reach inside; the cone along x checks the axis and Bullet's scaling
// (height by the axis' factor, radius by the mean of the other two). A multi-sphere of
// one sphere, or of one holding the other, is that sphere.
TEST(BulletShapeConversion, ConeAndMultiSphereMatchClosedForms) {
  btConeShape cone(0.04f, 0.1f);  // default margin 4 cm
  btConeShapeX coneX(0.03f, 0.08f);
  coneX.setMargin(0.001f);
  coneX.setLocalScaling(btVector3(0.5f, 1.2f, 0.8f));  // height 4 cm, radius 3 cm
  const btVector3 centres[2] = {btVector3(-0.03f, 0, 0), btVector3(0.04f, 0.01f, 0)};
  const btScalar radii[2] = {0.05f, 0.02f};
  btMultiSphereShape spheres(centres, radii, 2);
  auto alongX = [](const btVector3& p) { return btVector3(p.y(), p.x(), p.z()); };  // x axis onto y
  struct Case {
    const btConvexShape* shape;
    std::function<double(const btVector3&)> exact;
    const char* name;
  };
  const std::vector<Case> cases = {
      {&cone, [&](const btVector3& p) { return coneDistance(0.04, 0.1, p) - 0.04; }, "cone y, margin 4 cm"},
      {&coneX, [&](const btVector3& p) { return coneDistance(0.03, 0.04, alongX(p)) - 0.001; },
       "cone x scaled (0.5, 1.2, 0.8), margin 1 mm"},
      {&spheres, [&](const btVector3& p) { return roundConeDistance(centres[0], radii[0], centres[1], radii[1], p); },
       "multi-sphere"}};
  ASSERT_NEAR(coneX.getHeight(), 0.04f, 1e-7f);
  ASSERT_NEAR(coneX.getRadius(), 0.03f, 1e-7f);
  for (const Case& c : cases) {
    const std::vector<Geometry> parts = bullet::convertShape(c.shape, 0.005f);
    ASSERT_EQ(parts.size(), 1u) << c.name;
    ASSERT_EQ(parts[0].type, GeometryType::Mesh) << c.name;
    const SignedDistanceGrid& g = *parts[0].sdf;
    double worst = 0, nearWorst = 0;
    int inside = 0, failed = 0;
    for (int i = 0; i < g.dims[0]; ++i)
      for (int j = 0; j < g.dims[1]; ++j)
        for (int k = 0; k < g.dims[2]; ++k) {
          const btVector3 p(g.lower.x + i * g.cellSize, g.lower.y + j * g.cellSize, g.lower.z + k * g.cellSize);
          const double exact = c.exact(p);
          const float ours = g.values[((size_t)i * g.dims[1] + j) * g.dims[2] + k];
          worst = std::fmax(worst, std::fabs(ours - exact));
          if (std::fabs(exact) < 0.01) nearWorst = std::fmax(nearWorst, std::fabs(ours - exact));
          inside += ours < 0.f;
          if (std::fabs(ours - exact) > 1e-6 && failed++ < 3)
            ADD_FAILURE() << c.name << " at (" << p.x() << ", " << p.y() << ", " << p.z() << "): " << ours
                          << " m, closed form " << exact << " m";
        }
    std::printf("%s: %d x %d x %d samples, largest |sdf - closed form| %.2e m, %.2e m within 1 cm of the surface (%d "
                "inside)\n", c.name, g.dims[0], g.dims[1], g.dims[2], worst, nearWorst, inside);
    EXPECT_EQ(failed, 0) << c.name;
    EXPECT_GT(inside, 100) << c.name;
  }
  const btVector3 one(0.01f, 0.02f, 0.03f), inner[2] = {btVector3(0, 0, 0), btVector3(0.01f, 0, 0)};
  const btScalar r1 = 0.02f, rInner[2] = {0.05f, 0.02f};
  btMultiSphereShape single(&one, &r1, 1), nested(inner, rInner, 2);
  for (const btMultiSphereShape* m : {&single, &nested}) {
    const std::vector<Geometry> parts = bullet::convertShape(m, 0.005f);
    ASSERT_EQ(parts.size(), 1u);
    EXPECT_EQ(parts[0].type, GeometryType::Sphere);
    EXPECT_FLOAT_EQ(parts[0].radius, m == &single ? 0.02f : 0.05f);
    expectPoseNear(parts[0].localPose, btTransform(btQuaternion::getIdentity(), m == &single ? one : inner[0]),
                   m == &single ? "multi-sphere of one" : "nested spheres");
  }
}

// A btScaledBvhTriangleMeshShape (a shared BVH mesh with its own scaling, here (2, 1, 0.5)
// on a 4 cm cube) converts to the scaled mesh: its grid is exact at the samples (distance to
// the nearest triangle), so it must equal the closed-form box distance there (1e-6 m).
TEST(BulletShapeConversion, ScaledBvhMeshIsTheScaledMesh) {
  btTriangleMesh tris;
  const float h = 0.02f;
  const btVector3 v[8] = {{-h, -h, -h}, {h, -h, -h}, {h, h, -h}, {-h, h, -h},
                          {-h, -h, h},  {h, -h, h},  {h, h, h},  {-h, h, h}};
  const int faces[12][3] = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                            {3, 6, 2}, {3, 7, 6}, {0, 4, 7}, {0, 7, 3}, {1, 2, 6}, {1, 6, 5}};
  for (const auto& f : faces) tris.addTriangle(v[f[0]], v[f[1]], v[f[2]]);
  btBvhTriangleMeshShape cube(&tris, true);
  btScaledBvhTriangleMeshShape scaled(&cube, btVector3(2.f, 1.f, 0.5f));
  const std::vector<Geometry> parts = bullet::convertShape(&scaled, 0.005f);
  ASSERT_EQ(parts.size(), 1u);
  ASSERT_EQ(parts[0].type, GeometryType::Mesh);
  const SignedDistanceGrid& g = *parts[0].sdf;
  const Vec3f half{0.04f, 0.02f, 0.01f};
  double worst = 0;
  for (int i = 0; i < g.dims[0]; ++i)
    for (int j = 0; j < g.dims[1]; ++j)
      for (int k = 0; k < g.dims[2]; ++k) {
        const Vec3f p{g.lower.x + i * g.cellSize, g.lower.y + j * g.cellSize, g.lower.z + k * g.cellSize};
        Vec3f n;
        worst = std::fmax(worst, std::fabs(g.values[((size_t)i * g.dims[1] + j) * g.dims[2] + k] - sdfBox(p, half, n)));
      }
  std::printf("scaled BVH cube: largest |sdf - box distance| %.2e m over %d samples\n", worst,
              g.dims[0] * g.dims[1] * g.dims[2]);
  EXPECT_LT(worst, 1e-6);
}

// A convex hull is its points' hull grown by its margin, as Bullet collides with it. The
// conversion must be exact at the grid samples: the hull of a 4 cm cube's corners scaled
// (2, 1, 1) with margin m is the box rounded by m (closed form: box distance - m, 1e-6 m).
// The hull H of 400 points on a sphere of radius R = 5 cm (Fibonacci lattice) lies between
// the sphere and the largest ball about the centre inside it (radius r: the nearest face
// plane's distance), so its distance is bounded: |p| - R <= d_H(p) <= |p| - r, less m
// (1e-6 m slack, samples within 1 cm of the surface). Sampling the hull in Bullet's 42 directions (btShapeHull, before) was 4.5e-3 m
// off, outside those bounds.
TEST(BulletShapeConversion, ConvexHullIsExactWithItsMargin) {
  for (const float margin : {0.f, 0.01f}) {
    btConvexHullShape box;
    for (int c = 0; c < 8; ++c)
      box.addPoint(btVector3(c & 1 ? 0.02f : -0.02f, c & 2 ? 0.02f : -0.02f, c & 4 ? 0.02f : -0.02f), false);
    box.recalcLocalAabb();
    box.setLocalScaling(btVector3(2.f, 1.f, 1.f));
    box.setMargin(margin);
    const std::vector<Geometry> parts = bullet::convertShape(&box, 0.005f);
    ASSERT_EQ(parts.size(), 1u);
    const SignedDistanceGrid& g = *parts[0].sdf;
    double worst = 0;
    int inside = 0;
    for (int i = 0; i < g.dims[0]; ++i)
      for (int j = 0; j < g.dims[1]; ++j)
        for (int k = 0; k < g.dims[2]; ++k) {
          const Vec3f p{g.lower.x + i * g.cellSize, g.lower.y + j * g.cellSize, g.lower.z + k * g.cellSize};
          Vec3f n;
          const double exact = sdfBox(p, {0.04f, 0.02f, 0.02f}, n) - margin;
          const float ours = g.values[((size_t)i * g.dims[1] + j) * g.dims[2] + k];
          worst = std::fmax(worst, std::fabs(ours - exact));
          inside += ours < 0.f;
        }
    std::printf("hull of a box's corners scaled (2, 1, 1), margin %.2f: largest |sdf - (box distance - margin)| %.2e m "
                "(%d inside)\n", margin, worst, inside);
    EXPECT_LT(worst, 1e-6) << "margin " << margin;
    EXPECT_GT(inside, 100);

    btConvexHullShape ball;
    const int count = 400;
    const double R = 0.05, golden = kPi * (3 - std::sqrt(5.0));
    for (int i = 0; i < count; ++i) {
      const double z = 1 - 2 * (i + 0.5) / count, r = std::sqrt(1 - z * z);
      ball.addPoint(btVector3((btScalar)(R * r * std::cos(i * golden)), (btScalar)(R * r * std::sin(i * golden)),
                              (btScalar)(R * z)), false);
    }
    ball.recalcLocalAabb();
    ball.setMargin(margin);
    // the largest ball about the centre inside H: its radius is the nearest face plane's
    // distance (Bullet's own polyhedral features of the hull)
    ASSERT_TRUE(ball.initializePolyhedralFeatures());
    double inner = R;
    const btConvexPolyhedron* poly = ball.getConvexPolyhedron();
    for (int f = 0; f < poly->m_faces.size(); ++f) inner = std::fmin(inner, std::fabs(poly->m_faces[f].m_plane[3]));
    const double sag = R - inner;
    const std::vector<Geometry> ballParts = bullet::convertShape(&ball, 0.005f);
    ASSERT_EQ(ballParts.size(), 1u);
    const SignedDistanceGrid& b = *ballParts[0].sdf;
    double below = 0, above = 0;  // largest excursions below and above the sphere's distance
    for (int i = 0; i < b.dims[0]; ++i)
      for (int j = 0; j < b.dims[1]; ++j)
        for (int k = 0; k < b.dims[2]; ++k) {
          const Vec3f p{b.lower.x + i * b.cellSize, b.lower.y + j * b.cellSize, b.lower.z + k * b.cellSize};
          const double sphere = std::sqrt((double)p.x * p.x + (double)p.y * p.y + (double)p.z * p.z) - R - margin;
          if (std::fabs(sphere) > 0.01) continue;
          const double ours = b.values[((size_t)i * b.dims[1] + j) * b.dims[2] + k];
          below = std::fmax(below, sphere - ours);
          above = std::fmax(above, ours - sphere);
        }
    std::printf("hull of %d points on a 5 cm sphere, margin %.2f: sdf - (|p| - R - margin) in [%.2e, %.2e] m, bounds "
                "[0, %.2e] (R - inner radius)\n", count, margin, -below, above, sag);
    EXPECT_LT(below, 1e-6) << "margin " << margin << ": inside the sphere's distance";
    EXPECT_LT(above, sag + 1e-6) << "margin " << margin << ": beyond the inner sphere's distance";
  }
}

// The hull's siblings take the same exact path: a btConvexPointCloudShape of a 4 cm cube's
// corners scaled (2, 1, 1) and a btConvexTriangleMeshShape of that cube's triangles with the
// same scaling, margin 5 mm: the box rounded by the margin (1e-6 m).
TEST(BulletShapeConversion, PointCloudAndConvexTriangleMeshAreExact) {
  btVector3 corners[8];
  for (int c = 0; c < 8; ++c) corners[c] = btVector3(c & 1 ? 0.02f : -0.02f, c & 2 ? 0.02f : -0.02f, c & 4 ? 0.02f : -0.02f);
  btConvexPointCloudShape cloud(corners, 8, btVector3(2.f, 1.f, 1.f));
  cloud.setMargin(0.005f);
  btTriangleMesh tris;
  const int faces[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                            {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  for (const auto& f : faces) tris.addTriangle(corners[f[0]], corners[f[1]], corners[f[2]]);
  btConvexTriangleMeshShape convexMesh(&tris);
  convexMesh.setLocalScaling(btVector3(2.f, 1.f, 1.f));
  convexMesh.setMargin(0.005f);
  for (const btConvexShape* shape : {(const btConvexShape*)&cloud, (const btConvexShape*)&convexMesh}) {
    const std::vector<Geometry> parts = bullet::convertShape(shape, 0.005f);
    ASSERT_EQ(parts.size(), 1u);
    const SignedDistanceGrid& g = *parts[0].sdf;
    double worst = 0;
    for (int i = 0; i < g.dims[0]; ++i)
      for (int j = 0; j < g.dims[1]; ++j)
        for (int k = 0; k < g.dims[2]; ++k) {
          const Vec3f p{g.lower.x + i * g.cellSize, g.lower.y + j * g.cellSize, g.lower.z + k * g.cellSize};
          Vec3f n;
          worst = std::fmax(worst, std::fabs(g.values[((size_t)i * g.dims[1] + j) * g.dims[2] + k] -
                                             (sdfBox(p, {0.04f, 0.02f, 0.02f}, n) - 0.005f)));
        }
    std::printf("%s: largest |sdf - (box distance - margin)| %.2e m\n", shape->getName(), worst);
    EXPECT_LT(worst, 1e-6) << shape->getName();
  }
}

}  // namespace
}  // namespace mpm
