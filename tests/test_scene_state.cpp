// The scene's state across its lifecycle: what adding objects, reading during a step, a
// failed step, an advance beyond the substep limit and MTLED's model do to it.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "mpm/scene.h"

namespace mpm {
namespace {

SceneSettings settings(SolverType solver) {
  SceneSettings s;
  s.domain.lower = {-0.5f, 0.f, -0.5f};
  s.domain.upper = {0.5f, 1.f, 0.5f};
  s.dx = 0.05f;
  s.solver = solver;
  s.backend = Backend::Cpu;
  return s;
}

ParticleObjectDesc block(Vec3f center, float half = 0.1f) {
  ParticleObjectDesc d;
  d.center = center;
  d.halfExtents = {half, half, half};
  return d;
}

std::vector<Vec3f> positions(const Scene& scene, ParticleObjectId id) {
  std::vector<Vec3f> x;
  scene.readPositions(id, x);
  return x;
}

void expectSamePositions(const std::vector<Vec3f>& a, const std::vector<Vec3f>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].x, b[i].x) << "particle " << i;
    ASSERT_EQ(a[i].y, b[i].y) << "particle " << i;
    ASSERT_EQ(a[i].z, b[i].z) << "particle " << i;
  }
}

// Defect 1: MTLED kept its nodes' motion on the device and the host copy at creation;
// adding an object rebuilt the model from the host copy.
TEST(SceneState, AddingAnMtledObjectKeepsTheOthersMotion) {
  SceneSettings s = settings(SolverType::Mtled);
  s.gravity = {0.f, 0.f, 0.f};
  Scene scene(s);
  ParticleObjectDesc moving = block({-0.2f, 0.5f, 0.f});
  moving.velocity = {1.f, 0.f, 0.f};
  const ParticleObjectId a = scene.addParticleObject(moving);
  const std::vector<Vec3f> start = positions(scene, a);
  scene.step(0.05f);
  const std::vector<Vec3f> stepped = positions(scene, a);
  ASSERT_NEAR(stepped[0].x - start[0].x, 0.05f, 1e-3f) << "the object moved";

  scene.addParticleObject(block({0.25f, 0.5f, 0.f}));
  expectSamePositions(positions(scene, a), stepped);
  scene.step(0.05f);
  const std::vector<Vec3f> after = positions(scene, a);
  EXPECT_NEAR(after[0].x - start[0].x, 0.1f, 2e-3f) << "it moves on from where it was";
}

