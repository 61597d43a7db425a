// Shapes thinner than a cell resting on tissue: needles, thread links, probes
// and grasper jaws are thinner than a grid cell in real scenes. A Bullet capsule 4 cm long,
// of radius 0.2, 0.4 or 0.6 dx, dropped 3 cm onto a 30 kPa block 6 cm thick (dx = 1 cm),
// must come to rest on the block's surface and stay there for 5 s, as a rigid body and as
// the links of a multibody chain, with every grid solver. Before parts thinner than a cell
// had their contact band (PartView::band), radii 0.2 and 0.4 dx sank through the block.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <tuple>
#include <vector>

#include "bullet_test_world.h"
#include "mpm/scene.h"
#include "mpm_bullet/coupler.h"
#include "solver_cases.h"

namespace mpm {
namespace {

constexpr float kDx = 0.01f, kG = 9.81f, kTop = 0.06f, kHalfLength = 0.02f;

enum class Body { Rigid2g, Rigid02g, ChainLinks2g };
std::string bodyName(Body b) {
  return b == Body::Rigid2g ? "Rigid2g" : b == Body::Rigid02g ? "Rigid02g" : "ChainLinks2g";
}

struct Resting {
  float lowest = 0;   ///< the lowest capsule's bottom above the block's top at the end [cells]
  float highest = 0;  ///< the highest one's [cells]
  float spin = 0;      ///< rigid capsules: mean angular speed over the last second [rad/s]
  float spinPeak = 0;  ///< the fastest of its frames [rad/s]
};

/// Height of a capsule's lowest point [m]: its segment's lower end less the radius. Not
/// the bottom of Bullet's getAabb, which bounds the capsule's box: a capsule rolled by 45
/// degrees about its axis reports its bottom 0.41 r too low (0.25 dx for r = 0.6 dx; a
/// capsule rolling off a node column into the valley beside it rolls that far).
float capsuleBottom(const btCollisionObject& c) {
  const auto& capsule = static_cast<const btCapsuleShape&>(*c.getCollisionShape());
  const btTransform& t = c.getWorldTransform();
  const btVector3 axis = t.getBasis().getColumn(capsule.getUpAxis());
  return (float)(t.getOrigin().y() - capsule.getHalfHeight() * std::fabs(axis.y()) - capsule.getRadius());
}

Resting dropCapsules(Body body, float radiusCells, SolverType solver) {
  SceneSettings st;
  st.solver = solver;
  st.backend = Backend::Cpu;
  st.dx = kDx;
  st.domain.lower = {-0.1f, -0.02f, -0.1f};
  st.domain.upper = {0.1f, 0.15f, 0.1f};
  st.gravity = {0.f, -kG, 0.f};
  Scene scene(st);
  ParticleObjectDesc block;
  block.center = {0.f, 0.5f * kTop, 0.f};
  block.halfExtents = {0.05f, 0.5f * kTop, 0.05f};
  block.material.youngsModulus = 3e4f;
  block.material.poissonRatio = 0.3f;
  scene.addParticleObject(block);

  const bool chain = body == Body::ChainLinks2g;
  test::BulletWorld bw(chain ? test::WorldType::MultiBody : test::WorldType::Discrete, kG);
  btRigidBody* ground = bw.addGround();
  const float r = radiusCells * kDx, drop = 0.03f;
  const float mass = body == Body::Rigid02g ? 2e-4f : 2e-3f;
  std::vector<btCollisionObject*> capsules;
  bullet::Coupler coupler(bw.world.get(), scene);
  coupler.addRigidBody(ground);
  if (!chain) {
    btRigidBody* c = bw.addBody(new btCapsuleShapeX(r, 2.f * kHalfLength - 2.f * r), mass,
                                btTransform(btQuaternion::getIdentity(), btVector3(0, kTop + r + drop, 0)));
    coupler.addRigidBody(c);
    capsules.push_back(c);
  } else {
    // three capsule links along x, joined by spherical joints, a floating base
    btMultiBody* mb = bw.addCapsuleChain(3, r, kHalfLength, mass, btVector3(-2.f * kHalfLength - 0.002f, kTop + r + drop, 0));
    coupler.addMultiBody(mb);
    capsules = bw.chainColliders(mb);
  }
  constexpr int kFrames = 300, kLastSecond = 60;
  float spinSum = 0, spinPeak = 0;
  for (int f = 0; f < kFrames; ++f) {
    bw.world->stepSimulation(1.f / 60, 10, 1.f / 240);
    if (!chain && f >= kFrames - kLastSecond) {
      const float w = (float)static_cast<btRigidBody*>(capsules[0])->getAngularVelocity().length();
      spinSum += w;
      spinPeak = std::fmax(spinPeak, w);
    }
  }
  coupler.rethrowError();

  Resting res{1e9f, -1e9f, spinSum / kLastSecond, spinPeak};
  for (btCollisionObject* c : capsules) {
    const float above = (capsuleBottom(*c) - kTop) / kDx;
    res.lowest = std::fmin(res.lowest, above);
    res.highest = std::fmax(res.highest, above);
  }
  return res;
}

class ThinCapsules : public ::testing::TestWithParam<std::tuple<Body, float, SolverType>> {};

TEST_P(ThinCapsules, RestOnTheTissueSurface) {
  const auto [body, radius, solver] = GetParam();
  const Resting r = dropCapsules(body, radius, solver);
  std::printf("%s r = %.1f dx %s: after 5 s the capsules' bottoms lie %.3f ... %.3f dx above the block's top; "
              "spin over the last second %.3f rad/s mean, %.3f peak\n",
              bodyName(body).c_str(), radius, test::solverName(solver).c_str(), r.lowest, r.highest, r.spin, r.spinPeak);
  // On the surface: no deeper than 0.2 dx into it (measured down to -0.18 dx, the PB-MPM
  // chain of radius 0.6 dx; the block's own weight lowers its top by 0.06 dx). Before,
  // capsules of 0.2 and 0.4 dx went through the whole block (6 cells); the -0.39 dx once
  // measured here was the bottom of Bullet's getAabb of rolled capsules (capsuleBottom).
  EXPECT_GT(r.lowest, -0.2f) << "sank into the tissue";
  // Above it by at most the band that makes the part 0.75 dx thick (PartView::band), plus
  // 0.2 dx. A 0.2 g capsule on standard MPM hovered 0.9-1.3 dx above the tissue, held by the
  // node layer above it (takesContact); on PB-MPM the one of 0.6 dx blew the tissue up at
  // 2.3 s, kicked by its implicit velocity update (kBodyPredictionSteps).
  EXPECT_LT(r.highest, std::fmax(0.75f - radius, 0.f) + 0.2f) << "rests above the tissue";
  // At rest, not turning: the contact's lever is the surface point (contactNodePart). With
  // the node as the lever a 2 g capsule of radius 0.2 dx turned about its axis at 5.4-7.1
  // rad/s on average over the last second (nodes of its band lie up to 0.75 dx off the
  // axis), and a PB-MPM chain link rolled off; now at most 0.14 rad/s. The mean, not the
  // fastest frame: a node entering or leaving the contact band (a threshold) kicks the
  // capsule for one frame, and how often that happens moves with rounding alone (the peak
  // over the last second 0.17 or 1.35 rad/s on standard MPM, r 0.2 dx, as the compiler
  // contracts multiply-adds differently; the mean 0.14 in both). The 0.2 g capsules still
  // turn at 0.1-1.3 rad/s on average (r 0.2 and 0.4 dx, all radii on PB-MPM): open, in
  // docs/limits.md.
  if (body == Body::Rigid2g) EXPECT_LT(r.spin, 0.5f) << "turns about its axis while resting";
}

INSTANTIATE_TEST_SUITE_P(AllRadii, ThinCapsules,
                         ::testing::Combine(::testing::Values(Body::Rigid2g, Body::Rigid02g, Body::ChainLinks2g),
                                            ::testing::Values(0.2f, 0.4f, 0.6f), test::allSolvers()),
                         [](const ::testing::TestParamInfo<std::tuple<Body, float, SolverType>>& info) {
                           return bodyName(std::get<0>(info.param)) + "_R" +
                                  std::to_string((int)std::lround(10 * std::get<1>(info.param))) + "tenths_" +
                                  test::solverName(std::get<2>(info.param));
                         });

}  // namespace
}  // namespace mpm
