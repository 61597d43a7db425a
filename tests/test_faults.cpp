// Faults inside an advance: memory running out on any thread, blow-ups that stay finite,
// reads from other threads while an advance runs, and an advance stopped by cancel().
// Each case that could crash or hang runs in a forked child under an alarm.
#include <gtest/gtest.h>
#include <malloc.h>
#include <sys/resource.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "backend/cpu/thread_team.h"
#include "forked_child.h"
#include "mpm/scene.h"

namespace mpm {
namespace {

using test::expectChildSucceeded;
using test::forkChild;

SceneSettings boxSettings(int threads) {
  SceneSettings s;
  s.domain.lower = {-0.5f, 0.f, -0.5f};
  s.domain.upper = {0.5f, 1.f, 0.5f};
  s.dx = 0.05f;
  s.backend = Backend::Cpu;
  s.cpuThreads = threads;
  return s;
}

ParticleObjectDesc block(Vec3f center, float half, int perCell = 2) {
  ParticleObjectDesc d;
  d.center = center;
  d.halfExtents = {half, half, half};
  d.particlesPerCellAxis = perCell;
  return d;
}

/// The largest and smallest volume ratio J = det F of an object's particles; NaN if any is not finite.
std::pair<float, float> volumeRatioRange(const Scene& scene, ParticleObjectId id) {
  std::vector<Mat3f> F;
  scene.readDeformationGradients(id, F);
  float lo = INFINITY, hi = -INFINITY;
  for (const Mat3f& f : F) {
    const float J = determinant(f);
    if (!std::isfinite(J)) return {NAN, NAN};
    lo = std::min(lo, J);
    hi = std::max(hi, J);
  }
  return {lo, hi};
}

/// Address space this process maps now [bytes] (VmSize).
size_t mappedBytes() {
  std::ifstream status("/proc/self/status");
  std::string key;
  for (size_t kb; status >> key;) {
    if (key == "VmSize:" && status >> kb) return kb * 1024;
    status.ignore(1 << 20, '\n');
  }
  return 0;
}

/// Bit for bit the same positions.
bool same(const std::vector<Vec3f>& a, const std::vector<Vec3f>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3f)) == 0;
}

void limitAddressSpace(rlim_t bytes) {
  rlimit r{};
  getrlimit(RLIMIT_AS, &r);
  r.rlim_cur = bytes;
  setrlimit(RLIMIT_AS, &r);
}

// A team member that throws hands its exception to the caller once every member has left
// the job, a member waiting at a barrier for it included; the team runs on afterwards.
// Before, the worker's exception reached std::terminate (SIGABRT in the child).
TEST(Faults, ATeamMemberThatThrowsHandsItsErrorToTheCaller) {
  expectChildSucceeded(forkChild([] {
    ThreadTeam team;
    for (int thrower = 0; thrower < 2; ++thrower) {
      try {
        team.run(2, [&](int t, int nt) {
          if (t == thrower) throw std::runtime_error("member failed");
          team.barrier(nt);  // waits for the member that threw: must not hang
        });
        return 1;
      } catch (const std::runtime_error& e) {
        if (std::strcmp(e.what(), "member failed") != 0) return 2;
      }
      std::atomic<int> ran{0};
      team.run(2, [&](int, int nt) {
        team.barrier(nt);
        ran.fetch_add(1);
      });
      if (ran.load() != 2) return 3;
    }
    return 0;
  }), "1: no error; 2: another error; 3: the team did not run on");
}

// Memory running out in a two-thread advance (the copy of the particles' state kept to
// undo it does not fit) is an OutOfMemory error naming what and how many bytes; the scene
// is bit for bit as before the advance and steps on once memory allows. Before, the
// allocation failed in one of the team's tasks and ended the process.
TEST(Faults, OutOfMemoryInATwoThreadAdvanceLeavesTheSceneAsBefore) {
  expectChildSucceeded(forkChild([] {
    // large blocks mapped on their own and unmapped when freed: memory freed before the
    // limit cannot serve the copy, so the mapped size is what the process can use
    mallopt(M_MMAP_THRESHOLD, 1 << 16);
    Scene scene(boxSettings(2));
    scene.addParticleObject(block({-0.25f, 0.3f, 0.f}, 0.12f, 8));
    scene.step(1e-3f);  // the team, the bins and the copy of this many particles exist now
    // the copy must grow by more than the memory freed in adding them (the old fields and copy)
    scene.addParticleObject(block({0.2f, 0.5f, 0.f}, 0.18f, 8));
    const std::vector<uint8_t> before = scene.saveToMemory();
    const size_t particles = scene.particleCount();
    limitAddressSpace(mappedBytes() + 8 * particles);  // far less than the copy's ~200 bytes a particle
    int code = 1;
    try {
      scene.step(1e-3f);
    } catch (const OutOfMemory& e) {
      code = std::strstr(e.what(), "out of memory") ? 0 : 2;
    } catch (...) {
      code = 2;
    }
    limitAddressSpace(RLIM_INFINITY);
    if (code) return code;
    if (scene.saveToMemory() != before) return 3;
    try {
      scene.step(1e-3f);
    } catch (...) {
      return 4;
    }
    return scene.time() > 1e-3 ? 0 : 5;
  }), "1: the advance ran; 2: another error; 3: the scene changed; 4: it did not step on; 5: no time passed");
}

