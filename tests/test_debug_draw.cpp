// Coupler::debugDraw: the tissue, the blades, the needles and the threads as lines through
// a btIDebugDraw, where they are in the scene. No stepping: the scene holds the poses the
// coupler gave it when the tools were added.
#include <gtest/gtest.h>

#include <btBulletDynamicsCommon.h>

#include <cmath>
#include <vector>

#include "bullet_test_world.h"
#include "mpm/scene.h"
#include "mpm_bullet/coupler.h"
#include "mpm_bullet/suture.h"

namespace mpm {
namespace {

/// A debug drawer that keeps every line it is given.
struct RecordingDrawer : btIDebugDraw {
  struct Line {
    btVector3 from, to, color;
  };
  std::vector<Line> lines;
  int mode = DBG_DrawWireframe;

  void drawLine(const btVector3& from, const btVector3& to, const btVector3& color) override {
    lines.push_back({from, to, color});
  }
  void drawContactPoint(const btVector3&, const btVector3&, btScalar, int, const btVector3&) override {}
  void reportErrorWarning(const char*) override {}
  void draw3dText(const btVector3&, const char*) override {}
  void setDebugMode(int m) override { mode = m; }
  int getDebugMode() const override { return mode; }

  /// The lines drawn in `color`.
  std::vector<Line> of(Vec3f color) const {
    std::vector<Line> out;
    for (const Line& l : lines)
      if (l.color == btVector3(color.x, color.y, color.z)) out.push_back(l);
    return out;
  }
};

/// A kinematic body (no collision with anything here) at `pose`.
btRigidBody* kinematicBody(test::BulletWorld& bw, const btTransform& pose) {
  btRigidBody* b = bw.addBody(new btSphereShape(0.002f), 0.f, pose);
  b->setCollisionFlags(b->getCollisionFlags() | btCollisionObject::CF_KINEMATIC_OBJECT);
  b->setActivationState(DISABLE_DEACTIVATION);
  return b;
}

btTransform toBtTransform(const Pose& p) {
  return btTransform(btQuaternion(p.rotation.x, p.rotation.y, p.rotation.z, p.rotation.w),
                     btVector3(p.position.x, p.position.y, p.position.z));
}

Pose turned(Vec3f at, btVector3 axis, float angle) {
  const btQuaternion q(axis.normalized(), angle);
  Pose p;
  p.position = at;
  p.rotation = {(float)q.x(), (float)q.y(), (float)q.z(), (float)q.w()};
  return p;
}

// Tissue in two objects (one of them in a slot freed by a removed object), a quad blade
// and a needle on kinematic bodies and a four-link thread: every line where it belongs.
TEST(DebugDraw, LinesLieOnTheTissueAndTheTools) {
  test::BulletWorld bw(test::WorldType::MultiBody, 9.81f);
  SceneSettings s;
  s.domain = {{-0.1f, -0.05f, -0.1f}, {0.1f, 0.15f, 0.1f}};
  s.dx = 0.01f;
  Scene scene(s);
  ParticleObjectDesc block;
  block.center = {0.f, 0.03f, 0.f};
  block.halfExtents = {0.02f, 0.015f, 0.02f};
  const ParticleObjectId removed = scene.addParticleObject(block);
  block.center = {0.f, 0.08f, 0.f};
  block.halfExtents = {0.01f, 0.01f, 0.01f};
  const ParticleObjectId small = scene.addParticleObject(block);
  scene.removeParticleObject(removed);
  block.center = {0.f, 0.03f, 0.f};
  block.halfExtents = {0.02f, 0.015f, 0.02f};
  const ParticleObjectId tissue = scene.addParticleObject(block);
  ASSERT_EQ(tissue.generation, 1u);  // the slot `removed` had

  bullet::Coupler coupler(bw.world.get(), scene);
  btRigidBody* scalpel = kinematicBody(bw, toBtTransform(turned({0.02f, 0.09f, -0.01f}, {1, 1, 0}, 0.3f)));
  QuadSlicerDesc blade;
  blade.halfLength = 0.015f;
  blade.width = 0.02f;
  blade.pose = turned({0.f, -0.01f, 0.005f}, {0, 0, 1}, 0.2f);
  coupler.addSlicer(scalpel, blade);
  btRigidBody* holder = kinematicBody(bw, toBtTransform(turned({-0.03f, 0.09f, 0.02f}, {0, 1, 1}, -0.7f)));
  ArcDesc needle;
  needle.radius = 0.012f;
  needle.startAngle = 0.2f;
  needle.endAngle = 2.8f;
  needle.pose = turned({0.01f, 0.f, 0.f}, {1, 0, 0}, 0.5f);
  coupler.addNeedle(holder, needle);
  btMultiBody* thread = bw.addCapsuleChain(4, 0.001f, 0.005f, 1e-4f, btVector3(-0.02f, 0.12f, -0.05f));
  coupler.addThread(thread);

  RecordingDrawer drawer;
  const bullet::DebugDrawOptions options;
  coupler.debugDraw(&drawer, options);

  // tissue: three lines of a quarter cell through each particle, along the axes
  std::vector<Vec3f> x, more;
  scene.readPositions(tissue, x);
  scene.readPositions(small, more);
  x.insert(x.end(), more.begin(), more.end());
  const std::vector<RecordingDrawer::Line> cross = drawer.of(options.tissueColor);
  ASSERT_EQ(cross.size(), 3 * scene.particleCount());
  ASSERT_EQ(x.size(), scene.particleCount());
  std::vector<int> crossesAt(x.size(), 0);
  for (size_t c = 0; c < cross.size(); c += 3) {
    const btVector3 centre = 0.5f * (cross[c].from + cross[c].to);
    for (size_t k = 0; k < 3; ++k) {
      const RecordingDrawer::Line& l = cross[c + k];
      EXPECT_LT((0.5f * (l.from + l.to) - centre).length(), 1e-6f);
      EXPECT_NEAR((l.to - l.from).length(), 0.25f * s.dx, 1e-7f);
      EXPECT_NEAR(std::fabs((l.to - l.from)[(int)k]), 0.25f * s.dx, 1e-7f) << "along axis " << k;
    }
    for (size_t i = 0; i < x.size(); ++i)
      if ((centre - btVector3(x[i].x, x[i].y, x[i].z)).length() < 1e-6f) crossesAt[i]++;
  }
  for (size_t i = 0; i < x.size(); ++i) ASSERT_EQ(crossesAt[i], 1) << "particle " << i;

  // tools (grey): the blade's outline first, then the needle's arc
  const std::vector<RecordingDrawer::Line> tool = drawer.of(options.toolColor);
  ASSERT_EQ(tool.size(), 4u + 32u);
  const btTransform b = scalpel->getCenterOfMassTransform() * toBtTransform(blade.pose);
  const btVector3 corner[4] = {b * btVector3(-0.015f, 0, 0), b * btVector3(0.015f, 0, 0), b * btVector3(0.015f, 0.02f, 0),
                               b * btVector3(-0.015f, 0.02f, 0)};
  int endsAt[4] = {0, 0, 0, 0};
  for (size_t k = 0; k < 4; ++k)
    for (const btVector3& end : {tool[k].from, tool[k].to})
      for (int c = 0; c < 4; ++c)
        if ((end - corner[c]).length() < 1e-5f) endsAt[c]++;
  for (int c = 0; c < 4; ++c) EXPECT_EQ(endsAt[c], 2) << "corner " << c;  // a closed outline

  const btTransform n = holder->getCenterOfMassTransform() * toBtTransform(needle.pose);
  for (size_t k = 4; k < tool.size(); ++k)
    for (const btVector3& end : {tool[k].from, tool[k].to}) {
      const btVector3 local = n.invXform(end);  // in the arc's frame: the x-y plane, radius R
      EXPECT_NEAR(std::hypot(local.x(), local.y()), needle.radius, 1e-5f);
      EXPECT_NEAR(local.z(), 0.f, 1e-5f);
      const float angle = std::atan2(local.y(), local.x());
      EXPECT_GE(angle, needle.startAngle - 1e-4f);
      EXPECT_LE(angle, needle.endAngle + 1e-4f);
    }
  EXPECT_LT((n.invXform(tool[4].from) - btVector3(needle.radius * std::cos(0.2f), needle.radius * std::sin(0.2f), 0)).length(), 1e-5f);
  EXPECT_LT((n.invXform(tool.back().to) - btVector3(needle.radius * std::cos(2.8f), needle.radius * std::sin(2.8f), 0)).length(), 1e-5f);

  // the thread: its polyline through threadPoints
  const std::vector<RecordingDrawer::Line> strand = drawer.of(options.threadColor);
  const std::vector<btVector3> p = bullet::threadPoints(thread);
  ASSERT_EQ(strand.size(), p.size() - 1);
  for (size_t k = 0; k < strand.size(); ++k) {
    EXPECT_EQ(strand[k].from, p[k]);
    EXPECT_EQ(strand[k].to, p[k + 1]);
  }
  EXPECT_EQ(drawer.lines.size(), cross.size() + tool.size() + strand.size());

  // every third particle of each object
  RecordingDrawer sparse;
  bullet::DebugDrawOptions every3;
  every3.particleStride = 3;
  coupler.debugDraw(&sparse, every3);
  const size_t thirds = (scene.particleCount(tissue) + 2) / 3 + (scene.particleCount(small) + 2) / 3;
  EXPECT_EQ(sparse.of(every3.tissueColor).size(), 3 * thirds);
  EXPECT_EQ(sparse.lines.size(), 3 * thirds + tool.size() + strand.size());

  // the world's drawer when none is given; DBG_NoDebug and no drawer draw nothing
  coupler.debugDraw();  // the world has none
  RecordingDrawer worlds;
  bw.world->setDebugDrawer(&worlds);
  coupler.debugDraw();
  EXPECT_EQ(worlds.lines.size(), drawer.lines.size());
  RecordingDrawer off;
  off.setDebugMode(btIDebugDraw::DBG_NoDebug);
  coupler.debugDraw(&off);
  EXPECT_TRUE(off.lines.empty());
  bw.world->setDebugDrawer(&off);
  coupler.debugDraw();
  EXPECT_TRUE(off.lines.empty());
  bw.world->setDebugDrawer(nullptr);

  bullet::DebugDrawOptions bad;
  bad.particleStride = 0;
  EXPECT_THROW(coupler.debugDraw(&drawer, bad), InvalidArgument);
}

}  // namespace
}  // namespace mpm
