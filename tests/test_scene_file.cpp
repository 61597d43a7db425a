// Scene files (mpm_bullet/scene_file.h): every scene in assets/scenes/ loads and runs, every
// malformed case names its key path, and a file maps its keys onto the same physics as the
// equivalent C++ setup.
#include <gtest/gtest.h>

#include <btBulletDynamicsCommon.h>
#include <BulletDynamics/Featherstone/btMultiBody.h>
#include <BulletDynamics/Featherstone/btMultiBodyConstraintSolver.h>
#include <BulletDynamics/Featherstone/btMultiBodyDynamicsWorld.h>
#include <BulletDynamics/Featherstone/btMultiBodyPoint2Point.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "mpm_bullet/coupler.h"
#include "mpm_bullet/scene_file.h"
#include "mpm_bullet/suture.h"
#include "ply_read.h"
#include "test_paths.h"

namespace {

using mpm::bullet::LoadedScene;

std::string readText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The message of the InvalidArgument that loading `json` throws ("" if none).
std::string loadError(const std::string& json) {
  try {
    LoadedScene::fromString(json, mpm::test::assetPath("scenes"));
  } catch (const mpm::InvalidArgument& e) {
    return e.what();
  }
  return "";
}

// --- every scene file, coarse: loads and runs two frames -------------------------------

struct SceneCase {
  const char* file;
  const char* coarse;  // merge patch: a coarser grid and shorter frames, so each runs in seconds
};

class SceneFiles : public ::testing::TestWithParam<SceneCase> {};

TEST_P(SceneFiles, LoadsAndRunsTwoFrames) {
  const SceneCase c = GetParam();
  auto loaded = LoadedScene::fromFile(mpm::test::assetPath(std::string("scenes/") + c.file), c.coarse);
  ASSERT_GT(loaded->scene().particleCount(), 0u);
  const std::string header = loaded->csvHeader();
  for (int f = 0; f < 2; ++f) loaded->advanceFrame();
  EXPECT_EQ(loaded->frame(), 2);
  EXPECT_NEAR(loaded->scene().time(), 2 * loaded->frameTime(), 1e-4 * loaded->frameTime());
  // the CSV row has a value for every header column
  const std::string row = loaded->csvRow();
  EXPECT_EQ(std::count(row.begin(), row.end(), ','), std::count(header.begin(), header.end(), ','));
  const std::string png = testing::TempDir() + "/scene_file_" + c.file + ".png";
  loaded->writePng(png);
  EXPECT_TRUE(std::filesystem::exists(png));
}

// the patches keep each scene's layout and only coarsen it (dx, frame length, picture size)
INSTANTIATE_TEST_SUITE_P(
    AssetsScenes, SceneFiles,
    ::testing::Values(SceneCase{"block_drop.json", R"({"settings": {"dx": 0.0625, "cpuThreads": 1},
                                                      "output": {"camera": {"width": 160, "height": 100}}})"},
                      SceneCase{"coupling.json", R"({"settings": {"dx": 0.02, "cpuThreads": 1},
                                                    "output": {"camera": {"width": 160, "height": 100}}})"},
                      SceneCase{"cutting.json", R"({"settings": {"dx": 0.01, "cpuThreads": 1},
                                                   "output": {"camera": {"width": 160, "height": 100}}})"},
                      SceneCase{"suturing.json", R"({"settings": {"dx": 0.005, "cpuThreads": 1},
                                                    "output": {"frameTime": 0.0010416667,
                                                               "camera": {"width": 160, "height": 100}}})"}),
    [](const auto& info) { return std::string(info.param.file).substr(0, std::string(info.param.file).find('.')); });

TEST(SceneFile, EveryFileInAssetsScenesIsTested) {
  // a scene added to assets/scenes/ needs its row above
  std::vector<std::string> files;
  for (const auto& e : std::filesystem::directory_iterator(mpm::test::assetPath("scenes")))
    if (e.path().extension() == ".json" && e.path().filename() != "scene.schema.json")
      files.push_back(e.path().filename().string());
  std::sort(files.begin(), files.end());
  EXPECT_EQ(files, (std::vector<std::string>{"block_drop.json", "coupling.json", "cutting.json", "suturing.json"}));
}

// --- malformed files: each names its key path ------------------------------------------

TEST(SceneFileErrors, EveryBadCaseNamesItsKeyPath) {
  // tests/scene_files/bad/NAME.json and the message it must give, NAME.expected (the schema
  // test, tests/scene_files/check_scene_files.py, checks the schema refuses them as well)
  int cases = 0;
  for (const auto& e : std::filesystem::directory_iterator(mpm::test::sourcePath("tests/scene_files/bad"))) {
    if (e.path().extension() != ".json") continue;
    ++cases;
    std::string expected = readText(std::filesystem::path(e.path()).replace_extension(".expected").string());
    while (!expected.empty() && (expected.back() == '\n' || expected.back() == '\r')) expected.pop_back();
    ASSERT_FALSE(expected.empty()) << e.path();
    try {
      LoadedScene::fromFile(e.path().string());
      ADD_FAILURE() << e.path() << " loaded";
    } catch (const mpm::InvalidArgument& error) {
      EXPECT_NE(std::string(error.what()).find(expected), std::string::npos)
          << e.path() << ": got \"" << error.what() << "\", expected \"" << expected << "\"";
    }
  }
  EXPECT_GE(cases, 10);
}