// The copy's allocation names the particles and the bytes it wanted.
TEST(Faults, OutOfMemoryNamesTheAllocationAndItsBytes) {
  const OutOfMemory e("the copy of 10 particles' state kept to undo the advance", 2000);
  EXPECT_EQ(e.bytes(), 2000u);
  EXPECT_NE(std::string(e.what()).find("2000 bytes"), std::string::npos) << e.what();
  EXPECT_NE(std::string(e.what()).find("the copy of 10 particles"), std::string::npos) << e.what();
}

// A fixed substep 1.5 times MLS-MPM's largest stable one (1.06 dx / c_p: the step sweep of
// bench_stability) blows up while every value stays finite. With recovery, no advance may
// be accepted whose tissue has collapsed or blown up: each ends within the volume bounds
// or fails (and is then undone). Before, the block collapsed to J = 0 without an error.
TEST(Faults, ASubstepBeyondItsStableLimitIsNeverAccepted) {
  SceneSettings s = boxSettings(1);
  s.gravity = {0.f, -9.81f, 0.f};
  ParticleObjectDesc d = block({0.f, 0.2f, 0.f}, 0.1f);
  d.material.youngsModulus = 1e5f;
  d.velocity = {0.f, -1.f, 0.f};
  const float cp = std::sqrt(d.material.youngsModulus * (1 - 0.3f) / ((1 + 0.3f) * (1 - 0.6f) * 1000.f));
  const float substep = 1.5f * 1.06f * s.dx / cp;
  s.substeps.fixedSubsteps = 1;
  s.recovery.enabled = true;
  Scene scene(s);
  const ParticleObjectId id = scene.addParticleObject(d);
  int failed = 0, accepted = 0, halved = 0;
  for (int frame = 0; frame < 300; ++frame) {
    try {
      halved += scene.step(substep).halvings > 0;
      ++accepted;
    } catch (const SimulationDiverged&) {
      ++failed;
      break;  // it stays failed: the same advance fails again
    }
    const auto [lo, hi] = volumeRatioRange(scene, id);
    ASSERT_TRUE(lo > kMinVolumeRatio && hi < kMaxVolumeRatio)
        << "frame " << frame << " accepted with J in [" << lo << ", " << hi << "]";
  }
  EXPECT_GT(halved + failed, 0) << "the substep beyond the limit never failed a check";
  std::printf("[ info ] 1.5x the stable substep: %d advances accepted (%d after halving), %d failed\n", accepted,
              halved, failed);
}

// A particle moving more than a cell in one substep breaks the transfers' assumption: the
// advance fails naming the particle, its object and the cause; allowing 3 cells it runs.
TEST(Faults, AParticleFasterThanACellPerSubstepFailsTheAdvance) {
  SceneSettings s = boxSettings(1);
  s.gravity = {0.f, 0.f, 0.f};
  s.substeps.fixedSubsteps = 1;
  ParticleObjectDesc d = block({0.f, 0.5f, 0.f}, 0.1f);
  d.velocity = {10.f, 0.f, 0.f};  // 0.01 s: 2 cells of 5 cm
  {
    Scene scene(s);
    const ParticleObjectId id = scene.addParticleObject(d);
    std::vector<Vec3f> x0;
    scene.readPositions(id, x0);
    try {
      scene.step(0.01f);
      ADD_FAILURE() << "a step moving the block 2 cells was accepted";
    } catch (const SimulationDiverged& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find("of object 0"), std::string::npos) << m;
      EXPECT_NE(m.find("cells in one substep"), std::string::npos) << m;
      EXPECT_NE(m.find("maxCellsPerSubstep"), std::string::npos) << m;
    }
    std::vector<Vec3f> x1;
    scene.readPositions(id, x1);
    EXPECT_EQ(x1[0].x, x0[0].x) << "the failed advance was undone";
    EXPECT_EQ(scene.time(), 0.0);
  }
  s.divergenceCheck.maxCellsPerSubstep = 3.f;
  Scene scene(s);
  scene.addParticleObject(d);
  EXPECT_NO_THROW(scene.step(0.01f));
}

// A kinematic tool driven at 1e4 m/s through a block under the default substep policy,
// with the energy check and recovery on: no advance is accepted with the tissue collapsed.
// Before, each frame was accepted with particles at J <= 0 (measured: -1.2e-7 in the first).
TEST(Faults, AToolAtTenKilometresPerSecondNeverLeavesCollapsedTissue) {
  SceneSettings s = boxSettings(1);
  s.energyCheck.enabled = true;
  s.recovery.enabled = true;
  Scene scene(s);
  const ParticleObjectId id = scene.addParticleObject(block({0.f, 0.3f, 0.f}, 0.1f));
  ShapeDesc tool;
  tool.parts = {Geometry::sphere(0.04f)};
  tool.pose.position = {-0.2f, 0.3f, 0.f};
  tool.linearVelocity = {1e4f, 0.f, 0.f};
  scene.addShape(tool);
  int failed = 0;
  for (int frame = 0; frame < 2; ++frame) {
    try {
      scene.step(1e-3f);  // the tool passes through the block within the first frame
    } catch (const SimulationDiverged&) {
      ++failed;
      continue;
    }
    const auto [lo, hi] = volumeRatioRange(scene, id);
    ASSERT_TRUE(lo > kMinVolumeRatio && hi < kMaxVolumeRatio)
        << "frame " << frame << " accepted with J in [" << lo << ", " << hi << "]";
  }
  std::printf("[ info ] tool at 1e4 m/s: %d of 2 advances failed\n", failed);
}

