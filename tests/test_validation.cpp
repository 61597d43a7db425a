// Bad input: every public entry point names the field and the value, changes nothing,
// and the scene keeps stepping afterwards.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "mpm/scene.h"

namespace mpm {
namespace {

const float kNaN = std::numeric_limits<float>::quiet_NaN();
const float kInf = std::numeric_limits<float>::infinity();

SceneSettings goodSettings() {
  SceneSettings s;
  s.domain.lower = {-0.5f, 0.f, -0.5f};
  s.domain.upper = {0.5f, 1.f, 0.5f};
  s.dx = 0.05f;
  return s;
}

ParticleObjectDesc goodBlock() {
  ParticleObjectDesc d;
  d.center = {0.f, 0.5f, 0.f};
  d.halfExtents = {0.1f, 0.1f, 0.1f};
  return d;
}

// Runs `bad`, expects InvalidArgument whose field contains `field` and whose message
// contains `value`.
template <class F>
void expectRejected(F bad, const std::string& field, const std::string& value) {
  try {
    bad();
    ADD_FAILURE() << "no error for " << field;
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.field()).find(field), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(value), std::string::npos) << e.what();
  }
}

// A scene with one block that must be unchanged by rejected calls and still step.
struct LiveScene {
  Scene scene{goodSettings()};
  ParticleObjectId id = scene.addParticleObject(goodBlock());
  size_t particles = scene.particleCount(id);
  void expectStillUsable() {
    EXPECT_EQ(scene.particleCount(id), particles);
    const double t = scene.time();
    scene.step(0.01f);
    EXPECT_GT(scene.time(), t);
    std::vector<Vec3f> x;
    scene.readPositions(id, x);
    for (const Vec3f& p : x) ASSERT_TRUE(std::isfinite(p.x + p.y + p.z));
  }
};

TEST(Validation, CellSizeMustBePositiveAndFinite) {
  for (float dx : {0.f, -0.1f, kNaN, kInf}) {
    SceneSettings s = goodSettings();
    s.dx = dx;
    expectRejected([&] { Scene scene(s); }, "SceneSettings.dx", "");
  }
  SceneSettings s = goodSettings();
  s.dx = -0.25f;
  expectRejected([&] { Scene scene(s); }, "SceneSettings.dx", "-0.25");
}

TEST(Validation, DomainMustHavePositiveSize) {
  SceneSettings s = goodSettings();
  s.domain.upper = {0.5f, -1.f, 0.5f};
  expectRejected([&] { Scene scene(s); }, "SceneSettings.domain.upper", "-1");
  s = goodSettings();
  s.domain.lower.x = kNaN;
  expectRejected([&] { Scene scene(s); }, "SceneSettings.domain.lower", "nan");
}

TEST(Validation, MirrorPlanesNeedAGridSolverAndMaterialAboveThem) {
  SceneSettings s = goodSettings();
  s.domain.mirrorLower[2] = true;
  s.solver = SolverType::Mtled;
  expectRejected([&] { Scene scene(s); }, "SceneSettings.domain.mirrorLower[2]", "true");
  s.solver = SolverType::MlsMpm;
  Scene scene(s);
  ParticleObjectDesc d = goodBlock();
  d.center.z = s.domain.mirrorPlane(2, s.dx);  // half of the block below the mirror plane
  expectRejected([&] { scene.addParticleObject(d); }, "ParticleObjectDesc.center", "");
  EXPECT_EQ(scene.particleCount(), 0u);
}

TEST(Validation, GravityAndSubstepPolicyMustBeFinite) {
  SceneSettings s = goodSettings();
  s.gravity.y = kInf;
  expectRejected([&] { Scene scene(s); }, "SceneSettings.gravity", "inf");
  s = goodSettings();
  s.substeps.cflNumber = -0.5f;  // 0 is the solver's default
  expectRejected([&] { Scene scene(s); }, "SceneSettings.substeps.cflNumber", "-0.5");
  s.substeps.cflNumber = kInf;
  expectRejected([&] { Scene scene(s); }, "SceneSettings.substeps.cflNumber", "inf");
  s = goodSettings();
  s.substeps.fixedSubsteps = -3;
  expectRejected([&] { Scene scene(s); }, "SceneSettings.substeps.fixedSubsteps", "-3");
}

