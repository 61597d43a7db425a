#pragma once
// What every benchmark report shares: the machine and build it ran on, the command that
// made it, number formatting and writing the result files.
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "mpm/error.h"
#include "mpm/math.h"

namespace mpm::bench {

#if defined(__clang__)
constexpr const char* kCompiler = "Clang " __clang_version__;
#elif defined(__GNUC__)
constexpr const char* kCompiler = "GCC " __VERSION__;
#else
constexpr const char* kCompiler = "unknown";
#endif

/// FNV-1a of the bytes of a run's final particle positions: an optimisation meant to leave
/// the physics alone must print the same value as the build before it (same compiler flags:
/// under -march=native the compiler's contraction to fused multiply-adds follows inlining,
/// so compare x86-64 baseline builds, MPM_NATIVE_ARCH=OFF).
inline uint64_t positionsHash(const std::vector<Vec3f>& x) {
  uint64_t h = 1469598103934665603ull;
  const unsigned char* bytes = reinterpret_cast<const unsigned char*>(x.data());
  for (size_t i = 0; i < x.size() * sizeof(Vec3f); ++i) h = (h ^ bytes[i]) * 1099511628211ull;
  return h;
}

inline std::string num(double v, int decimals) {
  if (std::isnan(v)) return "–";
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", decimals, v);
  return text;
}

inline std::string cpuModel() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("model name", 0) != 0) continue;
    const size_t colon = line.find(':');
    if (colon != std::string::npos) return line.substr(line.find_first_not_of(" \t", colon + 1));
  }
  return "unknown";
}

/// This machine's results path stem for a benchmark, bench/results/<machine>/<bench>, the
/// machine named by bench/machine.sh (run from the repository's root, as the stems are
/// relative to it; "unknown" when it cannot run); gpu names the GPU instead of the CPU.
inline std::string resultsStem(const std::string& bench, bool gpu = false) {
  std::string machine;
  if (FILE* p = popen(gpu ? "bench/machine.sh --gpu 2>/dev/null" : "bench/machine.sh 2>/dev/null", "r")) {
    char text[128];
    while (std::fgets(text, sizeof text, p)) machine += text;
    pclose(p);
  }
  while (!machine.empty() && (machine.back() == '\n' || machine.back() == ' ')) machine.pop_back();
  return "bench/results/" + (machine.empty() ? std::string("unknown") : machine) + "/" + bench;
}

inline std::string loadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string one;
  in >> one;
  return one.empty() ? "?" : one;
}

inline std::string localDate() {
  const std::time_t now = std::time(nullptr);
  char text[64];
  std::strftime(text, sizeof text, "%Y-%m-%d %H:%M:%S %Z", std::localtime(&now));
  return text;
}

/// argv as a shell would need it typed back.
inline std::string commandLine(int argc, char** argv) {
  std::string line;
  for (int i = 0; i < argc; ++i) {
    std::string a = argv[i];
    const bool plain = !a.empty() && a.find_first_not_of(
                                         "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                         "0123456789_-+=.,/:") == std::string::npos;
    if (!plain) {
      std::string quoted = "'";
      for (char c : a) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
      a = quoted + "'";
    }
    line += (i ? " " : "") + a;
  }
  return line;
}

/// Context a reader needs to compare these numbers with others.
struct RunInfo {
  std::string date, cpu, command, loadBefore;
  unsigned hardwareThreads = 0;
  bool complete = false;

  /// The machine and command now, before the runs.
  static RunInfo now(int argc, char** argv) {
    RunInfo info;
    info.date = localDate();
    info.cpu = cpuModel();
    info.command = commandLine(argc, argv);
    info.loadBefore = loadAverage();
    info.hardwareThreads = std::thread::hardware_concurrency();
    return info;
  }

  /// The report's title and the lines that say where and how it was measured; `build` is
  /// the build type the benchmark was compiled with.
  std::string header(const std::string& title, const std::string& build) const {
    std::string h = "# " + title + "\n\n";
    if (!complete) h += "**Incomplete: the run stopped or is still going; rows so far.**\n\n";
    h += "- Date: " + date + "\n";
    h += "- CPU: " + cpu + " (" + std::to_string(hardwareThreads) + " hardware threads)\n";
    h += "- Build: " + build + ", compiler " + kCompiler + "\n";
    h += "- Command: `" + command + "`\n";
    h += "- Load average (1 min) before / after: " + loadBefore + " / " + loadAverage() + "\n\n";
    return h;
  }
};

inline void writeFile(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f << text;
  if (!f) throw mpm::Error("cannot write " + path);
}

/// Writes each (suffix, text) to <stem><suffix>, making the stem's folder first.
inline void writeResultFiles(const std::string& stem,
                             std::initializer_list<std::pair<const char*, std::string>> files) {
  const std::filesystem::path path(stem);
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path());
  for (const auto& [suffix, text] : files) writeFile(stem + suffix, text);
}

}  // namespace mpm::bench