constexpr char kDomain[] = R"("settings": {"domain": {"lower": [-0.2, -0.1, -0.2], "upper": [0.2, 0.3, 0.2]}, "dx": 0.04})";

TEST(SceneFileErrors, OutOfRangeMaterialIsTheLibrarysMessageAtTheKeyPath) {
  const std::string json = std::string("{") + kDomain + R"(, "objects": [
      {"center": [0, 0.06, 0], "halfExtents": [0.05, 0.05, 0.05]},
      {"center": [0, 0.18, 0], "halfExtents": [0.04, 0.04, 0.04], "material": {"poissonRatio": 0.7}}]})";
  EXPECT_EQ(loadError(json), "objects[1].material.poissonRatio = 0.7: must lie in (-1, 0.5)");
}

// Text that is no JSON is refused as such (fuzz_scene_file found nlohmann's exceptions
// escaping the loader: mpm_run ended in std::terminate).
TEST(SceneFileErrors, TextThatIsNoJsonIsRefused) {
  const std::string message = loadError("{\"settings\": ");
  EXPECT_NE(message.find("(not JSON)"), std::string::npos) << message;
}

// A number beyond a double (nlohmann's out_of_range, not a parse error) is named at its key
// path with its text, in an object and in an array.
TEST(SceneFileErrors, NumberBeyondADoubleNamesItsKey) {
  EXPECT_EQ(loadError(std::string("{") + kDomain + R"(, "world": {"tick": 4e400}})"),
            "world.tick = 4e400: is beyond the range of a number (a double, about 1.8e308)");
  const std::string objects = std::string("{") + kDomain + R"(, "objects": [
      {"center": [0, 0.06, 0], "halfExtents": [0.05, 0.05, 0.05]},
      {"center": [0, -1e999, 0], "halfExtents": [0.04, 0.04, 0.04]}]})";
  EXPECT_EQ(loadError(objects).rfind("objects[1].center[1] = -1e999: ", 0), 0u) << loadError(objects);
}

TEST(SceneFileErrors, MissingMeshFileNamesTheKey) {
  const std::string json = std::string("{") + kDomain +
                           R"(, "objects": [{"primitive": "Mesh", "center": [0, 0.1, 0], "mesh": {"file": "no_such.obj"}}]})";
  EXPECT_EQ(loadError(json).rfind("objects[0].mesh.file = \"no_such.obj\": no such file (", 0), 0u) << loadError(json);
  const std::string body = std::string("{") + kDomain +
                           R"(, "bodies": [{"name": "tool", "shape": {"type": "mesh", "file": "../nothing.stl"}}]})";
  EXPECT_EQ(loadError(body).rfind("bodies[0].shape.file = \"../nothing.stl\": no such file (", 0), 0u);
}