// No more fixed substeps than an advance may take (SubstepPolicy::kMaxSubsteps, 1e7).
TEST(Validation, FixedSubstepsAreBounded) {
  SceneSettings s = goodSettings();
  s.substeps.fixedSubsteps = 2000000000;
  expectRejected([&] { Scene scene(s); }, "SceneSettings.substeps.fixedSubsteps", "2000000000");
  s.substeps.fixedSubsteps = 10000001;
  expectRejected([&] { Scene scene(s); }, "SceneSettings.substeps.fixedSubsteps", "10000001");
  s.substeps.fixedSubsteps = 10000000;
  EXPECT_NO_THROW(Scene scene(s));
}

TEST(Validation, YoungsModulusMustBePositive) {
  LiveScene live;
  for (float E : {0.f, -1e4f, kNaN}) {
    ParticleObjectDesc d = goodBlock();
    d.material.youngsModulus = E;
    expectRejected([&] { live.scene.addParticleObject(d); }, "material.youngsModulus", "");
  }
  live.expectStillUsable();
}

// A value that is not a number shows as one: "nan" whatever its sign bit (0 / 0 on x86
// gives the negative one), "inf", "-inf"; the same words the C API and Python show.
TEST(Validation, NonFiniteValuesShowAsNanAndInf) {
  LiveScene live;
  const std::pair<float, const char*> cases[] = {
      {kNaN, "youngsModulus = nan:"}, {-kNaN, "youngsModulus = nan:"}, {kInf, "youngsModulus = inf:"}, {-kInf, "youngsModulus = -inf:"}};
  for (const auto& [E, shown] : cases) {
    ParticleObjectDesc d = goodBlock();
    d.material.youngsModulus = E;
    expectRejected([&] { live.scene.addParticleObject(d); }, "material.youngsModulus", shown);
  }
  live.expectStillUsable();
}

TEST(Validation, PoissonRatioMustLieInOpenInterval) {
  LiveScene live;
  for (float nu : {0.5f, -1.f, 0.7f, kNaN}) {
    ParticleObjectDesc d = goodBlock();
    d.material.poissonRatio = nu;
    expectRejected([&] { live.scene.addParticleObject(d); }, "material.poissonRatio", "");
  }
  live.expectStillUsable();
}

TEST(Validation, DensityMustBePositive) {
  LiveScene live;
  ParticleObjectDesc d = goodBlock();
  d.material.density = -5.f;
  expectRejected([&] { live.scene.addParticleObject(d); }, "material.density", "-5");
  live.expectStillUsable();
}

TEST(Validation, ObjectSizesMustBePositive) {
  LiveScene live;
  ParticleObjectDesc d = goodBlock();
  d.halfExtents.y = 0.f;
  expectRejected([&] { live.scene.addParticleObject(d); }, "ParticleObjectDesc.halfExtents", "0");
  d = goodBlock();
  d.primitive = PrimitiveType::Sphere;
  d.radius = -0.1f;
  expectRejected([&] { live.scene.addParticleObject(d); }, "ParticleObjectDesc.radius", "-0.1");
  d = goodBlock();
  d.particlesPerCellAxis = 0;
  expectRejected([&] { live.scene.addParticleObject(d); }, "particlesPerCellAxis", "0");
  d = goodBlock();
  d.center.z = kNaN;
  expectRejected([&] { live.scene.addParticleObject(d); }, "ParticleObjectDesc.center", "nan");
  live.expectStillUsable();
}

TEST(Validation, ParticlesOutsideDomainAreRejected) {
  LiveScene live;
  const size_t before = live.scene.particleCount();
  ParticleObjectDesc d = goodBlock();
  d.center = {0.45f, 0.5f, 0.f};  // sticks out of x = 0.5
  expectRejected([&] { live.scene.addParticleObject(d); }, "ParticleObjectDesc.center", "0.45");
  d.center = {0.f, 0.02f, 0.f};  // inside the floor wall
  expectRejected([&] { live.scene.addParticleObject(d); }, "ParticleObjectDesc.center", "0.02");
  EXPECT_EQ(live.scene.particleCount(), before) << "nothing was added";
  live.expectStillUsable();
}

