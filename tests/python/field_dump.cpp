// field_dump SCENE.json DT STEPS: loads a scene file (mpm_bullet/scene_file.h), steps its
// scene STEPS times by DT and writes every object's positions, velocities and deformation
// gradients to stdout as raw float32 (objects in file order; per object N x 3, N x 3,
// N x 9). tests/python/test_arrays.py compares them with the Python module's arrays of the
// same scene built from dicts: the same readers, the same reads, bit for bit.
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <vector>

#include "mpm_bullet/scene_file.h"

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: field_dump SCENE.json DT STEPS\n");
    return 2;
  }
  try {
    auto loaded = mpm::bullet::LoadedScene::fromFile(argv[1]);
    mpm::Scene& scene = loaded->scene();
    char* end = nullptr;
    const float dt = std::strtof(argv[2], &end);
    if (*end || !(dt > 0.f)) {
      std::fprintf(stderr, "field_dump: DT = %s: must be a number > 0\n", argv[2]);
      return 2;
    }
    const long steps = std::strtol(argv[3], &end, 10);
    if (*end || steps < 0) {
      std::fprintf(stderr, "field_dump: STEPS = %s: must be an integer >= 0\n", argv[3]);
      return 2;
    }
    for (long i = 0; i < steps; ++i) scene.step(dt);
    std::vector<mpm::Vec3f> v;
    std::vector<mpm::Mat3f> F;
    for (mpm::ParticleObjectId id : scene.particleObjects()) {
      scene.readPositions(id, v);
      std::fwrite(v.data(), sizeof(mpm::Vec3f), v.size(), stdout);
      scene.readVelocities(id, v);
      std::fwrite(v.data(), sizeof(mpm::Vec3f), v.size(), stdout);
      scene.readDeformationGradients(id, F);
      std::fwrite(F.data(), sizeof(mpm::Mat3f), F.size(), stdout);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "field_dump: %s\n", e.what());
    return 1;
  }
  return 0;
}