// A mesh object given inline ("vertices", "triangles", as Python's add_object passes numpy
// arrays) is the same tissue as the same mesh from a file: the particles bit for bit, with
// the scale applied to both; an inline mesh's bad parts are named at their keys.
TEST(SceneFile, InlineMeshIsTheSameTissueAsItsFile) {
  // a box 6 x 8 x 3 cm about its centre, in cm (scale 0.01)
  const char* vertices = "[[-3, -4, -1.5], [-3, -4, 1.5], [-3, 4, -1.5], [-3, 4, 1.5], [3, -4, -1.5], [3, -4, 1.5], "
                         "[3, 4, -1.5], [3, 4, 1.5]]";
  const char* triangles = "[[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1], [2, 3, 7], [2, 7, 6], "
                          "[0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]]";
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "mpm_inline_mesh_test";
  std::filesystem::create_directories(dir);
  {
    std::ofstream obj(dir / "box_cm.obj");
    for (const char* v : {"-3 -4 -1.5", "-3 -4 1.5", "-3 4 -1.5", "-3 4 1.5", "3 -4 -1.5", "3 -4 1.5", "3 4 -1.5",
                          "3 4 1.5"})
      obj << "v " << v << "\n";
    for (const char* f : {"1 2 4", "1 4 3", "5 7 8", "5 8 6", "1 5 6", "1 6 2", "3 4 8", "3 8 7", "1 3 7", "1 7 5",
                          "2 6 8", "2 8 4"})
      obj << "f " << f << "\n";
  }
  const auto scene = [&](const std::string& mesh) {
    return std::string(R"({"settings": {"domain": {"lower": [-0.1, 0, -0.1], "upper": [0.1, 0.2, 0.1]}, "dx": 0.01})") +
           R"(, "objects": [{"name": "block", "primitive": "Mesh", "center": [0, 0.1, 0], )" +
           R"("mesh": {)" + mesh + R"(, "scale": 0.01}}]})";
  };
  const auto fromFile = LoadedScene::fromString(scene(R"("file": "box_cm.obj")"), dir.string());
  const auto inlined = LoadedScene::fromString(
      scene(std::string(R"("vertices": )") + vertices + R"(, "triangles": )" + triangles), dir.string());
  std::vector<mpm::Vec3f> a, b;
  fromFile->scene().readPositions(fromFile->object("block"), a);
  inlined->scene().readPositions(inlined->object("block"), b);
  ASSERT_EQ(a.size(), 1152u);  // 6 x 8 x 3 cells of 1 cm, 8 particles each
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(mpm::Vec3f)));
  float top = -1.f;
  for (const mpm::Vec3f& x : b) top = std::max(top, x.y);
  EXPECT_NEAR(top, 0.1375f, 1e-5f) << "the scale applies: the top particles a quarter cell below 4 cm";
  std::filesystem::remove_all(dir);

  EXPECT_EQ(loadError(scene(std::string(R"("vertices": )") + vertices + R"(, "triangles": [[0, 1, 8]])")),
            "objects[0].mesh.triangles[0][2] = 8: must index the vertices (0 to 7)");
  EXPECT_EQ(loadError(scene(R"("triangles": [[0, 1, 2]])")), "objects[0].mesh.vertices = missing: required");
  EXPECT_EQ(loadError(scene(std::string(R"("file": "box_cm.obj", "vertices": )") + vertices)),
            "objects[0].mesh.file = \"box_cm.obj\": give either a file or vertices and triangles, not both");
  EXPECT_EQ(loadError(scene(R"("vertices": [[0, 0]], "triangles": [[0, 0, 0]])")),
            "objects[0].mesh.vertices[0] = [0,0]: must be an array of 3 numbers");
}

TEST(SceneFileErrors, ToolAndThreadErrorsAreRenamedToTheirKeys) {
  const std::string scalpel = R"({"name": "scalpel", "shape": {"type": "box", "halfExtents": [0.01, 0.01, 0.001]},
                                  "coupled": false})";
  EXPECT_EQ(loadError(std::string("{") + kDomain + R"(, "bodies": [)" + scalpel +
                      R"(], "slicers": [{"body": "scalpel", "halfLength": -0.01}]})")
                .rfind("slicers[0].halfLength = -0.01: ", 0),
            0u);
  EXPECT_EQ(loadError(std::string("{") + kDomain + R"(, "slicers": [{"body": "knife"}]})"),
            "slicers[0].body = \"knife\": no body of this name");
  EXPECT_EQ(loadError(std::string("{") + kDomain + R"(, "threads": [{"segments": 1, "start": [0, 0.2, 0]}]})"),
            "threads[0].segments = 1: must be >= 2");
  EXPECT_EQ(loadError(std::string("{") + kDomain + R"(, "threads": [{"start": [0, 0.2, 0], "pins": [{"point": 31}]}]})")
                .rfind("threads[0].pins[0].point = 31: ", 0),
            0u);
  EXPECT_EQ(loadError(std::string("{") + kDomain + R"(, "threads": [{"start": [0, 0.2, 0], "tick": 0}]})"),
            "threads[0].tick = 0.000000: must be finite and > 0");
  EXPECT_EQ(loadError(std::string("{") + kDomain + R"(, "threads": [{"start": [0, 0.2, 0], "youngsModulus": -1}]})"),
            "threads[0].youngsModulus = -1.000000: must be finite and >= 0 (0: a limp thread)");
  EXPECT_EQ(loadError(std::string("{") + kDomain +
                      R"(, "threads": [{"start": [0, 0.2, 0], "coupling": {"dynamic": false, "addedMass": true}}]})"),
            "threads[0].coupling.addedMass = true: needs dynamic = true (the tissue's push on the links)");
  EXPECT_EQ(loadError(std::string("{") + kDomain + R"(, "threads": [{"direction": [1, 0, 0]}]})"),
            "threads[0].start = missing: required unless a pin holds point 0 to a body at a pivot");
  EXPECT_EQ(loadError("{\"settings\": {\"dx\": -1}}"), "settings.dx = -1: must be > 0");
  EXPECT_EQ(loadError("[1, 2]"), "(scene) = [1,2]: must be an object");
  EXPECT_EQ(loadError("{\"settings\": ").rfind("(scene) = (not JSON): ", 0), 0u);
}

TEST(SceneFileErrors, CameraAndGroundAreCheckedByTheRendererAtLoading) {
  EXPECT_EQ(loadError(R"({"output": {"camera": {"eye": [0, 1, 0], "target": [0, 1, 0]}}})"),
            "output.camera.target = eye: must differ from Camera.eye");
  EXPECT_EQ(loadError(R"({"output": {"camera": {"width": 0}}})"), "output.camera.width = 0: must be in 1..32768");
  EXPECT_EQ(loadError(R"({"output": {"ground": {"halfSize": 0}}})").rfind("output.ground.halfSize = ", 0), 0u);
}