// Defect 2: every read of what the worker thread writes is refused during a step.
TEST(SceneState, ReadsOfStepResultsAreRefusedDuringAStep) {
  Scene scene(settings(SolverType::MlsMpm));
  scene.addParticleObject(block({0.f, 0.5f, 0.f}));
  scene.advance(0.01f);
  const auto refused = [](auto call, const char* name) {
    try {
      call();
      ADD_FAILURE() << name << " answered during a step";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("a step is running"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  };
  refused([&] { scene.time(); }, "time");
  refused([&] { scene.timings(); }, "timings");
  refused([&] { scene.resetTimings(); }, "resetTimings");
  refused([&] { scene.memoryBytes(); }, "memoryBytes");
  scene.fetchResults();
  EXPECT_NEAR(scene.time(), 0.01, 1e-9);
  EXPECT_GT(scene.timings().substeps, 0);
  EXPECT_GT(scene.memoryBytes(), 0u);
  scene.resetTimings();
  EXPECT_EQ(scene.timings().substeps, 0);
}

// Defect 3: a step that throws leaves the scene as it was before that advance.
TEST(SceneState, AFailedStepLeavesTheSceneAsBefore) {
  SceneSettings s = settings(SolverType::MlsMpm);
  s.substeps.fixedSubsteps = 1;
  Scene scene(s);
  const ParticleObjectId good = scene.addParticleObject(block({0.f, 0.5f, 0.f}));
  ShapeDesc tool;
  tool.parts = {Geometry::sphere(0.05f)};
  tool.pose.position = {0.3f, 0.8f, 0.3f};
  tool.linearVelocity = {0.f, 0.f, -0.1f};
  const ShapeId shape = scene.addShape(tool);
  scene.step(0.002f);

  // thrown so fast that it leaves the grid within the one substep
  ParticleObjectDesc thrown = block({0.f, 0.5f, 0.f}, 0.05f);
  thrown.center = {-0.3f, 0.3f, 0.f};
  thrown.velocity = {0.f, 1000.f, 0.f};
  const ParticleObjectId bad = scene.addParticleObject(thrown);
  const double t = scene.time();
  const std::vector<Vec3f> goodBefore = positions(scene, good), badBefore = positions(scene, bad);
  const ShapeState shapeBefore = scene.shapeState(shape);
  scene.advance(0.002f);
  EXPECT_THROW(scene.fetchResults(), SimulationDiverged);

  EXPECT_EQ(scene.time(), t);
  expectSamePositions(positions(scene, good), goodBefore);
  expectSamePositions(positions(scene, bad), badBefore);
  EXPECT_EQ(scene.shapeState(shape).pose.position.z, shapeBefore.pose.position.z);
  std::vector<Vec3f> v;
  scene.readVelocities(bad, v);
  EXPECT_EQ(v[0].y, 1000.f);

  // the same advance fails again, the same way; without the thrown object it steps
  EXPECT_THROW(scene.step(0.002f), SimulationDiverged);
  EXPECT_EQ(scene.time(), t);
  scene.removeParticleObject(bad);
  scene.step(0.002f);
  EXPECT_GT(scene.time(), t);
  EXPECT_LT(positions(scene, good)[0].y, goodBefore[0].y) << "it falls on";
}

// An advance that diverges after every halving of its substep (SceneSettings::recovery)
// is tried four times, each from the state the last one put back: the particles kept once
// the scene starts the advance (and reordered by grid block in the same pass) must still be
// the state before it at the last failure. The scene then runs on as its twin, which never
// tried the advance, to the last bit. Twice: with particles crossing blocks, which the
// advance's sort moves (the copy holds every field), and with every particle in block order
// already (the copy holds the state fields; the model fields stay where they are).
TEST(SceneState, AnAdvanceFailingAfterEveryHalvingLeavesNoTrace) {
  for (const bool moving : {true, false}) {
    SCOPED_TRACE(moving ? "particles crossing blocks" : "particles in block order");
    SceneSettings s = settings(SolverType::MlsMpm);
    s.substeps.fixedSubsteps = 1;
    s.recovery.enabled = true;
    s.recovery.maxHalvings = 3;
    Scene tried(s), twin(s);
    // at rest: within one grid block, after the other object's blocks
    ParticleObjectDesc thrown = block({0.f, 0.5f, 0.f}, moving ? 0.05f : 0.025f);
    thrown.center = {moving ? -0.3f : 0.25f, 0.3f, 0.f};
    thrown.velocity = {0.f, 1000.f, 0.f};  // 2 m in the advance: out of the grid however it is cut
    ParticleObjectId good{}, bad{};
    for (Scene* scene : {&tried, &twin}) {
      ParticleObjectDesc other = block({moving ? 0.1f : -0.1f, 0.5f, 0.f});
      if (moving) other.velocity = {4.f, 0.f, 0.f};  // particles cross blocks each step
      good = scene->addParticleObject(other);
      for (int i = 0; i < 5; ++i) scene->step(0.002f);
      bad = scene->addParticleObject(thrown);
    }
    const std::vector<Vec3f> before = positions(tried, good);
    EXPECT_THROW(tried.step(0.002f), SimulationDiverged);
    expectSamePositions(positions(tried, good), before);
    expectSamePositions(positions(tried, bad), positions(twin, bad));
    for (Scene* scene : {&tried, &twin}) {
      scene->removeParticleObject(bad);
      for (int i = 0; i < 5; ++i) scene->step(0.002f);
    }
    expectSamePositions(positions(tried, good), positions(twin, good));
    EXPECT_EQ(tried.time(), twin.time());
  }
}

// Scene::step runs the advance on the calling thread, advance() on the scene's worker: the
// same step either way, to the bit, with two threads (the calling thread leads the team),
// a moving tool, the energy account (which keeps the shapes' states from before the
// advance) and the reports; then the scene stepped one way goes on stepping the other.
TEST(SceneState, StepOnTheCallingThreadIsTheWorkersAdvance) {
  for (const SolverType solver : {SolverType::MlsMpm, SolverType::PbMpm}) {
    SCOPED_TRACE(solver == SolverType::MlsMpm ? "MLS-MPM" : "PB-MPM");
    SceneSettings s = settings(solver);
    s.cpuThreads = 2;
    s.energyCheck.enabled = true;
    Scene stepped(s), advanced(s);
    ParticleObjectId id{};
    ShapeId tool{};
    for (Scene* scene : {&stepped, &advanced}) {
      ParticleObjectDesc b = block({0.f, 0.3f, 0.f}, 0.15f);
      b.velocity = {0.5f, -1.f, 0.f};
      id = scene->addParticleObject(b);
      ShapeDesc d;
      d.parts = {Geometry::sphere(0.06f)};
      d.pose.position = {0.f, 0.5f, 0.f};
      d.linearVelocity = {0.f, -2.f, 0.f};
      tool = scene->addShape(d);
    }
    for (int i = 0; i < 12; ++i) {
      const StepReport a = stepped.step(1.f / 240);
      advanced.advance(1.f / 240);
      const StepReport b = advanced.fetchResults();
      ASSERT_EQ(a.substeps, b.substeps) << "step " << i;
      ASSERT_EQ(a.substepDt, b.substepDt);
      ASSERT_EQ(a.activeBlocks, b.activeBlocks);
      ASSERT_EQ(a.energy.kinetic, b.energy.kinetic);
      ASSERT_EQ(a.energy.work, b.energy.work);
      ASSERT_GT(a.energy.kinetic, 0.0);
      expectSamePositions(positions(stepped, id), positions(advanced, id));
      const ShapeImpulse ia = stepped.shapeImpulse(tool), ib = advanced.shapeImpulse(tool);
      ASSERT_EQ(ia.linear.y, ib.linear.y) << "step " << i;
    }
    EXPECT_NE(stepped.shapeImpulse(tool).linear.y, 0.f) << "the tool never touched the block";
    stepped.advance(1.f / 240);
    stepped.fetchResults();
    advanced.step(1.f / 240);
    expectSamePositions(positions(stepped, id), positions(advanced, id));
  }
}

// The step worker hands its error to the caller and keeps no reference to it: the caller
// reads the exception and destroys it. Run many times so that ThreadSanitizer
// (scripts/sanitize.sh) sees the interleaving in which the caller is done with the error
// before the worker has let go of the job; with std::packaged_task the worker then
// destroyed the exception, which TSan reported as a race on its vptr.
TEST(SceneState, EveryFailedStepHandsItsErrorToTheCaller) {
  SceneSettings s = settings(SolverType::MlsMpm);
  s.substeps.fixedSubsteps = 1;
  Scene scene(s);
  ParticleObjectDesc thrown = block({0.f, 0.5f, 0.f}, 0.05f);
  thrown.velocity = {0.f, 1000.f, 0.f};  // leaves the grid within the one substep
  scene.addParticleObject(thrown);
  for (int i = 0; i < 200; ++i) {
    scene.advance(0.002f);
    try {
      scene.fetchResults();
      ADD_FAILURE() << "advance " << i << " did not fail";
    } catch (const SimulationDiverged& e) {
      ASSERT_NE(std::string(e.what()).find("left the grid"), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(scene.time(), 0.0);
}

// Defect 3 for MTLED, whose nodes live in its own system: a diverging substep.
TEST(SceneState, AFailedMtledStepLeavesTheSceneAsBefore) {
  SceneSettings s = settings(SolverType::Mtled);
  s.substeps.fixedSubsteps = 200;  // 0.1 s each: far beyond the critical step
  Scene scene(s);
  ParticleObjectDesc spinning = block({0.f, 0.5f, 0.f});
  spinning.angularVelocity = {0.f, 0.f, 1.f};
  const ParticleObjectId id = scene.addParticleObject(spinning);
  const std::vector<Vec3f> before = positions(scene, id);
  EXPECT_THROW(scene.step(20.f), SimulationDiverged);
  EXPECT_EQ(scene.time(), 0.0);
  expectSamePositions(positions(scene, id), before);
}

// Defect 3 when the energy check fails, after the shapes have been read back: they are
// put back too. A spinning block at 13 times its CFL step (as test_stability's).
TEST(SceneState, AFailedEnergyCheckPutsTheShapesBack) {
  SceneSettings s = settings(SolverType::MlsMpm);
  s.gravity = {0.f, 0.f, 0.f};
  s.energyCheck.enabled = true;
  s.divergenceCheck.enabled = false;  // its volume bound would see this blow-up first
  s.substeps.fixedSubsteps = 1;
  Scene scene(s);
  ParticleObjectDesc spinning = block({0.f, 0.5f, 0.f});
  spinning.angularVelocity = {0.f, 0.f, 5.f};
  const ParticleObjectId id = scene.addParticleObject(spinning);
  ShapeDesc tool;
  tool.parts = {Geometry::sphere(0.05f)};
  tool.pose.position = {0.3f, 0.8f, 0.3f};
  tool.linearVelocity = {0.f, 0.f, -0.1f};
  const ShapeId shape = scene.addShape(tool);
  const float dt = 4.f * s.dx / std::sqrt(1e4f * 0.7f / (1.3f * 0.4f) / 1000.f);
  for (int step = 0; step < 50; ++step) {
    const double t = scene.time();
    const std::vector<Vec3f> x = positions(scene, id);
    const Vec3f at = scene.shapeState(shape).pose.position;
    try {
      scene.step(dt);
    } catch (const SimulationDiverged& e) {
      ASSERT_NE(std::string(e.what()).find("energy grew"), std::string::npos) << e.what();
      EXPECT_EQ(scene.time(), t);
      expectSamePositions(positions(scene, id), x);
      EXPECT_EQ(scene.shapeState(shape).pose.position.z, at.z);
      return;
    }
  }
  FAIL() << "50 steps of " << dt << " s ran without an error";
}

// Defect 7: an advance that needs more substeps than the limit is refused before it starts.
TEST(SceneState, AdvanceBeyondTheSubstepLimitIsRefused) {
  Scene scene(settings(SolverType::MlsMpm));
  ParticleObjectDesc stiff = block({0.f, 0.5f, 0.f});
  stiff.material.youngsModulus = 1e30f;  // CFL substep 4e-16 s
  const ParticleObjectId id = scene.addParticleObject(stiff);
  const std::vector<Vec3f> before = positions(scene, id);
  try {
    scene.advance(0.001f);
    scene.fetchResults();
    ADD_FAILURE() << "an advance of 0.001 s at E = 1e30 Pa was taken";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("substeps"), std::string::npos) << m;
    EXPECT_NE(m.find("youngsModulus = 1e+30"), std::string::npos) << m;
  }
  EXPECT_EQ(scene.time(), 0.0);
  expectSamePositions(positions(scene, id), before);
  scene.removeParticleObject(id);
  scene.addParticleObject(block({0.f, 0.5f, 0.f}));
  scene.step(0.001f);
  EXPECT_GT(scene.time(), 0.0);
}

// Defect 9: MTLED's model is built when the object is added, so its errors come from there.
TEST(SceneState, MtledModelErrorsComeFromAddParticleObject) {
  SceneSettings s = settings(SolverType::Mtled);
  s.mtled.supportNodes = 27;
  Scene scene(s);
  const ParticleObjectId id = scene.addParticleObject(block({0.f, 0.5f, 0.f}));
  scene.step(0.01f);
  const std::vector<Vec3f> before = positions(scene, id);
  const size_t count = scene.particleCount();
  ParticleObjectDesc tiny = block({0.3f, 0.5f, 0.f}, 0.0125f);  // 2 x 2 x 2 nodes, fewer than 27
  try {
    scene.addParticleObject(tiny);
    ADD_FAILURE() << "an object of 8 nodes accepted with 27 support nodes";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("27"), std::string::npos) << e.what();
  }
  EXPECT_EQ(scene.particleCount(), count);
  expectSamePositions(positions(scene, id), before);
  scene.step(0.01f);
  EXPECT_NEAR(scene.time(), 0.02, 1e-9);
}

// Defect 9: MTLED objects report their deformation gradient at the nodes. A spinning block
// keeps its shape: F is the rotation it has turned by.
TEST(SceneState, MtledDeformationGradientsFollowTheMotion) {
  SceneSettings s = settings(SolverType::Mtled);
  s.gravity = {0.f, 0.f, 0.f};
  Scene scene(s);
  ParticleObjectDesc spinning = block({0.f, 0.5f, 0.f});
  spinning.angularVelocity = {0.f, 0.f, 1.f};
  const ParticleObjectId id = scene.addParticleObject(spinning);
  std::vector<Mat3f> F;
  scene.readDeformationGradients(id, F);
  ASSERT_EQ(F.size(), scene.particleCount(id));
  EXPECT_EQ(F[0].m[0][1], 0.f);
  scene.step(0.1f);  // 0.1 rad about z
  scene.readDeformationGradients(id, F);
  const float c = std::cos(0.1f), sn = std::sin(0.1f);
  for (size_t i = 0; i < F.size(); ++i) {
    ASSERT_NEAR(F[i].m[0][0], c, 0.01f) << "node " << i;
    ASSERT_NEAR(F[i].m[0][1], -sn, 0.01f) << "node " << i;
    ASSERT_NEAR(F[i].m[1][0], sn, 0.01f) << "node " << i;
    ASSERT_NEAR(F[i].m[1][1], c, 0.01f) << "node " << i;
    ASSERT_NEAR(F[i].m[2][2], 1.f, 0.01f) << "node " << i;
  }
}

}  // namespace
}  // namespace mpm
