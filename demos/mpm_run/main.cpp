// mpm_run: runs a scene file (mpm_bullet/scene_file.h, assets/scenes/) headless: the
// progress bar on the terminal, and in --out frames.csv, PNG frames and PLY frames beside
// them (--no-ply: none), optionally starting from and writing checkpoints. --check only
// loads and validates the file. Any error prints its message (naming the key path for a
// bad file) and exits with 1.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <string>

#include "../scene_runner.h"

int main(int argc, char** argv) {
  CLI::App app{"Runs a JSON scene file (Bullet + MPM) headless"};
  std::string scenePath, loadPath, savePath;
  demo::SceneOptions options;
  options.out = "out/run";
  int frames = -1;
  bool check = false;
  app.add_option("scene", scenePath, "the scene file (.json)")->required();
  options.add(app);
  app.add_option("--frames", frames, "frames to run (default: the file's output.frames)")->check(CLI::PositiveNumber);
  app.add_option("--load-checkpoint", loadPath, "start from this checkpoint (Coupler::save)");
  app.add_option("--save-checkpoint", savePath, "write a checkpoint after the last frame");
  app.add_flag("--check", check, "only load and validate the scene file");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 1;  // --help is not an error; a bad command line is one like any other
  }

  try {
    auto loaded = mpm::bullet::LoadedScene::fromFile(scenePath, options.overrides());
    if (check) {
      std::printf("%s: valid (%zu particles)\n", scenePath.c_str(), loaded->scene().particleCount());
      return 0;
    }
    if (frames < 0) frames = loaded->frameCount();
    if (!loadPath.empty()) loaded->loadCheckpoint(loadPath);
    std::printf("%s: %zu particles, frames %d to %d of %.4g s\n", scenePath.c_str(),
                loaded->scene().particleCount(), loaded->frame(), loaded->frame() + frames, loaded->frameTime());
    demo::runFrames(*loaded, options.out, frames, "mpm_run");
    if (!savePath.empty()) loaded->saveCheckpoint(savePath);
    std::printf("frames and frames.csv in %s/\n", options.out.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mpm_run: %s\n", e.what());
    return 1;
  }
  return 0;
}
