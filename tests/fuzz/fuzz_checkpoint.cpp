// libFuzzer target: the checkpoint loader (Scene::loadFromMemory). The input is a
// checkpoint's payload; the target wraps it in a valid header (magic, version, CRC-32,
// length), so the fuzzer's bytes reach the section parser instead of stopping at the
// checksum. A loaded scene is stepped once (if that takes at most 100 substeps), so a
// checkpoint whose fields pass the loader
// but break the solver (indices, sizes) shows too. mpm::Error is the loader's answer to
// bad bytes; any other exception, a crash or a sanitizer report is a finding.
//
// MPM_FUZZ_WRITE_SEEDS=DIR writes the seed corpus (payloads of small scenes) and exits.
#include <zlib.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "mpm/checkpoint_io.h"
#include "mpm/curves.h"
#include "mpm/error.h"
#include "mpm/scene.h"
#include "mpm/slicers.h"

namespace {

mpm::SceneSettings settings() {
  mpm::SceneSettings s;
  s.domain = {{-0.1f, -0.1f, -0.1f}, {0.1f, 0.1f, 0.1f}};
  s.dx = 0.02f;
  s.backend = mpm::Backend::Cpu;
  s.cpuThreads = 1;
  return s;
}

std::vector<uint8_t> withHeader(const uint8_t* payload, size_t n) {
  using namespace mpm::checkpoint;
  std::vector<uint8_t> file(kHeaderBytes + n);
  const uint32_t crc = (uint32_t)crc32_z(crc32_z(0L, Z_NULL, 0), payload, n);
  const uint64_t size = n;
  std::memcpy(file.data(), kMagic, 8);
  std::memcpy(file.data() + 8, &kFormatVersion, 4);
  std::memcpy(file.data() + 12, &crc, 4);
  std::memcpy(file.data() + 16, &size, 8);
  if (n) std::memcpy(file.data() + kHeaderBytes, payload, n);
  return file;
}

/// Seeds: a block alone; a block with a box shape and a blade; with a needle and a thread.
void writeSeeds(const std::string& dir) {
  for (int kind = 0; kind < 3; ++kind) {
    mpm::Scene scene(settings());
    mpm::ParticleObjectDesc block;
    block.halfExtents = {0.02f, 0.02f, 0.02f};
    block.particlesPerCellAxis = 1;
    scene.addParticleObject(block);
    if (kind >= 1) {
      mpm::ShapeDesc box;
      box.parts = {mpm::Geometry::box({0.05f, 0.01f, 0.05f})};
      box.pose.position = {0.f, -0.04f, 0.f};
      scene.addShape(box);
      mpm::QuadSlicerDesc blade;
      blade.halfLength = 0.03f;
      blade.pose.position = {0.f, 0.01f, 0.f};
      scene.addSlicer(blade);
    }
    if (kind == 2) {
      mpm::ArcDesc arc;
      arc.pose.position = {0.f, 0.03f, 0.f};
      scene.addCurve(arc);
      mpm::LineSegmentsDesc thread;
      thread.points = {{-0.03f, 0.03f, 0.f}, {-0.02f, 0.03f, 0.f}, {-0.01f, 0.03f, 0.f}};
      thread.linearDensity = 1e-3f;
      scene.addCurve(thread);
    }
    scene.step(1e-3f);
    const std::vector<uint8_t> file = scene.saveToMemory();
    std::ofstream(dir + "/seed" + std::to_string(kind), std::ios::binary)
        .write((const char*)file.data() + mpm::checkpoint::kHeaderBytes,
               (std::streamsize)(file.size() - mpm::checkpoint::kHeaderBytes));
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  if (const char* dir = std::getenv("MPM_FUZZ_WRITE_SEEDS")) {
    writeSeeds(dir);
    std::exit(0);
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static mpm::Scene scene(settings());  // one scene, reused: a refused load changes nothing
  try {
    scene.loadFromMemory(withHeader(data, size));
    // a checkpoint may hold a fast particle (its speed is state): the step it asks for is
    // slow, not wrong, so only steps of up to 100 substeps are taken
    if (1e-4f <= 100.f * scene.maxSubstep()) scene.step(1e-4f);
  } catch (const mpm::Error&) {
  }
  return 0;
}