// While an advance runs, a read from another thread is refused (StepInProgress) or sees a
// whole frame, never one the advance is writing. Before, the "step running" flag was
// cleared as fetchResults began to wait: reads then saw half-written frames.
TEST(Faults, ReadsFromAnotherThreadSeeWholeFramesOnly) {
  SceneSettings s = boxSettings(2);
  Scene scene(s);
  const ParticleObjectId id = scene.addParticleObject(block({0.f, 0.5f, 0.f}, 0.1f));
  std::vector<std::vector<Vec3f>> frames(1);
  scene.readPositions(id, frames[0]);
  std::atomic<bool> done{false};
  std::vector<std::vector<Vec3f>> seen;
  int refused = 0, reads = 0;
  std::thread reader([&] {
    std::vector<Vec3f> x;
    for (; reads < 10000; ++reads) {
      try {
        scene.readPositions(id, x);
        if (seen.empty() || !same(seen.back(), x)) seen.push_back(x);
      } catch (const StepInProgress&) {
        ++refused;
      }
      std::this_thread::sleep_for(std::chrono::microseconds(20));
    }
    done.store(true);
  });
  while (!done.load() && frames.size() < 20000) {
    scene.advance(2e-3f);
    scene.fetchResults();
    frames.emplace_back();
    scene.readPositions(id, frames.back());
    std::this_thread::sleep_for(std::chrono::microseconds(50));  // a window between advances
  }
  reader.join();
  int torn = 0;
  for (const std::vector<Vec3f>& x : seen) {
    bool whole = false;
    for (const std::vector<Vec3f>& f : frames) whole = whole || same(f, x);
    torn += !whole;
  }
  EXPECT_EQ(torn, 0) << "of " << seen.size() << " distinct reads";
  EXPECT_GT(seen.size(), 1u) << "the reader saw the advances";
  std::printf("[ info ] %d reads: %d refused, %zu distinct frames seen, %d torn\n", reads, refused, seen.size(),
              torn);
}

// cancel() from another thread stops a long advance at a substep boundary: its fetch
// throws AdvanceCancelled and the scene is as before it, then steps on. Before, an
// advance of a million substeps could not be stopped.
TEST(Faults, CancelStopsALongAdvanceAndLeavesTheSceneAsBefore) {
  expectChildSucceeded(forkChild([] {
    SceneSettings s = boxSettings(1);
    s.substeps.fixedSubsteps = 1000000;  // about an hour here
    Scene scene(s);
    const ParticleObjectId id = scene.addParticleObject(block({0.f, 0.5f, 0.f}, 0.1f));
    std::vector<Vec3f> before, after;
    scene.readPositions(id, before);
    scene.advance(1.f);
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    std::thread canceller([&] { scene.cancel(); });
    canceller.join();
    try {
      scene.fetchResults();
      return 1;
    } catch (const AdvanceCancelled& e) {
      if (!std::strstr(e.what(), "substeps")) return 2;
    } catch (...) {
      return 2;
    }
    scene.readPositions(id, after);
    if (!same(after, before) || scene.time() != 0.0) return 3;
    scene.cancel();  // with no advance running: nothing to stop
    return scene.maxSubstep() > 0.f ? 0 : 4;
  }), "1: the advance ran to its end; 2: another error; 3: the scene changed; 4: not usable");
}

// Every call that reads or changes the scene is refused with StepInProgress during an
// advance, from the thread that started it and from any other.
TEST(Faults, CallsDuringAnAdvanceAreRefusedWithStepInProgress) {
  Scene scene(boxSettings(1));
  const ParticleObjectId id = scene.addParticleObject(block({0.f, 0.5f, 0.f}, 0.1f));
  scene.advance(0.01f);
  std::vector<Vec3f> x;
  EXPECT_THROW(scene.readPositions(id, x), StepInProgress);
  EXPECT_THROW(scene.particleCount(), StepInProgress);
  EXPECT_THROW(scene.saveToMemory(), StepInProgress);
  std::thread other([&] {
    EXPECT_THROW(scene.summary(id), StepInProgress);
    EXPECT_THROW(scene.addParticleObject(block({0.3f, 0.5f, 0.f}, 0.05f)), StepInProgress);
  });
  other.join();
  scene.fetchResults();
  EXPECT_NO_THROW(scene.readPositions(id, x));
}

}  // namespace
}  // namespace mpm
