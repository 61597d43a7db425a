#pragma once
// What every demo that runs a scene file shares (mpm_run and the thin demos): the command
// line's options as merge patches over the file, and the frame loop writing frames.csv
// (the file's columns) and, when the file's output asks, PNG and PLY frames.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "mpm/output.h"
#include "mpm_bullet/scene_file.h"

namespace demo {

/// Options every scene-file demo takes; each becomes a merge patch over the file.
struct SceneOptions {
  std::string out;
  int threads = -1, pngEvery = -1;
  bool noPly = false;
  std::vector<std::string> patches;  ///< --set, in order

  void add(CLI::App& app) {
    app.add_option("--out", out, "output folder: frames.csv, frame_NNNN.png, frame_NNNN.ply (tissue), frame_NNNN_tools.ply");
    app.add_option("--threads", threads, "CPU threads (0 = all; default: the file's settings.cpuThreads)")
        ->check(CLI::NonNegativeNumber);
    app.add_option("--png-every", pngEvery, "a picture (and PLY files) every N frames (0: none; default: the file's)")
        ->check(CLI::NonNegativeNumber);
    app.add_flag("--no-ply", noPly, "no PLY files beside the pictures (the file's output.ply: false)");
    app.add_option("--set", patches,
                   "a JSON merge patch over the scene file, e.g. '{\"settings\": {\"dx\": 0.005}}' (elements of "
                   "objects, bodies and threads by their name: '{\"objects\": [{\"name\": \"block\", ...}]}')");
  }
  /// The patches to load the file with: --set's, then the options'.
  std::vector<std::string> overrides() const {
    std::vector<std::string> all = patches;
    if (threads >= 0) all.push_back("{\"settings\": {\"cpuThreads\": " + std::to_string(threads) + "}}");
    if (pngEvery >= 0) all.push_back("{\"output\": {\"pngEvery\": " + std::to_string(pngEvery) + "}}");
    if (noPly) all.push_back(R"({"output": {"ply": false}})");
    return all;
  }
};

/// Frame `frame`'s files when due: frame_NNNN.ply and frame_NNNN_tools.ply, frame_NNNN.png.
inline void writeFrameFiles(const mpm::bullet::LoadedScene& loaded, const std::string& out) {
  char name[64];
  std::snprintf(name, sizeof name, "/frame_%04d", loaded.frame());
  if (loaded.plyDue()) loaded.writePly(out + name + ".ply", out + name + "_tools.ply");
  if (loaded.pngDue()) loaded.writePng(out + name + ".png");
}

/// Runs `frames` frames from where `loaded` is, with frames.csv and the frame files in
/// `out`; `afterFrame` (optional) runs after each frame's advance, before its files, and
/// once before the first.
inline void runFrames(mpm::bullet::LoadedScene& loaded, const std::string& out, int frames, const char* label,
                      const std::function<void()>& afterFrame = {}) {
  std::filesystem::create_directories(out);
  std::ofstream csv(out + "/frames.csv");
  csv << loaded.csvHeader() << "\n";
  mpm::io::ProgressBar progress(label, frames);
  for (int f = 0; f <= frames; ++f) {
    if (f > 0) loaded.advanceFrame();
    if (afterFrame) afterFrame();
    csv << loaded.csvRow() << "\n";
    writeFrameFiles(loaded, out);
    progress.update(f);
  }
  progress.finish();
}

}  // namespace demo
