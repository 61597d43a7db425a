// Checkpoints: the container refuses what is not a whole checkpoint of this
// format, and a save that fails midway leaves the previous file loadable; a scene saved,
// restored and stepped on follows the uninterrupted run bit for bit (every solver, one CPU
// thread, with a static and a dynamic shape); a refused checkpoint changes nothing.
#include <gtest/gtest.h>

#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "grid/block_grid.h"
#include "mpm/checkpoint_io.h"
#include "bullet_test_world.h"
#include "mpm/scene.h"
#include "mpm_bullet/coupler.h"
#include "solver_cases.h"

namespace mpm {
namespace {

using checkpoint::Reader;
using checkpoint::Writer;
using Reason = CheckpointError::Reason;

std::vector<uint8_t> sampleFile() {
  Writer w;
  w.section("numbers");
  w.put<double>(1.25);
  w.putArray(std::vector<float>{1.f, 2.f, 3.f});
  w.putString("end");
  return w.finish();
}

Reason refusal(const std::vector<uint8_t>& file) {
  try {
    Reader r(file.data(), file.size());
    r.section("numbers");
    r.get<double>("a double");
    std::vector<float> a;
    r.getArray(a, "floats");
    r.getString("a string");
    r.finish();
  } catch (const CheckpointError& e) {
    return e.reason();
  }
  ADD_FAILURE() << "accepted";
  return Reason::Io;
}

TEST(CheckpointFormat, ReadsBackWhatWasWritten) {
  const std::vector<uint8_t> file = sampleFile();
  Reader r(file.data(), file.size());
  r.section("numbers");
  EXPECT_EQ(r.get<double>("a double"), 1.25);
  std::vector<float> a;
  r.getArray(a, "floats");
  EXPECT_EQ(a, (std::vector<float>{1.f, 2.f, 3.f}));
  EXPECT_EQ(r.getString("a string"), "end");
  EXPECT_NO_THROW(r.finish());
}

TEST(CheckpointFormat, RefusesWrongMagicVersionAndChecksum) {
  std::vector<uint8_t> f = sampleFile();
  f[0] = 'X';
  EXPECT_EQ(refusal(f), Reason::NotACheckpoint);
  f = sampleFile();
  f[8] += 1;  // the format version
  EXPECT_EQ(refusal(f), Reason::Version);
  // any flipped payload bit is caught by the CRC
  for (size_t at = checkpoint::kHeaderBytes; at < sampleFile().size(); at += 5) {
    f = sampleFile();
    f[at] ^= 0x10;
    EXPECT_EQ(refusal(f), Reason::Checksum) << "byte " << at;
  }
}

// A bool is read as a byte that must be 0 or 1 (fuzz_checkpoint found a file whose CRC
// held and whose bool byte was 29: copied into a bool, undefined behaviour), also in a
// fixed array of bools (DomainSettings::mirrorLower).
TEST(CheckpointFormat, RefusesABoolThatIsNeitherZeroNorOne) {
  for (const uint8_t byte : {uint8_t(0), uint8_t(1), uint8_t(2), uint8_t(29), uint8_t(255)}) {
    checkpoint::Writer w;
    w.put(byte);
    const uint8_t three[3] = {1, 0, byte};
    w.put(three);
    const std::vector<uint8_t> file = w.finish();
    Reader r(file.data(), file.size());
    bool flags[3];
    if (byte <= 1) {
      EXPECT_EQ(r.get<bool>("a flag"), byte == 1);
      r.getInto(flags, "three flags");
      EXPECT_TRUE(flags[0] && !flags[1] && flags[2] == (byte == 1));
      continue;
    }
    try {
      r.get<bool>("a flag");
      ADD_FAILURE() << "a bool byte of " << (int)byte << " was taken";
    } catch (const CheckpointError& e) {
      EXPECT_EQ(e.reason(), Reason::Malformed);
      EXPECT_NE(std::string(e.what()).find("a flag holds " + std::to_string(byte)), std::string::npos) << e.what();
    }
    Reader again(file.data(), file.size());
    again.get<uint8_t>("a byte");
    EXPECT_THROW(again.getInto(flags, "three flags"), CheckpointError);
  }
}

TEST(CheckpointFormat, RefusesTruncationAtEveryLength) {
  const std::vector<uint8_t> whole = sampleFile();
  for (size_t n = 0; n < whole.size(); ++n) {
    const std::vector<uint8_t> cut(whole.begin(), whole.begin() + (long)n);
    const Reason r = refusal(cut);
    EXPECT_TRUE(r == Reason::Truncated || (n < 8 && r == Reason::NotACheckpoint)) << "cut at " << n;
  }
  std::vector<uint8_t> longer = whole;
  longer.push_back(0);
  EXPECT_EQ(refusal(longer), Reason::Truncated);
}

TEST(CheckpointFormat, AFailedSaveLeavesThePreviousFile) {
  const std::string path = ::testing::TempDir() + "mpm_checkpoint_atomic.bin";
  const std::vector<uint8_t> first = sampleFile();
  checkpoint::writeFileAtomically(path, first);
  // a second save whose writer dies after half of the bytes (a full disk, a killed process)
  std::vector<uint8_t> second = first;
  second.resize(second.size() * 4, 7);
  const checkpoint::ChunkWriter dies = [&](const uint8_t* d, size_t n, std::FILE* f) {
    return std::fwrite(d, 1, n / 2, f);
  };
  try {
    checkpoint::writeFileAtomically(path, second, dies);
    FAIL() << "the failed write was not reported";
  } catch (const CheckpointError& e) {
    EXPECT_EQ(e.reason(), Reason::Io) << e.what();
  }
  EXPECT_EQ(checkpoint::readFile(path), first);
  EXPECT_EQ(std::fopen((path + ".tmp").c_str(), "rb"), nullptr) << "the partial file was left behind";
  std::remove(path.c_str());
}

// readFile checks a file's kind, size and header before it reads the file: a device that
// never ends (/dev/zero: read until memory ran out), a directory, or a huge file whose
// header does not state its size is refused at once, naming the path and why.
TEST(CheckpointFormat, ReadFileChecksKindAndSizeBeforeReading) {
  const auto refusedAs = [](const std::string& path, Reason reason, const std::string& why) {
    try {
      checkpoint::readFile(path);
      ADD_FAILURE() << path << " was read";
    } catch (const CheckpointError& e) {
      EXPECT_EQ(e.reason(), reason) << e.what();
      EXPECT_NE(std::string(e.what()).find("'" + path + "'"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
  };
  refusedAs("/dev/zero", Reason::NotACheckpoint, "is not a regular file (a character device)");
  refusedAs(::testing::TempDir(), Reason::NotACheckpoint, "is not a regular file (a directory)");
  // a sparse 64 GiB file that starts as a checkpoint of a few bytes
  const std::string path = ::testing::TempDir() + "mpm_checkpoint_huge.bin";
  checkpoint::writeFileAtomically(path, sampleFile());
  ASSERT_EQ(::truncate(path.c_str(), off_t(1) << 36), 0);
  refusedAs(path, Reason::Truncated, "(trailing bytes)");
  std::remove(path.c_str());
}

// ---- a scene: a soft block resting on a ground plane, a dynamic sphere dropped on it ----

SceneSettings sceneSettings(SolverType solver) {
  SceneSettings s;
  s.domain.lower = {-0.12f, -0.04f, -0.12f};
  s.domain.upper = {0.12f, 0.2f, 0.12f};
  s.dx = 0.02f;
  s.solver = solver;
  s.backend = Backend::Cpu;
  s.cpuThreads = 1;
  return s;
}

struct TestScene {
  Scene scene;
  ParticleObjectId block;
  ShapeId ground, ball;
  explicit TestScene(SolverType solver) : scene(sceneSettings(solver)) {
    ParticleObjectDesc d;
    d.center = {0.f, 0.04f, 0.f};
    d.halfExtents = {0.05f, 0.04f, 0.05f};
    d.material.youngsModulus = 3e4f;
    block = scene.addParticleObject(d);
    ShapeDesc plane;
    plane.parts = {Geometry{}};
    plane.parts[0].type = GeometryType::Plane;
    plane.contact.friction = 0.5f;
    ground = scene.addShape(plane);
    ShapeDesc sphere;
    sphere.parts = {Geometry::sphere(0.02f)};
    sphere.pose.position = {0.01f, 0.11f, 0.f};
    sphere.mass = 0.05f;
    const float I = 0.4f * 0.05f * 0.02f * 0.02f;
    sphere.inertia = {I, I, I};
    sphere.gravity = {0.f, -9.81f, 0.f};
    sphere.linearVelocity = {0.f, -0.5f, 0.f};
    ball = scene.addShape(sphere);
  }
};

/// Everything a step writes that a caller can read, bit for bit.
struct Snapshot {
  double time = 0;
  std::vector<Vec3f> x, v;
  std::vector<Mat3f> F;
  ShapeState ball;
  ShapeImpulse impulse;
};
Snapshot snapshot(const TestScene& t) {
  Snapshot s;
  s.time = t.scene.time();
  t.scene.readPositions(t.block, s.x);
  t.scene.readVelocities(t.block, s.v);
  t.scene.readDeformationGradients(t.block, s.F);
  s.ball = t.scene.shapeState(t.ball);
  s.impulse = t.scene.shapeImpulse(t.ball);
  return s;
}
bool sameBits(const void* a, const void* b, size_t n) { return n == 0 || std::memcmp(a, b, n) == 0; }
template <class T>
bool sameBits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && sameBits(a.data(), b.data(), a.size() * sizeof(T));
}
void expectIdentical(const Snapshot& a, const Snapshot& b, const char* what) {
  EXPECT_EQ(a.time, b.time) << what;
  EXPECT_TRUE(sameBits(a.x, b.x)) << what << ": positions";
  EXPECT_TRUE(sameBits(a.v, b.v)) << what << ": velocities";
  EXPECT_TRUE(sameBits(a.F, b.F)) << what << ": deformation gradients";
  EXPECT_TRUE(sameBits(&a.ball, &b.ball, sizeof(ShapeState))) << what << ": the dynamic shape's pose and velocity";
  EXPECT_TRUE(sameBits(&a.impulse, &b.impulse, sizeof(ShapeImpulse))) << what << ": its impulse";
}

constexpr float kFrame = 1.f / 120;
/// Steps `frames` frames; returns the momentum the tissue gave the ball over them.
float run(TestScene& t, int frames) {
  float pushed = 0;
  for (int f = 0; f < frames; ++f) {
    t.scene.step(kFrame);
    pushed += std::fabs(t.scene.shapeImpulse(t.ball).linear.y);
  }
  return pushed;
}

class SceneCheckpoint : public ::testing::TestWithParam<SolverType> {};

TEST_P(SceneCheckpoint, RestoredRunIsBitIdentical) {
  TestScene original(GetParam());
  run(original, 3);
  const std::vector<uint8_t> saved = original.scene.saveToMemory();
  // the ball lands on the block within these frames (and bounces off MTLED's undamped one)
  ASSERT_GT(run(original, 6), 0.f) << "the ball must press on the tissue after the save";
  const Snapshot uninterrupted = snapshot(original);

  // into a fresh scene of the same settings (its own object and shapes are replaced)
  TestScene fresh(GetParam());
  fresh.scene.loadFromMemory(saved);
  run(fresh, 6);
  expectIdentical(snapshot(fresh), uninterrupted, "a fresh scene");

  // rewinding the scene that went on: its handles name the same object and shapes again
  original.scene.loadFromMemory(saved);
  run(original, 6);
  expectIdentical(snapshot(original), uninterrupted, "the rewound scene");

  // through a file
  const std::string path = ::testing::TempDir() + "mpm_checkpoint_" + test::solverName(GetParam()) + ".ckpt";
  TestScene viaFile(GetParam());
  run(viaFile, 3);
  viaFile.scene.save(path);
  run(viaFile, 6);
  viaFile.scene.load(path);
  run(viaFile, 6);
  expectIdentical(snapshot(viaFile), uninterrupted, "a scene reloaded from a file");
  std::remove(path.c_str());
}

TEST_P(SceneCheckpoint, RefusedCheckpointsChangeNothing) {
  TestScene t(GetParam());
  run(t, 3);
  const std::vector<uint8_t> good = t.scene.saveToMemory({1, 2, 3});
  EXPECT_EQ(t.scene.attachmentOf(good), (std::vector<uint8_t>{1, 2, 3}));
  run(t, 2);
  const Snapshot before = snapshot(t);
  auto expectRefused = [&](const std::vector<uint8_t>& bytes, Reason reason, const char* what) {
    try {
      t.scene.loadFromMemory(bytes);
      ADD_FAILURE() << what << ": accepted";
    } catch (const CheckpointError& e) {
      EXPECT_EQ(e.reason(), reason) << what << ": " << e.what();
    }
    expectIdentical(snapshot(t), before, what);
  };
  std::vector<uint8_t> bad = good;
  bad[3] = 'x';
  expectRefused(bad, Reason::NotACheckpoint, "wrong magic");
  bad = good;
  bad[8] = 99;
  expectRefused(bad, Reason::Version, "another version");
  bad = good;
  bad[bad.size() / 2] ^= 1;
  expectRefused(bad, Reason::Checksum, "one flipped bit");
  for (size_t cut : {size_t(5), size_t(20), good.size() / 3, good.size() - 1}) {
    bad.assign(good.begin(), good.begin() + (long)cut);
    expectRefused(bad, cut < 8 ? Reason::NotACheckpoint : Reason::Truncated, "truncated");
  }
  // a checkpoint of another scene: a different cell size, named with both values
  SceneSettings other = sceneSettings(GetParam());
  other.dx = 0.025f;
  Scene otherScene(other);
  try {
    t.scene.loadFromMemory(otherScene.saveToMemory());
    ADD_FAILURE() << "another scene's checkpoint was accepted";
  } catch (const CheckpointError& e) {
    EXPECT_EQ(e.reason(), Reason::OtherScene);
    EXPECT_NE(std::string(e.what()).find("SceneSettings.dx = 0.0250000004, this scene's 0.0199999996"),
              std::string::npos)
        << e.what();
  }
  expectIdentical(snapshot(t), before, "another scene");
  // the execution settings may differ: a checkpoint of a two-thread scene loads
  SceneSettings twoThreads = sceneSettings(GetParam());
  twoThreads.cpuThreads = 2;
  Scene loads(twoThreads);
  EXPECT_NO_THROW(loads.loadFromMemory(good));
  EXPECT_EQ(loads.time(), 3 * (double)kFrame);
}

/// `good` with `value` written at byte `offset` and its CRC-32 sealed again, so the
/// loader's own checks (not the checksum) must refuse the change.
template <class T>
std::vector<uint8_t> patched(const std::vector<uint8_t>& good, size_t offset, const T& value) {
  std::vector<uint8_t> file = good;
  std::memcpy(&file[offset], &value, sizeof(T));
  const uint32_t crc = (uint32_t)crc32_z(crc32_z(0L, Z_NULL, 0), file.data() + checkpoint::kHeaderBytes,
                                         file.size() - checkpoint::kHeaderBytes);
  std::memcpy(&file[12], &crc, 4);
  return file;
}

// Run-time policies (recovery, the energy check, the backend and its threads) are not the
// model: a checkpoint loads into the same scene run under other policies; a model field
// (the substep policy) still makes it another scene's.
TEST(SceneCheckpointFields, RunTimePoliciesMayDiffer) {
  SceneSettings policies = sceneSettings(SolverType::MlsMpm);
  policies.recovery.enabled = true;
  policies.recovery.maxHalvings = 7;
  policies.energyCheck.enabled = true;
  policies.energyCheck.tolerance = 0.3f;
  policies.energyCheck.noiseSpeed = 0.01f;
  policies.cpuThreads = 2;
  policies.backend = Backend::Auto;
  TestScene saved(SolverType::MlsMpm), plain(SolverType::MlsMpm);
  Scene withPolicies(policies);
  withPolicies.loadFromMemory(saved.scene.saveToMemory());  // the same physics: its model
  run(saved, 2);
  withPolicies.step(kFrame);
  withPolicies.step(kFrame);
  EXPECT_NO_THROW(plain.scene.loadFromMemory(withPolicies.saveToMemory()));
  EXPECT_EQ(plain.scene.time(), withPolicies.time());
  EXPECT_EQ(plain.scene.particleCount(), saved.scene.particleCount());
  SceneSettings model = policies;
  model.substeps.fixedSubsteps = 3;
  Scene other(model);
  try {
    plain.scene.loadFromMemory(other.saveToMemory());
    ADD_FAILURE() << "a checkpoint of another substep policy was accepted";
  } catch (const CheckpointError& e) {
    EXPECT_EQ(e.reason(), Reason::OtherScene) << e.what();
    EXPECT_NE(std::string(e.what()).find("SceneSettings.substeps.fixedSubsteps = 3"), std::string::npos) << e.what();
  }
}

// A particle far outside the grid in a checkpoint whose CRC holds (fuzz_checkpoint: x =
// 2e31, whose stencil index overflowed an int in the first step) is refused on loading,
// as is one just outside the grid and one at NaN; the scene is left as it was.
TEST(SceneCheckpointFields, RefusesParticlesOutsideTheGrid) {
  TestScene t(SolverType::MlsMpm);
  run(t, 3);
  const std::vector<uint8_t> good = t.scene.saveToMemory();
  std::vector<Vec3f> x;
  t.scene.readPositions(t.block, x);
  // the first particle's position, as the payload holds it
  const auto at = std::search(good.begin() + (long)checkpoint::kHeaderBytes, good.end(), (const uint8_t*)&x[0],
                              (const uint8_t*)&x[0] + sizeof(Vec3f));
  ASSERT_NE(at, good.end());
  const Snapshot before = snapshot(t);
  for (const float bad : {2e31f, 0.2f + 0.05f, std::nanf("")}) {
    const std::vector<uint8_t> file = patched(good, (size_t)(at - good.begin()), bad);
    try {
      t.scene.loadFromMemory(file);
      ADD_FAILURE() << "a particle at x = " << bad << " was loaded";
    } catch (const CheckpointError& e) {
      EXPECT_EQ(e.reason(), Reason::Malformed) << e.what();
      EXPECT_NE(std::string(e.what()).find("outside the grid"), std::string::npos) << e.what();
    }
    expectIdentical(snapshot(t), before, "particle outside the grid");
  }
  EXPECT_NO_THROW(t.scene.loadFromMemory(good));
}

// A needle's tip state outside the three there are (outside, entering, deep) in a
// checkpoint whose CRC holds is refused, naming it; the scene is left as it was.
TEST(SceneCheckpointFields, RefusesATipStateThatIsNone) {
  TestScene t(SolverType::MlsMpm);
  ArcDesc needle;
  needle.pose.position = {0.03f, 0.15f, 0.01f};  // above the block, touching nothing
  t.scene.addCurve(needle);
  run(t, 2);
  const std::vector<uint8_t> good = t.scene.saveToMemory();
  // the needle's state as written, the tip's byte after it (find_end: the ArcDesc before
  // it ends with the same pose and velocities)
  const ShapeState state{needle.pose, needle.linearVelocity, needle.angularVelocity};
  const auto at = std::find_end(good.begin() + (long)checkpoint::kHeaderBytes, good.end(), (const uint8_t*)&state,
                                (const uint8_t*)&state + sizeof(state));
  ASSERT_NE(at, good.end());
  const size_t tip = (size_t)(at - good.begin()) + sizeof(state);
  ASSERT_EQ(good[tip], 0) << "the tip, outside";
  const Snapshot before = snapshot(t);
  try {
    t.scene.loadFromMemory(patched(good, tip, (uint8_t)3));
    ADD_FAILURE() << "a tip state of 3 was loaded";
  } catch (const CheckpointError& e) {
    EXPECT_EQ(e.reason(), Reason::Malformed) << e.what();
    EXPECT_NE(std::string(e.what()).find("tip state is 3"), std::string::npos) << e.what();
  }
  expectIdentical(snapshot(t), before, "a tip state that is none");
  EXPECT_NO_THROW(t.scene.loadFromMemory(patched(good, tip, (uint8_t)2)));
}

// A loaded shape must pass addShape's own check (fuzz_checkpoint, in CI: a part whose
// type read Mesh but which had no grid was dereferenced when the shape was built, a null
// pointer): the test scene's sphere turned into a Mesh part is refused, naming the field.
TEST(SceneCheckpointFields, RefusesAShapeNoAddCallWouldTake) {
  TestScene t(SolverType::MlsMpm);
  run(t, 2);
  const std::vector<uint8_t> good = t.scene.saveToMemory();
  // the sphere's part as written: type, half extents (the default), radius
  struct {
    int32_t type = (int32_t)GeometryType::Sphere;
    Vec3f halfExtents{0.05f, 0.05f, 0.05f};
    float radius = 0.02f;
  } sphere;
  static_assert(sizeof(sphere) == 20, "packed as written");
  const auto at = std::search(good.begin() + (long)checkpoint::kHeaderBytes, good.end(), (const uint8_t*)&sphere,
                              (const uint8_t*)&sphere + sizeof(sphere));
  ASSERT_NE(at, good.end());
  const std::vector<uint8_t> file = patched(good, (size_t)(at - good.begin()), (int32_t)GeometryType::Mesh);
  const Snapshot before = snapshot(t);
  try {
    t.scene.loadFromMemory(file);
    ADD_FAILURE() << "a Mesh part without a grid was loaded";
  } catch (const CheckpointError& e) {
    EXPECT_EQ(e.reason(), Reason::Malformed) << e.what();
    EXPECT_NE(std::string(e.what()).find("a shape: ShapeDesc.parts[0].sdf"), std::string::npos) << e.what();
  }
  expectIdentical(snapshot(t), before, "a shape no add call would take");
  EXPECT_NO_THROW(t.scene.loadFromMemory(good));
}

// A particle far outside the grid, or at NaN, is outside without overflowing the stencil's
// int base (UBSan, in the ASan tree: fuzz_checkpoint's loaded velocity of 1e28 put a
// particle at 8.7e23 in the first substep and the divergence check itself converted it to
// int; a NaN state reached P2G's stencil in the next substep).
TEST(SceneCheckpointFields, StencilInsideRefusesFarPositionsInFloats) {
  GridGeometry g;
  g.lower = {-0.1f, -0.1f, -0.1f};
  g.dx = 0.02f;
  g.invDx = 50.f;
  g.cells[0] = g.cells[1] = g.cells[2] = 10;
  EXPECT_TRUE(g.stencilInside({0.f, 0.f, 0.f}));
  for (const float far : {8.7e23f, -2e31f, std::numeric_limits<float>::infinity(), std::nanf("")}) {
    EXPECT_FALSE(g.stencilInside({far, 0.f, 0.f})) << far;
    EXPECT_FALSE(g.stencilInside({0.f, 0.f, far})) << far;
    int base[3];
    Vec3f fx;
    g.stencilBase({far, far, far}, base, fx);
    EXPECT_FALSE(g.baseInside(base)) << far;
  }
  EXPECT_FALSE(g.stencilInside({0.f, 0.1f, 0.f}));  // on the upper face: the stencil reaches past it
}

// On the CUDA backend the grid sums with float atomics, in no fixed order: a restored run
// follows the uninterrupted one within rounding, not bit for bit. A CUDA checkpoint also
// loads into a CPU scene (the backend is an execution setting).
TEST_P(SceneCheckpoint, CudaRestoredRunFollowsWithinRounding) {
  if (!cudaDeviceAvailable()) GTEST_SKIP() << "no CUDA device: the CUDA checkpoint run is skipped";
  auto cudaScene = [&] {
    auto t = std::make_unique<TestScene>(GetParam());
    SceneSettings s = t->scene.settings();
    s.backend = Backend::Cuda;
    t->scene = Scene(s);
    return t;
  };
  auto original = cudaScene();
  TestScene reference(GetParam());  // the objects and shapes, built in a CPU scene
  original->scene.loadFromMemory(reference.scene.saveToMemory());  // and moved to the GPU
  original->block = reference.block;
  original->ball = reference.ball;
  run(*original, 3);
  const std::vector<uint8_t> saved = original->scene.saveToMemory();
  run(*original, 6);
  const Snapshot uninterrupted = snapshot(*original);
  auto restored = cudaScene();
  restored->scene.loadFromMemory(saved);
  restored->block = reference.block;
  restored->ball = reference.ball;
  run(*restored, 6);
  const Snapshot again = snapshot(*restored);
  ASSERT_EQ(again.x.size(), uninterrupted.x.size());
  float worst = 0;
  for (size_t i = 0; i < again.x.size(); ++i) worst = std::fmax(worst, norm(again.x[i] - uninterrupted.x[i]));
  std::printf("%s on CUDA: restored run within %.3g m of the uninterrupted one\n", test::solverName(GetParam()).c_str(),
              worst);
  EXPECT_LT(worst, 1e-5f);
  EXPECT_NO_THROW(TestScene(GetParam()).scene.loadFromMemory(saved)) << "a CUDA checkpoint loads on the CPU";
}

INSTANTIATE_TEST_SUITE_P(EverySolver, SceneCheckpoint, test::everySolver(), test::solverParamName());

// ---- a coupled scene: tissue on Bullet's ground, a box and a two-link chain dropped on it ----

struct CoupledScene {
  Scene scene{sceneSettings(SolverType::MlsMpm)};
  test::BulletWorld bw{test::WorldType::MultiBody, 9.81f};
  bullet::Coupler coupler{bw.world.get(), scene};
  btRigidBody* box;
  btMultiBody* chain;
  explicit CoupledScene(bool withChain = true) {
    ParticleObjectDesc d;
    d.center = {0.f, 0.03f, 0.f};
    d.halfExtents = {0.06f, 0.03f, 0.06f};
    d.material.youngsModulus = 3e4f;
    scene.addParticleObject(d);
    coupler.addRigidBody(bw.addGround());
    box = bw.addBody(new btBoxShape(btVector3(0.015f, 0.01f, 0.015f)), 0.02f,
                     btTransform(btQuaternion(btVector3(0, 0, 1), 0.3f), btVector3(-0.03f, 0.09f, 0)));
    coupler.addRigidBody(box);
    chain = withChain ? bw.addCapsuleChain(2, 0.006f, 0.02f, 0.01f, btVector3(0.0f, 0.1f, 0.04f)) : nullptr;
    if (chain) coupler.addMultiBody(chain);
  }
  void run(int frames) {
    for (int f = 0; f < frames; ++f) {
      bw.world->stepSimulation(1.f / 60, 4, 1.f / 240);
      coupler.rethrowError();
    }
  }
};

/// The coupled bodies' poses and velocities, bit for bit.
std::vector<btScalar> bodyState(const CoupledScene& c) {
  std::vector<btScalar> out;
  auto add = [&](const btVector3& v) { out.insert(out.end(), {v.x(), v.y(), v.z()}); };
  for (int r = 0; r < 3; ++r) add(c.box->getWorldTransform().getBasis()[r]);
  add(c.box->getWorldTransform().getOrigin());
  add(c.box->getLinearVelocity());
  add(c.box->getAngularVelocity());
  if (!c.chain) return out;
  add(c.chain->getBasePos());
  add(c.chain->getBaseVel());
  add(c.chain->getBaseOmega());
  for (int k = 0; k < 4; ++k) out.push_back(c.chain->getWorldToBaseRot()[k]);
  for (int k = 0; k < 4; ++k) out.push_back(c.chain->getJointPosMultiDof(0)[k]);
  for (int k = 0; k < 3; ++k) out.push_back(c.chain->getJointVelMultiDof(0)[k]);
  return out;
}

TEST(CouplerCheckpoint, RewindsTheBulletBodiesWithTheTissue) {
  CoupledScene c;
  c.run(12);  // the box and the chain land on the tissue
  const std::vector<uint8_t> saved = c.coupler.saveToMemory();
  const std::vector<btScalar> savedBodies = bodyState(c);
  const btVector3 savedLink = c.chain->getLinkCollider(0)->getWorldTransform().getOrigin();
  const double savedTime = c.scene.time();
  c.run(12);
  ASSERT_NE(bodyState(c), savedBodies) << "the bodies must have moved on";

  c.coupler.loadFromMemory(saved);
  EXPECT_EQ(bodyState(c), savedBodies) << "poses and velocities put back bit for bit";
  EXPECT_EQ(c.scene.time(), savedTime);
  // the chain's link colliders follow its joints at once (forward kinematics): where it was
  const btVector3 linkOrigin = c.chain->getLinkCollider(0)->getWorldTransform().getOrigin();
  EXPECT_LT((linkOrigin - savedLink).length(), 1e-6f) << "the link collider was not moved back with its joint";
  c.run(12);
  const std::vector<btScalar> again = bodyState(c);
  // and step on bit for bit as the run that was not rewound: nothing here has contacts of
  // Bullet's own (their warm-start caches are not kept). Failed before the restored box's
  // world inertia was updated (Bullet recomputes it from the orientation only when it
  // integrates): it turned with the inertia of its later orientation.
  CoupledScene reference;
  reference.run(24);
  EXPECT_EQ(again, bodyState(reference));

  // a coupler of other bodies refuses it and changes nothing
  CoupledScene noChain(false);
  noChain.run(2);
  const double before = noChain.scene.time();
  const btTransform boxBefore = noChain.box->getWorldTransform();
  try {
    noChain.coupler.loadFromMemory(saved);
    ADD_FAILURE() << "a checkpoint of other bodies was accepted";
  } catch (const CheckpointError& e) {
    EXPECT_EQ(e.reason(), Reason::Unsupported) << e.what();
  }
  EXPECT_EQ(noChain.scene.time(), before);
  EXPECT_TRUE(noChain.box->getWorldTransform().getOrigin() == boxBefore.getOrigin());
}

}  // namespace
}  // namespace mpm