TEST(Validation, TimeStepMustBePositiveAndFinite) {
  LiveScene live;
  for (float dt : {0.f, -0.01f, kNaN, kInf})
    expectRejected([&] { live.scene.advance(dt); }, "dt", "");
  live.expectStillUsable();
}

TEST(Validation, StaleHandleIsRejected) {
  LiveScene live;
  const ParticleObjectId other = live.scene.addParticleObject(goodBlock());
  live.scene.removeParticleObject(other);
  EXPECT_FALSE(live.scene.isValid(other));
  std::vector<Vec3f> x;
  expectRejected([&] { live.scene.readPositions(other, x); }, "ParticleObjectId", "");
  expectRejected([&] { live.scene.removeParticleObject(other); }, "ParticleObjectId", "");
  // the slot is reused with a new generation; the old handle stays stale
  const ParticleObjectId again = live.scene.addParticleObject(goodBlock());
  EXPECT_EQ(again.index, other.index);
  EXPECT_FALSE(live.scene.isValid(other));
  EXPECT_TRUE(live.scene.isValid(again));
  live.expectStillUsable();
}

TEST(Validation, ChangingSceneDuringStepIsRefused) {
  LiveScene live;
  live.scene.advance(0.01f);
  EXPECT_THROW(live.scene.addParticleObject(goodBlock()), Error);
  EXPECT_THROW(live.scene.advance(0.01f), Error);
  live.scene.fetchResults();
  live.expectStillUsable();
}

// The grid's block tables cover the whole domain: a domain far larger than dx is refused
// up front with the memory it would take, not by an overflow or an allocation failure.
TEST(Validation, GridTooLargeForMemoryIsRefused) {
  for (float size : {100.f, 16.f}) {  // 100 m: beyond 16384 cells an axis; 16 m: 16000
    SceneSettings s = goodSettings();
    s.domain.lower = {0.f, 0.f, 0.f};
    s.domain.upper = {size, size, size};
    s.dx = 0.001f;
    try {
      Scene scene(s);
      ADD_FAILURE() << "a " << size << " m domain at dx = 1 mm accepted";
    } catch (const InvalidArgument& e) {
      EXPECT_EQ(e.field(), "SceneSettings.dx") << e.what();
      EXPECT_NE(std::string(e.what()).find(" GB"), std::string::npos) << e.what();
    }
  }
  // the bytes stated are those the CPU's tables take, 12 a block (three 4-byte tables):
  // 1024 x 1024 x 257 blocks of 4^3 nodes at dx = 1 m, 3.23 GB
  SceneSettings wide = goodSettings();
  wide.domain.lower = {0.f, 0.f, 0.f};
  wide.domain.upper = {4095.f, 4095.f, 1027.f};
  wide.dx = 1.f;
  wide.backend = Backend::Cpu;
  expectRejected([&] { Scene scene(wide); }, "SceneSettings.dx", "gives 2.69e+08 grid blocks");
  expectRejected([&] { Scene scene(wide); }, "SceneSettings.dx", "would take 3.23 GB of memory");
  // MTLED has no grid: only the per-axis bound applies
  SceneSettings s = goodSettings();
  s.domain.lower = {0.f, 0.f, 0.f};
  s.domain.upper = {16.f, 16.f, 16.f};
  s.dx = 0.001f;
  s.solver = SolverType::Mtled;
  EXPECT_NO_THROW(Scene scene(s));
}

// The particle count is estimated before any particle is made.
TEST(Validation, ParticleCountIsBounded) {
  LiveScene live;
  ParticleObjectDesc d = goodBlock();
  d.particlesPerCellAxis = 1000;  // 6.4e10 particles in a 0.2 m box at dx = 0.05
  expectRejected([&] { live.scene.addParticleObject(d); }, "ParticleObjectDesc.particlesPerCellAxis", "1000");
  d = goodBlock();
  d.particleSpacing = 1e-5f;
  expectRejected([&] { live.scene.addParticleObject(d); }, "ParticleObjectDesc.particleSpacing", "1e-05");
  live.expectStillUsable();
}