// --- the file's keys map onto the same physics as the C++ setup -------------------------

// a 0.2 kg ball dropped on a slab on the ground, standard MPM, every field away from its default
constexpr char kBallOnSlab[] = R"({
  "settings": {"domain": {"lower": [-0.15, -0.05, -0.15], "upper": [0.15, 0.25, 0.15]}, "dx": 0.02,
               "solver": "StandardMpm", "standardMpm": {"flipBlend": 0.9}, "substeps": {"cflNumber": 0.25},
               "backend": "Cpu", "cpuThreads": 1},
  "world": {"gravity": [0, -9.81, 0], "tick": 0.005, "solverIterations": 12},
  "objects": [{"name": "slab", "center": [0, 0.041, 0], "halfExtents": [0.1, 0.04, 0.1],
               "material": {"model": "NeoHookeanDecoupled", "youngsModulus": 2e4, "poissonRatio": 0.35, "density": 1100}}],
  "bodies": [{"name": "ground", "shape": {"type": "plane"}},
             {"name": "ball", "shape": {"type": "sphere", "radius": 0.03}, "mass": 0.2,
              "pose": {"position": [0.01, 0.115, 0]}, "linearVelocity": [0, -0.2, 0], "friction": 0.3,
              "coupling": {"contact": {"mode": "Frictional", "friction": 0.5, "band": 0.001}}}],
  "output": {"frames": 4, "frameTime": 0.02}
})";

// With "world": {"tissueInterval": 2} against Coupler::setTissueInterval(2), bit for bit
// as well: the scene file's clock and the frame's impulse sums follow Bullet's ticks.
class SceneFileInterval : public ::testing::TestWithParam<int> {};

TEST_P(SceneFileInterval, BallOnSlabMatchesTheSameSetupInCpp) {
  const int interval = GetParam();
  auto loaded = LoadedScene::fromString(kBallOnSlab, ".", R"({"world": {"tissueInterval": )" + std::to_string(interval) + "}}");
  EXPECT_EQ(loaded->coupler().tissueInterval(), interval);
  for (int f = 0; f < 4; ++f) loaded->advanceFrame();

  // the same by hand
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  btDbvtBroadphase broadphase;
  btMultiBodyConstraintSolver solver;
  btMultiBodyDynamicsWorld world(&dispatcher, &broadphase, &solver, &config);
  world.setGravity(btVector3(0, -9.81f, 0));
  world.getSolverInfo().m_numIterations = 12;
  mpm::SceneSettings settings;
  settings.domain.lower = {-0.15f, -0.05f, -0.15f};
  settings.domain.upper = {0.15f, 0.25f, 0.15f};
  settings.dx = 0.02f;
  settings.solver = mpm::SolverType::StandardMpm;
  settings.standardMpm.flipBlend = 0.9f;
  settings.substeps.cflNumber = 0.25f;
  settings.backend = mpm::Backend::Cpu;
  settings.cpuThreads = 1;
  mpm::Scene scene(settings);
  mpm::ParticleObjectDesc slab;
  slab.center = {0.f, 0.041f, 0.f};
  slab.halfExtents = {0.1f, 0.04f, 0.1f};
  slab.material = {mpm::MaterialModel::NeoHookeanDecoupled, 2e4f, 0.35f, 1100.f};
  const mpm::ParticleObjectId slabId = scene.addParticleObject(slab);
  mpm::bullet::Coupler coupler(&world, scene);
  btStaticPlaneShape groundShape(btVector3(0, 1, 0), 0);
  btRigidBody ground(0.f, nullptr, &groundShape);
  world.addRigidBody(&ground);
  coupler.addRigidBody(&ground);
  btSphereShape ballShape(0.03f);
  btVector3 inertia;
  ballShape.calculateLocalInertia(0.2f, inertia);
  btRigidBody::btRigidBodyConstructionInfo info(0.2f, nullptr, &ballShape, inertia);
  info.m_startWorldTransform = btTransform(btQuaternion::getIdentity(), btVector3(0.01f, 0.115f, 0));
  info.m_friction = 0.3f;
  btRigidBody ball(info);
  ball.setLinearVelocity(btVector3(0, -0.2f, 0));
  world.addRigidBody(&ball);
  mpm::bullet::CouplingOptions options;
  options.contact.mode = mpm::ContactMode::Frictional;
  options.contact.friction = 0.5f;
  options.contact.band = 0.001f;
  coupler.addRigidBody(&ball, options);
  coupler.setTissueInterval(interval);
  for (int f = 0; f < 4; ++f) {
    world.stepSimulation(4 * 0.005f, 5, 0.005f);
    coupler.rethrowError();
  }

  const btVector3 a = loaded->body("ball")->getCenterOfMassPosition(), b = ball.getCenterOfMassPosition();
  const btVector3 va = loaded->body("ball")->getLinearVelocity(), vb = ball.getLinearVelocity();
  EXPECT_LT(a.y(), 0.105f) << "the ball fell onto the slab (its top at 0.081 m)";
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(a[k], b[k], 1e-6f) << "ball position " << k;
    EXPECT_NEAR(va[k], vb[k], 1e-5f) << "ball velocity " << k;
  }
  const mpm::ObjectSummary sa = loaded->scene().summary(loaded->object("slab")), sb = scene.summary(slabId);
  EXPECT_EQ(sa.particles, sb.particles);
  EXPECT_NEAR(sa.mass, sb.mass, 1e-6 * sb.mass);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(sa.centerOfMass[k], sb.centerOfMass[k], 1e-6);
    EXPECT_NEAR(sa.momentum[k], sb.momentum[k], 1e-6 * sb.mass);
  }
  EXPECT_NE(sa.momentum[1], 0.0) << "the ball pushed the slab";
  EXPECT_NEAR(loaded->scene().time(), 0.08, 1e-6) << "the frames end where intervals do";
  world.removeRigidBody(&ball);
  world.removeRigidBody(&ground);
}

