// Coupling demo: runs assets/scenes/coupling.json: three rigid boxes, light, equal and heavy
// relative to the tissue under them (0.05, 0.5, 5 kg), dropped on a soft slab that lies on
// a Bullet ground; Bullet steps the boxes and the coupler advances the tissue with every
// internal tick. Writes the file's frames (PNG, PLY) and frames.csv (each box's position
// over time) to --out, and prints where each box comes to rest: heavier boxes sink deeper.
#include <CLI/CLI.hpp>
#include <btBulletDynamicsCommon.h>

#include <cstdio>
#include <string>

#include "../scene_runner.h"

int main(int argc, char** argv) {
  CLI::App app{"Rigid boxes of different masses on a soft tissue slab (Bullet + MPM)"};
  std::string scenePath = MPM_ASSETS_DIR "/scenes/coupling.json";
  demo::SceneOptions options;
  options.out = "out/coupling";
  int frames = -1;
  app.add_option("--scene", scenePath, "the scene file");
  options.add(app);
  app.add_option("--frames", frames, "frames to run (default: the file's output.frames)")->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);

  try {
    auto loaded = mpm::bullet::LoadedScene::fromFile(scenePath, options.overrides());
    const char* boxes[3] = {"light", "equal", "heavy"};
    std::printf("coupling: %zu tissue particles, boxes of %g / %g / %g kg\n", loaded->scene().particleCount(),
                1 / loaded->body(boxes[0])->getInvMass(), 1 / loaded->body(boxes[1])->getInvMass(),
                1 / loaded->body(boxes[2])->getInvMass());
    demo::runFrames(*loaded, options.out, frames < 0 ? loaded->frameCount() : frames, "coupling");
    for (const char* name : boxes) {
      const btRigidBody* box = loaded->body(name);
      std::printf("%s box (%g kg): rests at y = %.4f m\n", name, 1 / box->getInvMass(), box->getCenterOfMassPosition().y());
    }
    std::printf("frames, pictures and frames.csv in %s/\n", options.out.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "coupling: %s\n", e.what());
    return 1;
  }
  return 0;
}