// An enum value outside its list is refused, not read as another choice.
TEST(Validation, EnumValuesOutsideTheirListAreRefused) {
  const auto settingsRejected = [](auto change, const std::string& field, const char* value = "99") {
    SceneSettings s = goodSettings();
    change(s);
    expectRejected([&] { Scene scene(s); }, field, value);
  };
  settingsRejected([](SceneSettings& s) { s.solver = static_cast<SolverType>(99); }, "SceneSettings.solver");
  settingsRejected([](SceneSettings& s) { s.domain.wallMode = static_cast<WallMode>(99); },
                   "SceneSettings.domain.wallMode");
  settingsRejected([](SceneSettings& s) { s.backend = static_cast<Backend>(99); }, "SceneSettings.backend");
  settingsRejected([](SceneSettings& s) { s.backend = static_cast<Backend>(-1); }, "SceneSettings.backend", "-1");

  LiveScene live;
  ParticleObjectDesc d = goodBlock();
  d.material.model = static_cast<MaterialModel>(99);
  expectRejected([&] { live.scene.addParticleObject(d); }, "ParticleObjectDesc.material.model", "99");
  d = goodBlock();
  d.primitive = static_cast<PrimitiveType>(99);
  expectRejected([&] { live.scene.addParticleObject(d); }, "ParticleObjectDesc.primitive", "99");
  ShapeDesc shape;
  shape.parts = {Geometry::sphere(0.05f)};
  shape.pose.position = {0.3f, 0.8f, 0.3f};
  shape.parts[0].type = static_cast<GeometryType>(99);
  expectRejected([&] { live.scene.addShape(shape); }, "ShapeDesc.parts[0].type", "99");
  shape.parts[0].type = GeometryType::Sphere;
  shape.contact.mode = static_cast<ContactMode>(99);
  expectRejected([&] { live.scene.addShape(shape); }, "ShapeDesc.contact.mode", "99");
  live.expectStillUsable();
}

// The fastest a shape may move: the speed that alone needs the substep limit (1e7) of
// substeps per simulated second at the CFL number in force (shapes.h).
float shapeSpeedLimit(const SceneSettings& s) { return 1e7f * s.substeps.cflFor(s.solver) * s.dx; }

ShapeDesc movingSphere(Vec3f v, Vec3f w = {}) {
  ShapeDesc d;
  d.parts = {Geometry::sphere(0.05f)};
  d.pose.position = {0.3f, 0.8f, 0.3f};
  d.linearVelocity = v;
  d.angularVelocity = w;
  return d;
}

// A shape too fast for the grid is refused where it is given, naming its field, not by the
// next advance naming the tissue's material.
TEST(Validation, ShapeFasterThanTheGridIsRefusedWhereGiven) {
  LiveScene live;
  const float limit = shapeSpeedLimit(live.scene.settings());
  expectRejected([&] { live.scene.addShape(movingSphere({1e30f, 0.f, 0.f})); }, "ShapeDesc.linearVelocity", "1e+30");
  expectRejected([&] { live.scene.addShape(movingSphere({1.01f * limit, 0.f, 0.f})); }, "ShapeDesc.linearVelocity",
                 "");
  // the sphere's rim, 0.05 m from its centre, at 1.01 times the limit
  expectRejected([&] { live.scene.addShape(movingSphere({}, {0.f, 0.f, 1.01f * limit / 0.05f})); },
                 "ShapeDesc.angularVelocity", "");
  const ShapeId shape = live.scene.addShape(movingSphere({0.99f * limit, 0.f, 0.f}));
  EXPECT_EQ(shape.index, 0u);  // nothing was added before it
  ShapeState fast = live.scene.shapeState(shape);
  fast.linearVelocity = {0.f, -1e30f, 0.f};
  expectRejected([&] { live.scene.setShapeState(shape, fast); }, "ShapeState.linearVelocity", "-1e+30");
  fast.linearVelocity = {};
  fast.angularVelocity = {1e30f, 0.f, 0.f};
  expectRejected([&] { live.scene.setShapeState(shape, fast); }, "ShapeState.angularVelocity", "1e+30");
  EXPECT_EQ(live.scene.shapeState(shape).linearVelocity.x, 0.99f * limit);  // unchanged
  fast.angularVelocity = {};
  live.scene.setShapeState(shape, fast);
  live.expectStillUsable();
}