INSTANTIATE_TEST_SUITE_P(TicksPerAdvance, SceneFileInterval, ::testing::Values(1, 2),
                         [](const auto& info) { return "Every" + std::to_string(info.param) + "Ticks"; });

TEST(SceneFileErrors, TissueIntervalMustDivideTheFrame) {
  EXPECT_EQ(loadError(R"({"world": {"tissueInterval": 0}})"), "world.tissueInterval = 0: must lie in [1, 1000] ticks");
  EXPECT_EQ(loadError(R"({"world": {"tick": 0.005, "tissueInterval": 3}, "output": {"frameTime": 0.02}})"),
            "world.tissueInterval = 3: must divide the frame's 4 Bullet ticks (output.frameTime / world.tick)");
}

TEST(SceneFilePhysics, FreeFallingTissueBoxFollowsGravity) {
  // one Bullet tick of 0.1 s in 40 fixed substeps: symplectic Euler gives the fall
  // g t^2 (1 + 1/N) / 2 (as tests/test_c_api.c checks through the C API)
  auto loaded = LoadedScene::fromString(R"({
    "settings": {"domain": {"lower": [-0.3, -0.5, -0.3], "upper": [0.3, 0.5, 0.3]}, "dx": 0.025,
                 "gravity": [0, -9.81, 0], "substeps": {"fixedSubsteps": 40}, "cpuThreads": 1, "backend": "Cpu"},
    "world": {"tick": 0.1},
    "objects": [{"name": "box", "center": [0, 0.3, 0], "halfExtents": [0.05, 0.05, 0.05],
                 "material": {"youngsModulus": 2e4}}],
    "output": {"frames": 1, "frameTime": 0.1}})");
  const double y0 = loaded->scene().summary(loaded->object("box")).centerOfMass[1];
  loaded->advanceFrame();
  const double t = loaded->scene().time(), N = 40;
  EXPECT_NEAR(t, 0.1, 1e-6);
  const double fall = 0.5 * 9.81 * t * t * (1 + 1 / N);
  const double fell = y0 - loaded->scene().summary(loaded->object("box")).centerOfMass[1];
  EXPECT_NEAR(fell, fall, 1e-3 * fall);
}

TEST(SceneFileThreads, AFixedBaseThreadIsAnchoredAndPinsAreWhereThePointsAre) {
  auto loaded = LoadedScene::fromString(std::string("{") + kDomain + R"(,
    "world": {"gravity": [0, -9.81, 0], "tick": 0.0010416667, "solverIterations": 50},
    "threads": [{"name": "anchored", "length": 0.06, "segments": 12, "linearDensity": 1e-3, "start": [0, 0.25, 0],
                 "direction": [1, 0, 0], "fixedBase": true},
                {"name": "pinned", "length": 0.06, "segments": 12, "linearDensity": 1e-3, "start": [0, 0.25, 0.05],
                 "direction": [1, 0, 0], "pins": [{"point": 0}]}],
    "output": {"frameTime": 0.0104166667}})");
  EXPECT_TRUE(loaded->thread("anchored")->hasFixedBase());
  EXPECT_FALSE(loaded->thread("pinned")->hasFixedBase());
  loaded->advanceFrame();
  // both hang from their first point: it stays where it was built (the pin's pivot
  // defaults to the point's position), the free ends fall
  for (const char* name : {"anchored", "pinned"}) {
    const std::vector<btVector3> p = mpm::bullet::threadPoints(loaded->thread(name));
    EXPECT_LT((p.front() - btVector3(0, 0.25f, name[0] == 'a' ? 0.f : 0.05f)).length(), 1e-4f) << name;
    EXPECT_LT(p.back().y(), 0.25f - 1e-4f) << name;
  }
}

