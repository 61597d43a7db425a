// Domain walls: material never passes them, slip walls keep tangential motion, sticky
// walls stop it. Every solver, with the same bounds.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <tuple>
#include <vector>

#include "mpm/scene.h"
#include "solver_cases.h"

namespace mpm {
namespace {

using test::solverName;

SceneSettings floorBox(SolverType solver, WallMode mode) {
  SceneSettings s;
  s.solver = solver;
  s.domain.lower = {-0.5f, 0.f, -0.5f};
  s.domain.upper = {0.5f, 1.f, 0.5f};
  s.domain.wallMode = mode;
  s.dx = 0.04f;
  s.gravity = {0.f, -9.81f, 0.f};
  return s;
}

ParticleObjectDesc slidingBlock(float height) {
  ParticleObjectDesc d;
  d.center = {-0.1f, height, 0.f};
  d.halfExtents = {0.1f, 0.05f, 0.1f};
  d.velocity = {0.5f, 0.f, 0.f};
  d.material.youngsModulus = 2e5f;
  d.material.poissonRatio = 0.3f;
  return d;
}

class Walls : public ::testing::TestWithParam<SolverType> {};

TEST_P(Walls, DroppedBlockNeverPassesTheFloor) {
  for (WallMode mode : {WallMode::Sticky, WallMode::Slip, WallMode::Separate}) {
    Scene scene(floorBox(GetParam(), mode));
    ParticleObjectDesc d;
    d.center = {0.f, 0.5f, 0.f};
    d.halfExtents = {0.1f, 0.1f, 0.1f};
    d.velocity = {0.f, -2.f, 0.f};
    d.material.youngsModulus = 5e4f;
    const ParticleObjectId id = scene.addParticleObject(d);
    std::vector<Vec3f> x;
    float lowest = 1e9f;
    for (int f = 0; f < 40; ++f) {
      scene.step(0.01f);
      scene.readPositions(id, x);
      for (const Vec3f& p : x) lowest = std::min(lowest, p.y);
    }
    std::printf("%s, wall mode %d: lowest particle %.4f m\n", solverName(GetParam()).c_str(), (int)mode, lowest);
    // the wall acts on nodes 0 and 1: nothing may get below the second node, y = dx
    EXPECT_GT(lowest, 0.04f) << "wall mode " << static_cast<int>(mode);
  }
}

// Mean x travel of the block's bottom particle layer over 0.3 s of sliding.
double bottomLayerTravel(SolverType solver, WallMode mode, double* velocity) {
  Scene scene(floorBox(solver, mode));
  // resting on the floor: bottom particles at y = 2 dx + h/2, inside the wall's reach
  const ParticleObjectId id = scene.addParticleObject(slidingBlock(0.08f + 0.05f));
  std::vector<Vec3f> x0, x;
  scene.readPositions(id, x0);
  float yMin = 1e9f;
  for (const Vec3f& p : x0) yMin = std::min(yMin, p.y);
  for (int f = 0; f < 30; ++f) scene.step(0.01f);
  scene.readPositions(id, x);
  double travel = 0;
  int n = 0;
  for (size_t i = 0; i < x.size(); ++i)
    if (x0[i].y < yMin + 1e-4f) travel += x[i].x - x0[i].x, ++n;
  const ObjectSummary s = scene.summary(id);
  *velocity = s.momentum[0] / s.mass;
  std::printf("%s, wall mode %d: bottom layer travel %.4f m, block velocity %.4f m/s\n", solverName(solver).c_str(),
              (int)mode, travel / n, *velocity);
  return travel / n;
}

TEST_P(Walls, SlipFloorKeepsSlidingVelocity) {
  double v;
  const double travel = bottomLayerTravel(GetParam(), WallMode::Slip, &v);
  EXPECT_NEAR(v, 0.5, 0.01) << "frictionless: horizontal velocity kept";
  EXPECT_NEAR(travel, 0.15, 0.01) << "the bottom slides with the block";
}

TEST_P(Walls, StickyFloorHoldsTheBottomLayer) {
  double v;
  const double travel = bottomLayerTravel(GetParam(), WallMode::Sticky, &v);
  EXPECT_LT(std::abs(travel), 0.015) << "bottom layer held (slip floor: 0.15 m)";
  EXPECT_LT(std::abs(v), 0.25) << "the block's sliding momentum is mostly taken by the wall";
}

TEST_P(Walls, SeparateWallLetsMaterialLeave) {
  // no gravity, a block resting on the floor moving upward: a separating wall lets it go
  // with its momentum; a slip wall holds the nodes it touches and takes momentum away
  auto rise = [this](WallMode mode) {
    SceneSettings s = floorBox(GetParam(), mode);
    s.gravity = {0.f, 0.f, 0.f};
    Scene scene(s);
    ParticleObjectDesc d = slidingBlock(0.08f + 0.05f);
    d.velocity = {0.f, 1.f, 0.f};
    const ParticleObjectId id = scene.addParticleObject(d);
    for (int f = 0; f < 10; ++f) scene.step(0.01f);
    const ObjectSummary sum = scene.summary(id);
    return sum.momentum[1] / sum.mass;
  };
  const double separate = rise(WallMode::Separate), slip = rise(WallMode::Slip);
  std::printf("%s: rising block velocity after 0.1 s: separate wall %.4f m/s, slip wall %.4f m/s\n",
              solverName(GetParam()).c_str(), separate, slip);
  EXPECT_NEAR(separate, 1.0, 0.01);
  EXPECT_LT(slip, separate - 0.02);
}

// A sphere pressed on the axis of a block, with friction, gravity and a slip floor: the
// whole block, and a quarter of it on two mirror planes through the axis. The axis lies off
// the origin: a ghost's image of a point depends on where its plane is (2 plane - x), which
// a plane through the origin hides.
struct PressedBlock {
  std::vector<Vec3f> x0, x;  ///< particle positions at the start and the end
  ShapeImpulse impulse;      ///< summed over the run
};

PressedBlock pressBlock(SolverType solver, bool quarter) {
  const float dx = 0.01f, half = 0.08f, height = 0.08f;
  SceneSettings s = floorBox(solver, WallMode::Slip);
  s.dx = dx;
  const float wall = (float)s.domain.wallThickness * dx;
  // the axis x = z = 0.25 m on a node column, wallThickness cells above the lower faces
  const float axis = 0.25f;
  s.domain.lower = {axis - 0.12f - wall, -wall, axis - 0.12f - wall};
  s.domain.upper = {axis + 0.12f + wall, 0.16f, axis + 0.12f + wall};
  if (quarter) {
    s.domain.lower.x = s.domain.lower.z = axis - wall;
    s.domain.mirrorLower[0] = s.domain.mirrorLower[2] = true;
    EXPECT_NEAR(s.domain.mirrorPlane(0, dx), axis, 1e-6f);
  }
  Scene scene(s);
  ParticleObjectDesc d;
  d.center = quarter ? Vec3f{axis + 0.5f * half, 0.5f * height, axis + 0.5f * half} : Vec3f{axis, 0.5f * height, axis};
  d.halfExtents = quarter ? Vec3f{0.5f * half, 0.5f * height, 0.5f * half} : Vec3f{half, 0.5f * height, half};
  d.material.youngsModulus = 2e4f;
  d.material.poissonRatio = 0.3f;
  const ParticleObjectId id = scene.addParticleObject(d);
  Geometry ball;
  ball.type = GeometryType::Sphere;
  ball.radius = 0.05f;
  ShapeDesc sphere;
  sphere.parts = {ball};
  sphere.pose.position = {axis, height + 0.05f + 0.005f, axis};
  sphere.linearVelocity = {0.f, -0.1f, 0.f};
  sphere.contact.mode = ContactMode::Frictional;
  sphere.contact.friction = 0.3f;
  const ShapeId sphereId = scene.addShape(sphere);
  PressedBlock r;
  scene.readPositions(id, r.x0);
  for (int f = 0; f < 20; ++f) {  // 0.02 m of travel, 0.015 m into the block
    scene.step(0.01f);
    const ShapeImpulse i = scene.shapeImpulse(sphereId);
    r.impulse.linear += i.linear;
    r.impulse.angular += i.angular;
  }
  scene.readPositions(id, r.x);
  return r;
}

TEST_P(Walls, QuarterModelOnMirrorPlanesMovesAsTheWholeBody) {
  const PressedBlock whole = pressBlock(GetParam(), false), quarter = pressBlock(GetParam(), true);
  ASSERT_EQ(whole.x.size(), 4 * quarter.x.size());
  // the whole block's particle at each quarter particle's start (same lattice)
  auto key = [](Vec3f p) { return std::make_tuple(std::lround(p.x * 4e3), std::lround(p.y * 4e3), std::lround(p.z * 4e3)); };
  std::map<std::tuple<long, long, long>, size_t> wholeAt;
  for (size_t i = 0; i < whole.x0.size(); ++i) wholeAt[key(whole.x0[i])] = i;
  double worst = 0, moved = 0;
  for (size_t i = 0; i < quarter.x.size(); ++i) {
    const auto it = wholeAt.find(key(quarter.x0[i]));
    ASSERT_NE(it, wholeAt.end()) << "quarter particle " << i << " has no twin in the whole block";
    worst = std::max(worst, (double)norm(quarter.x[i] - whole.x[it->second]));
    moved = std::max(moved, (double)norm(quarter.x[i] - quarter.x0[i]));
  }
  const double force = whole.impulse.linear.y, quarterForce = 4.0 * quarter.impulse.linear.y;
  std::printf("%s: largest displacement %.3g m; largest quarter-whole difference %.3g m; sphere impulse whole %.6g, "
              "4 x quarter %.6g N s (%+.3g %%)\n",
              solverName(GetParam()).c_str(), moved, worst, force, quarterForce, 100 * (quarterForce / force - 1));
  EXPECT_GT(moved, 0.01) << "the sphere pressed the block";
  // the same arithmetic in another order: float rounding only
  EXPECT_LT(worst, 1e-5) << "a quarter particle strays from its twin in the whole block";
  EXPECT_NEAR(quarterForce / force, 1.0, 1e-3) << "the quarter model takes a quarter of the sphere's impulse";
}

INSTANTIATE_TEST_SUITE_P(AllSolvers, Walls, test::allSolvers(), test::solverParamName());

}  // namespace
}  // namespace mpm