TEST(Validation, SlicerOrCurveFasterThanTheGridIsRefusedWhereGiven) {
  LiveScene live;
  QuadSlicerDesc blade;
  blade.pose.position = {0.3f, 0.8f, 0.3f};
  blade.linearVelocity = {0.f, -1e30f, 0.f};
  expectRejected([&] { live.scene.addSlicer(blade); }, "QuadSlicerDesc.linearVelocity", "-1e+30");
  blade.linearVelocity = {};
  const SlicerId slicer = live.scene.addSlicer(blade);
  ShapeState fast = live.scene.slicerState(slicer);
  fast.angularVelocity = {0.f, 0.f, 1e30f};
  expectRejected([&] { live.scene.setSlicerState(slicer, fast); }, "ShapeState.angularVelocity", "1e+30");

  ArcDesc needle;
  needle.pose.position = {-0.3f, 0.8f, 0.3f};
  // its tip, radius from the frame's origin, at twice the limit
  needle.angularVelocity = {0.f, 0.f, 2.f * shapeSpeedLimit(live.scene.settings()) / needle.radius};
  expectRejected([&] { live.scene.addCurve(needle); }, "ArcDesc.angularVelocity", "");
  needle.angularVelocity = {};
  const CurveId arc = live.scene.addCurve(needle);
  fast = live.scene.curveState(arc);
  fast.linearVelocity = {1e30f, 0.f, 0.f};
  expectRejected([&] { live.scene.setCurveState(arc, fast); }, "ShapeState.linearVelocity", "1e+30");

  LineSegmentsDesc thread;
  thread.points = {{-0.3f, 0.8f, -0.3f}, {-0.2f, 0.8f, -0.3f}};
  thread.velocities = {{0.f, 0.f, 0.f}, {0.f, 0.f, 1e30f}};
  expectRejected([&] { live.scene.addCurve(thread); }, "LineSegmentsDesc.velocities[1]", "1e+30");
  thread.velocities.clear();
  const CurveId wire = live.scene.addCurve(thread);
  expectRejected([&] { live.scene.setCurvePoints(wire, thread.points, {{1e30f, 0.f, 0.f}, {}}); },
                 "LineSegmentsDesc.velocities[0]", "1e+30");
  EXPECT_EQ(live.scene.curveState(arc).linearVelocity.x, 0.f);
  live.expectStillUsable();
}

// An advance refused for too many substeps names what set the substep: here a shape
// within the limit but too fast for a 10 s advance, not the soft tissue's material.
TEST(Validation, SubstepRefusalNamesTheFastestShape) {
  LiveScene live;
  live.scene.addShape(movingSphere({0.f, 0.f, 0.5f * shapeSpeedLimit(live.scene.settings())}));
  try {
    live.scene.step(10.f);
    ADD_FAILURE() << "an advance of 5e7 substeps was taken";
  } catch (const InvalidArgument& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("shape 0's ShapeState.linearVelocity"), std::string::npos) << m;
    EXPECT_EQ(m.find("youngsModulus"), std::string::npos) << m;
  }
  EXPECT_EQ(live.scene.time(), 0.0);
}

// A blade sampled too finely is refused naming the slicer's field, not the distance
// grid builder's "cellSize".
TEST(Validation, BladeSampleSpacingIsNamedAsTheSlicers) {
  LiveScene live;
  MeshSlicerDesc blade;
  blade.blade.vertices = {{-0.05f, 0.f, 0.f}, {0.05f, 0.f, 0.f}, {0.f, 0.03f, 0.f}};
  blade.blade.indices = {0, 1, 2};
  blade.pose.position = {0.3f, 0.8f, 0.3f};
  blade.sampleSpacing = 1e-6f;  // 1e5 samples along the edge
  expectRejected([&] { live.scene.addSlicer(blade); }, "MeshSlicerDesc.sampleSpacing", "1e-06");
  blade.sampleSpacing = 0.f;  // a quarter of dx
  EXPECT_EQ(live.scene.addSlicer(blade).index, 0u);
  live.expectStillUsable();
}

}  // namespace
}  // namespace mpm
