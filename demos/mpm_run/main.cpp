// mpm_run: runs a scene file (mpm_bullet/scene_file.h, assets/scenes/) headless: the
// progress bar on the terminal, PNG frames and a CSV in --out, and optionally starting from
// and writing checkpoints. --check only loads and validates the file. Any error prints its
// message (naming the key path for a bad file) and exits with 1.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "mpm/output.h"
#include "mpm_bullet/scene_file.h"

int main(int argc, char** argv) {
  CLI::App app{"Runs a JSON scene file (Bullet + MPM) headless"};
  std::string scenePath, out = "out/run", loadPath, savePath;
  int frames = -1, threads = -1;
  bool check = false;
  app.add_option("scene", scenePath, "the scene file (.json)")->required();
  app.add_option("--out", out, "output folder: frame_NNNN.png, frames.csv");
  app.add_option("--frames", frames, "frames to run (default: the file's output.frames)")->check(CLI::PositiveNumber);
  app.add_option("--threads", threads, "CPU threads (0 = all; default: the file's settings.cpuThreads)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--load-checkpoint", loadPath, "start from this checkpoint (Coupler::save)");
  app.add_option("--save-checkpoint", savePath, "write a checkpoint after the last frame");
  app.add_flag("--check", check, "only load and validate the scene file");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 1;  // --help is not an error; a bad command line is one like any other
  }

  try {
    // command-line settings go in as a merge patch over the file
    std::string overrides;
    if (threads >= 0) overrides = "{\"settings\": {\"cpuThreads\": " + std::to_string(threads) + "}}";
    auto loaded = mpm::bullet::LoadedScene::fromFile(scenePath, overrides);
    if (check) {
      std::printf("%s: valid (%zu particles)\n", scenePath.c_str(), loaded->scene().particleCount());
      return 0;
    }
    if (frames < 0) frames = loaded->frameCount();
    std::filesystem::create_directories(out);
    if (!loadPath.empty()) loaded->loadCheckpoint(loadPath);
    std::ofstream csv(out + "/frames.csv");
    csv << loaded->csvHeader() << "\n" << loaded->csvRow() << "\n";
    std::printf("%s: %zu particles, frames %d to %d of %.4g s\n", scenePath.c_str(),
                loaded->scene().particleCount(), loaded->frame(), loaded->frame() + frames, loaded->frameTime());
    char name[64];
    auto picture = [&] {
      if (!loaded->pngDue()) return;
      std::snprintf(name, sizeof name, "/frame_%04d.png", loaded->frame());
      loaded->writePng(out + name);
    };
    picture();
    mpm::io::ProgressBar progress("mpm_run", frames);
    for (int f = 1; f <= frames; ++f) {
      loaded->advanceFrame();
      csv << loaded->csvRow() << "\n";
      picture();
      progress.update(f);
    }
    progress.finish();
    if (!savePath.empty()) loaded->saveCheckpoint(savePath);
    std::printf("frames and frames.csv in %s/\n", out.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mpm_run: %s\n", e.what());
    return 1;
  }
  return 0;
}