// The suturing scene's thread is laid along its path measured from the last corner: its last
// point is the eye's corner, where the pin to the needle holds it, and its links are a
// segment long (the path's corners are 1 um off the arc's rounding, the pin's pivot is exact).
TEST(SceneFileThreads, APathMeasuredFromTheLastCornerEndsThere) {
  auto loaded = LoadedScene::fromFile(mpm::test::assetPath("scenes/suturing.json"),
                                      R"({"settings": {"dx": 0.005, "cpuThreads": 1}})");
  const std::vector<btVector3> p = mpm::bullet::threadPoints(loaded->thread("thread"));
  ASSERT_EQ(p.size(), 31u);
  const btVector3 eye = loaded->body("needle")->getCenterOfMassTransform() *
                        loaded->threadPin("thread", 30)->getPivotInB();
  EXPECT_LT((p.back() - eye).length(), 1e-6f);
  for (size_t k = 0; k + 1 < p.size(); ++k) EXPECT_NEAR((p[k + 1] - p[k]).length(), 0.0025f, 2.5e-6f) << k;
  EXPECT_TRUE(loaded->thread("thread")->hasFixedBase());
  EXPECT_THROW(loaded->threadPin("thread", 0), mpm::InvalidArgument) << "point 0 is the fixed base, not pinned";
}

// An override names the one element it changes: the right block's patch keeps its
// material and the left block; an array whose elements name nothing in the file replaces it.
TEST(SceneFile, AnOverrideOfANamedElementPatchesThatElementOnly) {
  const std::string file = mpm::test::assetPath("scenes/suturing.json");
  const char* coarse = R"({"settings": {"dx": 0.005, "cpuThreads": 1}})";
  auto whole = LoadedScene::fromFile(file, coarse);
  auto patched = LoadedScene::fromFile(
      file, std::vector<std::string>{coarse, R"({"objects": [{"name": "right", "halfExtents": [0.015, 0.01, 0.0075]}]})"});
  std::vector<mpm::Vec3f> a, b;
  whole->scene().readPositions(whole->object("right"), a);
  patched->scene().readPositions(patched->object("right"), b);
  EXPECT_EQ(b.size() * 2, a.size()) << "half as deep";
  EXPECT_EQ(patched->material("right").fractureToughness, 200.f) << "the rest of the block is the file's";
  EXPECT_EQ(patched->scene().particleCount(), whole->scene().particleCount() - b.size());
  auto replaced = LoadedScene::fromFile(
      file, std::vector<std::string>{coarse, R"({"objects": [{"name": "only", "primitive": "Box", "center": [0, 0.02, 0], "halfExtents": [0.01, 0.01, 0.01]}]})"});
  EXPECT_THROW(replaced->object("left"), mpm::InvalidArgument);
}

// --- PLY frames ------------------------------------------------------------------------

// The tissue file holds every particle (the cutaway is the picture's only) in its object's
// colour; the tools file the needle's arc (33 points, 32 edges), the knot where the thread's
// fixed base is (one point, no edge) and the thread (31, 30).
TEST(SceneFilePly, FrameReadsBackAsTheSceneIs) {
  auto loaded = LoadedScene::fromFile(mpm::test::assetPath("scenes/suturing.json"),
                                      R"({"settings": {"dx": 0.005, "cpuThreads": 1}})");
  EXPECT_TRUE(loaded->plyDue());
  const std::string tissue = testing::TempDir() + "/scene_file_frame.ply", tools = testing::TempDir() + "/scene_file_tools.ply";
  loaded->writePly(tissue, tools);
  const mpm::test::PlyRead t = mpm::test::readPly(tissue);
  EXPECT_EQ(t.vertexCount, loaded->scene().particleCount());
  EXPECT_EQ(t.edgeCount, 0u);
  EXPECT_EQ(t.trailingBytes, 0u);
  ASSERT_EQ(t.frame.points.size(), loaded->scene().particleCount());
  std::vector<mpm::Vec3f> left, right;
  loaded->scene().readPositions(loaded->object("left"), left);
  loaded->scene().readPositions(loaded->object("right"), right);
  left.insert(left.end(), right.begin(), right.end());
  for (size_t i = 0; i < left.size(); ++i)
    for (int c = 0; c < 3; ++c) ASSERT_EQ(t.frame.points[i][c], left[i][c]) << "particle " << i;
  EXPECT_EQ(t.frame.colours.front().g, 110);  // the left block's [215, 110, 105]
  EXPECT_EQ(t.frame.colours.back().g, 150);   // the right one's [235, 150, 130]
  const mpm::test::PlyRead w = mpm::test::readPly(tools);
  EXPECT_EQ(w.vertexCount, 33u + 1u + 31u);
  EXPECT_EQ(w.edgeCount, 32u + 30u);
  EXPECT_EQ(w.trailingBytes, 0u);
  const std::vector<btVector3> thread = mpm::bullet::threadPoints(loaded->thread("thread"));
  ASSERT_EQ(w.frame.points.size(), 33u + 1u + 31u);
  EXPECT_EQ(w.frame.points.back().x, (float)thread.back().x());
  for (int c = 0; c < 3; ++c) EXPECT_EQ(w.frame.points[33][c], (float)thread.front()[c]) << "the knot sits on the thread's base";
  EXPECT_FALSE(LoadedScene::fromFile(mpm::test::assetPath("scenes/suturing.json"),
                                     R"({"settings": {"dx": 0.005, "cpuThreads": 1}, "output": {"ply": false}})")
                   ->plyDue());
}

