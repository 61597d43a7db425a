// SceneBatch (mpm/scene_batch.h): scenes advanced together end bit for bit where each
// would have stepped alone, on 1 and 2 batch threads; shapes' impulses and states too.
// Bad input is refused naming the field and the value, starting nothing.
#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <vector>

#include "mpm/scene.h"
#include "core/validate.h"
#include "mpm/scene_batch.h"
#include "forked_child.h"

namespace mpm {
namespace {

constexpr float kTick = 1.f / 240;  // the Bullet coupler's tick in the README's scene

/// A small cut of the README's embedding scene (tests/embed_snippet.inc: dx 2 cm,
/// Neo-Hookean E = 200 kPa, nu = 0.3): a 12 x 6 x 12 cm slab, 864 particles, on a
/// kinematic ground box, and in odd scenes a 0.2 kg sphere falling onto it. Scene `i`
/// starts the slab spinning at 0.5 i rad/s so no two scenes are the same.
struct Small {
  std::unique_ptr<Scene> scene;
  ParticleObjectId slab;
  ShapeId ball;
  bool hasBall = false;
};

Small makeScene(int i, int cpuThreads) {
  SceneSettings s;
  s.domain = {{-0.25f, -0.1f, -0.25f}, {0.25f, 0.4f, 0.25f}};
  s.dx = 0.02f;
  s.backend = Backend::Cpu;
  s.cpuThreads = cpuThreads;
  Small out;
  out.scene = std::make_unique<Scene>(s);
  ParticleObjectDesc slab;
  slab.center = {0.f, 0.032f, 0.f};
  slab.halfExtents = {0.06f, 0.03f, 0.06f};
  slab.material = {MaterialModel::NeoHookeanDecoupled, 2e5f, 0.3f, 1000.f};
  slab.angularVelocity = {0.f, 0.5f * (float)i, 0.f};
  out.slab = out.scene->addParticleObject(slab);
  ShapeDesc ground;
  ground.parts = {Geometry::box({0.24f, 0.04f, 0.24f})};
  ground.pose.position = {0.f, -0.04f, 0.f};
  out.scene->addShape(ground);
  if (i % 2) {
    ShapeDesc ball;
    ball.parts = {Geometry::sphere(0.03f)};
    ball.pose.position = {0.01f * (float)i, 0.095f, 0.f};
    ball.linearVelocity = {0.f, -0.5f, 0.f};
    ball.mass = 0.2f;
    const float I = 0.4f * 0.2f * 0.03f * 0.03f;
    ball.inertia = {I, I, I};
    ball.gravity = {0.f, -9.81f, 0.f};
    out.ball = out.scene->addShape(ball);
    out.hasBall = true;
  }
  return out;
}

struct Result {
  std::vector<Vec3f> x, v;
  ShapeImpulse impulse;
  ShapeState ball;
  double time = 0;
};

Result read(const Small& s) {
  Result r;
  s.scene->readPositions(s.slab, r.x);
  s.scene->readVelocities(s.slab, r.v);
  if (s.hasBall) {
    r.impulse = s.scene->shapeImpulse(s.ball);
    r.ball = s.scene->shapeState(s.ball);
  }
  r.time = s.scene->time();
  return r;
}

void expectSame(const Result& a, const Result& b, int scene) {
  SCOPED_TRACE("scene " + std::to_string(scene));
  ASSERT_EQ(a.x.size(), b.x.size());
  ASSERT_EQ(a.x.size(), 864u);
  EXPECT_EQ(0, std::memcmp(a.x.data(), b.x.data(), a.x.size() * sizeof(Vec3f)));
  EXPECT_EQ(0, std::memcmp(a.v.data(), b.v.data(), a.v.size() * sizeof(Vec3f)));
  EXPECT_EQ(0, std::memcmp(&a.impulse, &b.impulse, sizeof(ShapeImpulse)));
  EXPECT_EQ(0, std::memcmp(&a.ball, &b.ball, sizeof(ShapeState)));
  EXPECT_EQ(a.time, b.time);
}

constexpr int kScenes = 5;  // more than the threads, and not a multiple of 2
constexpr int kTicks = 36;

/// Each scene stepped alone on `cpuThreads` threads.
std::vector<Result> alone(int cpuThreads) {
  std::vector<Result> out;
  for (int i = 0; i < kScenes; ++i) {
    Small s = makeScene(i, cpuThreads);
    for (int t = 0; t < kTicks; ++t) s.scene->step(kTick);
    out.push_back(read(s));
  }
  return out;
}

/// Scenes 0 .. count - 1 (makeScene) and the list a SceneBatch takes.
struct Batch {
  std::vector<Small> scenes;
  std::vector<Scene*> all;
};
Batch makeBatch(int count, int cpuThreads = 1) {
  Batch b;
  for (int i = 0; i < count; ++i) {
    b.scenes.push_back(makeScene(i, cpuThreads));
    b.all.push_back(b.scenes.back().scene.get());
  }
  return b;
}

/// The same scenes in a batch of `threads`; the scenes' own setting is 2 threads, which
/// the batch overrides while it steps them.
std::vector<Result> batched(int threads, std::vector<size_t>* substeps = nullptr) {
  Batch b = makeBatch(kScenes, 2);
  const std::vector<Small>& scenes = b.scenes;
  SceneBatch batch(b.all, threads);
  EXPECT_EQ(batch.threads(), threads);
  for (int t = 0; t < kTicks; ++t) {
    const std::vector<StepReport> reports = batch.step(kTick);
    EXPECT_EQ(reports.size(), (size_t)kScenes);
    if (substeps && t == 0)
      for (const StepReport& r : reports) substeps->push_back(r.substeps);
  }
  EXPECT_TRUE(batch.failedScenes().empty());
  std::vector<Result> out;
  for (const Small& s : scenes) out.push_back(read(s));
  return out;
}

TEST(SceneBatch, ScenesEndWhereEachSteppedAloneOnOneAndTwoThreads) {
  const std::vector<Result> ref = alone(1);
  std::vector<size_t> substeps;
  const std::vector<Result> one = batched(1, &substeps), two = batched(2);
  for (int i = 0; i < kScenes; ++i) {
    expectSame(ref[i], one[i], i);
    expectSame(ref[i], two[i], i);
  }
  // the scenes did differ and did move: the ball was stopped by the slab, the slab spun
  for (size_t n : substeps) EXPECT_GE(n, 2u);  // E = 200 kPa at dx 2 cm: several substeps a tick
  EXPECT_NE(0, std::memcmp(ref[1].x.data(), ref[2].x.data(), ref[1].x.size() * sizeof(Vec3f)));
  EXPECT_GT(ref[1].impulse.linear.y, 0.f);  // the slab pushes the ball up
  EXPECT_GT(ref[1].ball.linearVelocity.y, -0.5f - 9.81f * kTicks * kTick);  // slower than free fall
  EXPECT_NEAR(ref[0].time, kTicks * (double)kTick, 1e-12);  // summed in double
}

TEST(SceneBatch, SteppedAloneAfterwardsTheSceneKeepsItsOwnThreads) {
  // a batch of one on 2 threads gives the scene both; afterwards it steps on its own
  // setting (1 thread) and still matches a scene that never was in a batch
  Small a = makeScene(3, 1), b = makeScene(3, 1);
  {
    SceneBatch batch({a.scene.get()}, 2);
    for (int t = 0; t < 4; ++t) batch.step(kTick);
  }
  for (int t = 0; t < 4; ++t) b.scene->step(kTick);
  for (int t = 0; t < 4; ++t) {
    a.scene->step(kTick);
    b.scene->step(kTick);
  }
  expectSame(read(b), read(a), 3);
}

TEST(SceneBatch, PerSceneStepsAdvanceEachByItsOwnDt) {
  Small a = makeScene(0, 1), b = makeScene(1, 1);
  SceneBatch batch({a.scene.get(), b.scene.get()}, 2);
  batch.advance(std::vector<float>{kTick, 2 * kTick});
  const std::vector<StepReport> r = batch.fetchResults();
  ASSERT_EQ(r.size(), 2u);
  EXPECT_DOUBLE_EQ(a.scene->time(), (double)kTick);
  EXPECT_DOUBLE_EQ(b.scene->time(), (double)(2 * kTick));
  EXPECT_TRUE(batch.fetchResults().empty());  // nothing running
}

template <class F>
void expectInvalid(F f, const std::string& field, const std::string& value) {
  try {
    f();
    ADD_FAILURE() << "no error for " << field;
  } catch (const InvalidArgument& e) {
    EXPECT_EQ(e.field(), field) << e.what();
    EXPECT_EQ(e.value(), value) << e.what();
  }
}

TEST(SceneBatch, BadInputIsRefusedNamingTheFieldAndStartsNothing) {
  Small a = makeScene(0, 1), b = makeScene(1, 1);
  expectInvalid([&] { SceneBatch({a.scene.get(), nullptr}); }, "SceneBatch scenes[1]", "null");
  expectInvalid([&] { SceneBatch({a.scene.get(), b.scene.get(), a.scene.get()}); }, "SceneBatch scenes[2]",
                "scenes[0]");
  expectInvalid([&] { SceneBatch({a.scene.get()}, -1); }, "SceneBatch threads", "-1");

  SceneBatch batch({a.scene.get(), b.scene.get()}, 2);
  expectInvalid([&] { batch.advance(0.f); }, "SceneBatch::advance dt", "0");
  expectInvalid([&] { batch.advance(std::vector<float>{kTick}); }, "SceneBatch::advance dt", "1 values");
  expectInvalid([&] { batch.advance(std::vector<float>{kTick, -kTick}); }, "SceneBatch::advance dt[1]",
                validate::show(-kTick));
  expectInvalid([&] { batch.scene(2); }, "SceneBatch::scene index", "2");
  // a scene in the middle of its own step
  b.scene->advance(kTick);
  expectInvalid([&] { batch.advance(kTick); }, "SceneBatch scenes[1]", "stepping");
  b.scene->fetchResults();
  EXPECT_EQ(a.scene->time(), 0.0);  // nothing started
  // a batch step still running
  batch.advance(kTick);
  EXPECT_THROW(batch.advance(kTick), Error);
  batch.fetchResults();
  EXPECT_DOUBLE_EQ(a.scene->time(), (double)kTick);
  EXPECT_DOUBLE_EQ(b.scene->time(), (double)(2 * kTick));

  SceneBatch empty({});
  EXPECT_TRUE(empty.step(kTick).empty());
}


// A process that forks after stepping a batch (Python's multiprocessing does, for data
// generation): the child has only the forking thread, none of the batch's runners. Its
// batch must step the scenes there as the parent's does, bit for bit; with the parent's
// runners it waited for them forever (here the alarm ends it after 60 s).
TEST(SceneBatch, ForkedChildStepsLikeItsParent) {
  Batch b = makeBatch(3);
  SceneBatch batch(b.all, 2);
  for (int t = 0; t < 3; ++t) batch.step(kTick);  // the runners are working

  int pipeFd[2];
  ASSERT_EQ(pipe(pipeFd), 0);
  const pid_t child = test::forkChild([&] {
    for (int t = 0; t < 3; ++t) batch.step(kTick);
    return test::writeAll(pipeFd[1], read(b.scenes[1]).x);
  });
  ASSERT_GE(child, 0);
  close(pipeFd[1]);
  for (int t = 0; t < 3; ++t) batch.step(kTick);
  const Result parent = read(b.scenes[1]);
  const std::vector<Vec3f> fromChild = test::readAll<Vec3f>(pipeFd[0], parent.x.size());
  close(pipeFd[0]);
  test::expectChildSucceeded(child);
  ASSERT_EQ(fromChild.size(), parent.x.size());
  EXPECT_EQ(0, std::memcmp(parent.x.data(), fromChild.data(), parent.x.size() * sizeof(Vec3f)));
}

// Forked while a batch step runs (between advance and fetchResults): the scenes are being
// stepped by the parent's runners, so the child's are half stepped. Its fetchResults says
// so instead of waiting for runners it does not have; the parent fetches as usual.
TEST(SceneBatch, ForkedChildRefusesAStepInFlight) {
  Batch b = makeBatch(4);
  SceneBatch batch(b.all, 2);
  batch.advance(kTick);
  const pid_t child = test::forkChild([&] {
    return test::throwsSaying([&] { batch.fetchResults(); }, "forked while a step was running");
  });
  ASSERT_GE(child, 0);
  EXPECT_EQ(batch.fetchResults().size(), 4u);
  test::expectChildSucceeded(child, "1: fetchResults returned, 2: another error");
}

}  // namespace
}  // namespace mpm