// --- scripted motion and checkpoints ---------------------------------------------------

TEST(SceneFileMotion, KinematicKeyframesMoveTheBodyAlongThePath) {
  auto loaded = LoadedScene::fromString(std::string("{") + kDomain + R"(,
    "world": {"tick": 0.01},
    "bodies": [{"name": "tool", "shape": {"type": "sphere", "radius": 0.01}, "coupled": false,
                "motion": {"mode": "kinematic", "ease": "linear", "keyframes": [
                  {"time": 0, "position": [0, 0.2, 0]}, {"time": 0.1, "position": [0.1, 0.2, 0]}]}}],
    "output": {"frameTime": 0.05}})");
  loaded->advanceFrame();  // Bullet takes the pose a tick ahead of the frame's start: 0.01 s
  EXPECT_NEAR(loaded->body("tool")->getCenterOfMassPosition().x(), 0.01f, 1e-5f);
  loaded->advanceFrame();
  loaded->advanceFrame();
  EXPECT_NEAR(loaded->body("tool")->getCenterOfMassPosition().x(), 0.1f, 1e-5f) << "held after the last keyframe";
}

// A driven body follows its script on Bullet's clock: with the tissue advanced once every
// 4 ticks (the scene's clock ahead of Bullet's inside each interval) it moves exactly as
// with every tick. Reading the scene's clock, it ran up to 3 ticks ahead of its script.
TEST(SceneFileMotion, ScriptsRunOnBulletsClockAcrossTissueIntervals) {
  auto run = [](int interval) {
    auto loaded = LoadedScene::fromString(std::string("{") + kDomain + R"(,
      "world": {"tick": 0.01, "gravity": [0, 0, 0], "tissueInterval": )" + std::to_string(interval) + R"(},
      "bodies": [{"name": "tool", "shape": {"type": "sphere", "radius": 0.01}, "mass": 0.1, "coupled": false,
                  "motion": {"mode": "driver", "keyframes": [
                    {"time": 0, "position": [0, 0.2, 0]}, {"time": 0.2, "position": [0.1, 0.2, 0]}]}}],
      "output": {"frameTime": 0.04}})");
    loaded->advanceFrame();
    loaded->advanceFrame();
    return loaded->body("tool")->getCenterOfMassPosition();
  };
  const btVector3 every = run(1), fourth = run(4);
  EXPECT_GT(every.x(), 0.01f) << "the driver moved the body";
  EXPECT_EQ(fourth.x(), every.x());
  EXPECT_EQ(fourth.y(), every.y());
}

// A keyframe's own ease governs the stretch into it (a smoothstep turn, then a steady pull),
// and a held driven body stops where its script was when held, at rest.
TEST(SceneFileMotion, AKeyframesEaseAndAHoldStopTheStretch) {
  auto loaded = LoadedScene::fromString(std::string("{") + kDomain + R"(,
    "world": {"tick": 0.01, "gravity": [0, 0, 0]},
    "bodies": [{"name": "tool", "shape": {"type": "sphere", "radius": 0.01}, "mass": 0.1, "coupled": false,
                "motion": {"mode": "driver", "limits": {"maxForce": 100, "maxTorque": 100, "timeConstant": 0.005},
                           "keyframes": [{"time": 0, "position": [0, 0.2, 0]},
                                         {"time": 0.1, "position": [0, 0.2, 0]},
                                         {"time": 0.5, "position": [0.1, 0.2, 0], "ease": "linear"}]}}],
    "output": {"frameTime": 0.2}})");
  std::vector<double> speeds;
  loaded->setTickCallback([&](float) { speeds.push_back(loaded->body("tool")->getLinearVelocity().x()); });
  loaded->advanceFrame();  // to 0.2 s: the steady stretch at 0.25 m/s from 0.1 s on
  EXPECT_NEAR(speeds.back(), 0.25, 0.25 * 0.02) << "linear: the pull's speed, not a smoothstep's 0.28 m/s";
  loaded->holdBody("tool");
  const float x = (float)loaded->body("tool")->getCenterOfMassPosition().x();
  loaded->advanceFrame();
  EXPECT_TRUE(loaded->held("tool"));
  EXPECT_LT(std::fabs(loaded->body("tool")->getCenterOfMassPosition().x() - x), 0.003f) << "held, not pulled on to 0.1 m";
  EXPECT_LT(std::fabs(speeds.back()), 1e-3);
  EXPECT_THROW(loaded->holdBody("nothing"), mpm::InvalidArgument);
}

// A slow turn's feedforward is the stretch's own angular speed: a driven body (time
// constant 0.1 s) turning at 0.05 rad/s sits on its script after 1 s, not w tau = 5e-3 rad
// behind it. Measured before: 4.5e-3 rad behind (the central difference of two float rotations
// 1e-4 rad apart gave w = 0, leaving the driver's lag; the suturing needle turned 5 % behind).
TEST(SceneFileMotion, ASlowTurnIsDrivenOnItsScript) {
  auto loaded = LoadedScene::fromString(std::string("{") + kDomain + R"(,
    "world": {"tick": 0.01, "gravity": [0, 0, 0]},
    "bodies": [{"name": "tool", "shape": {"type": "sphere", "radius": 0.01}, "mass": 0.1, "coupled": false,
                "motion": {"mode": "driver", "ease": "linear",
                           "limits": {"maxForce": 100, "maxTorque": 100, "timeConstant": 0.1},
                           "keyframes": [{"time": 0, "position": [0, 0.2, 0], "rotation": {"axis": [0, 0, 1], "angle": 0}},
                                         {"time": 10, "position": [0, 0.2, 0], "rotation": {"axis": [0, 0, 1], "angle": 0.5}}]}}],
    "output": {"frameTime": 0.1}})");
  for (int f = 0; f < 10; ++f) loaded->advanceFrame();
  const btQuaternion q = loaded->body("tool")->getOrientation();
  EXPECT_NEAR(2 * std::atan2(q.z(), q.w()), 0.05, 5e-4);
  EXPECT_NEAR(loaded->body("tool")->getAngularVelocity().z(), 0.05, 5e-4);
}

TEST(SceneFileCheckpoint, CouplerCheckpointResumesTheRun) {
  const char* coarse = R"({"settings": {"dx": 0.02, "cpuThreads": 1, "backend": "Cpu"}})";
  auto loaded = LoadedScene::fromFile(mpm::test::assetPath("scenes/coupling.json"), coarse);
  loaded->advanceFrame();
  const std::string path = testing::TempDir() + "/scene_file_coupling.ckpt";
  loaded->saveCheckpoint(path);
  loaded->advanceFrame();
  const float y = (float)loaded->body("heavy")->getCenterOfMassPosition().y();
  auto resumed = LoadedScene::fromFile(mpm::test::assetPath("scenes/coupling.json"), coarse);
  resumed->loadCheckpoint(path);
  EXPECT_EQ(resumed->frame(), 1);
  resumed->advanceFrame();
  EXPECT_EQ((float)resumed->body("heavy")->getCenterOfMassPosition().y(), y);
}

// The suturing scene (needle, thread, pins, driven body) saved from its file and loaded
// into a scene built anew from it resumes the run: the needle body and the thread's middle
// point bit for bit a frame later (before, a scene with needles refused checkpoints).
TEST(SceneFileCheckpoint, TheSuturingSceneResumesTheRun) {
  const char* coarse = R"({"settings": {"dx": 0.005, "cpuThreads": 1}, "output": {"frameTime": 0.0020833333333333333}})";
  auto loaded = LoadedScene::fromFile(mpm::test::assetPath("scenes/suturing.json"), coarse);
  for (int f = 0; f < 2; ++f) loaded->advanceFrame();
  const std::string path = testing::TempDir() + "/scene_file_suturing.ckpt";
  loaded->saveCheckpoint(path);
  loaded->advanceFrame();
  auto resumed = LoadedScene::fromFile(mpm::test::assetPath("scenes/suturing.json"), coarse);
  resumed->loadCheckpoint(path);
  EXPECT_EQ(resumed->frame(), 2);
  resumed->advanceFrame();
  const btVector3 a = loaded->body("needle")->getCenterOfMassPosition(), b = resumed->body("needle")->getCenterOfMassPosition();
  const btVector3 ea = mpm::bullet::threadPoints(loaded->thread("thread"))[15],
                  eb = mpm::bullet::threadPoints(resumed->thread("thread"))[15];
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ((float)a[k], (float)b[k]);
    EXPECT_EQ((float)ea[k], (float)eb[k]);
  }
}

}  // namespace

namespace {

TEST(SceneFile, TheDocsExampleLoads) {
  // the first JSON block of docs/api.md's "Scene files and mpm_run", verbatim
  const std::string readme = readText(mpm::test::sourcePath("docs/api.md"));
  const size_t section = readme.find("## Scene files and `mpm_run`");
  ASSERT_NE(section, std::string::npos);
  const size_t begin = readme.find("```json\n", section), end = readme.find("\n```", begin + 8);
  ASSERT_NE(begin, std::string::npos);
  auto loaded = LoadedScene::fromString(readme.substr(begin + 8, end - begin - 8), ".",
                                        R"({"settings": {"dx": 0.02, "cpuThreads": 1}})");
  EXPECT_GT(loaded->scene().particleCount(), 0u);
  EXPECT_NE(loaded->body("box"), nullptr);
  EXPECT_EQ(loaded->csvHeader(), "time_s,bodies.box.position_x,bodies.box.position_y,bodies.box.position_z");
}

}  // namespace
