// Hertz contact (mpm::scenes::HertzIndentation): a rigid sphere pressed slowly into an
// elastic slab, force against depth compared with F_H = 4/3 E* sqrt(R) d^1.5 for
// d <= 0.1 R, at several grid resolutions. Prints a markdown table and writes it, with a
// header naming the machine and the command, to <out>.md, the table to <out>.csv and the
// averaged force-depth curves to <out>_curves.csv.
//
//   bench_hertz --resolutions 4,6,8 --out bench/results/<machine>/hertz
//
// The depth is resolved by a fraction of a cell at these resolutions (0.1 R is 0.4 dx at
// R = 4 dx), which is why this is a benchmark and not a test: tests/test_hertz.cpp runs the
// coarsest row with the tolerance this table justifies.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <exception>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>

#include "mpm/error.h"
#include "mpm/output.h"
#include "mpm/scene.h"
#include "bench_options.h"
#include "bench_report.h"
#include "scenes/standard_scenes.h"

namespace {

using namespace mpm::bench;

using mpm::scenes::HertzIndentation;
constexpr double kR = HertzIndentation::kRadius;


/// What the command line asks for.
struct Options {
  std::vector<int> resolutions{4, 6, 8};  ///< R / dx of the rows
  int threads = 0;                        ///< CPU threads; 0 = all
  mpm::Backend backend = mpm::Backend::Cpu;
  bool neoHookean = false;  ///< the slab's law: decoupled Neo-Hookean instead of fixed corotated
  float loadingTransits = 20.f;           ///< time from d = 0 to 0.1 R [H / c_p]
  float slab = 4.f;                       ///< slab half-width and thickness [R]
  int sensitivity = 0;  ///< R / dx of the loading-rate and slab-size rows; 0: none
  bool whole = false;   ///< the whole slab, not a quarter on mirror planes
  std::string runs;     ///< folder keeping each row's frames for reuse; "" = none
  std::string out = mpm::bench::resultsStem("hertz");  ///< path stem of the results
};

/// One run of the scene and what it measured.
struct Row {
  std::string variant;  ///< "" for the resolution study, else what was changed
  HertzIndentation::Run run;
  HertzIndentation::Comparison cmp;
  double wallSeconds = 0;
};


/// The file of `runs` that keeps the frames of a run of `setup` (every setting that changes
/// the result is in the name).
std::string runFile(const std::string& runs, const HertzIndentation::Setup& s) {
  char name[160];
  std::snprintf(name, sizeof name, "/r%d_slab%.4gx%.4g_load%.4g_%s%s%s.csv", s.cellsPerRadius, s.slabHalfWidth,
                s.slabThickness, s.loadingTransits, s.quarter ? "quarter" : "whole",
                s.material == mpm::MaterialModel::NeoHookeanDecoupled ? "_neo" : "",
                s.backend == mpm::Backend::Cuda ? "_cuda" : "");
  return runs + name;
}

void saveRun(const std::string& path, const Row& r) {
  std::ofstream f(path);
  f << "# particles,substeps,wall_s\n" << r.run.particles << ',' << r.run.substeps << ','
    << num(r.wallSeconds, 3) << "\n# phase,depth_m,force_N\n";
  char line[96];
  for (const auto* phase : {&r.run.approach, &r.run.loading})
    for (const HertzIndentation::Sample& s : *phase) {
      std::snprintf(line, sizeof line, "%s,%.17g,%.17g\n", phase == &r.run.approach ? "approach" : "loading",
                    s.depth, s.force);
      f << line;
    }
  if (!f) throw std::runtime_error("cannot write " + path);
}

/// Reads a run saved by saveRun into `r`; false if there is none.
bool loadRun(const std::string& path, Row& r) {
  std::ifstream f(path);
  if (!f) return false;
  std::string line;
  char comma;
  std::getline(f, line);
  if (!(f >> r.run.particles >> comma >> r.run.substeps >> comma >> r.wallSeconds))
    throw std::runtime_error("malformed run file " + path);
  std::getline(f, line);
  std::getline(f, line);
  while (std::getline(f, line)) {
    const size_t a = line.find(','), b = line.find(',', a + 1);
    if (a == std::string::npos || b == std::string::npos) throw std::runtime_error("malformed line in " + path);
    const HertzIndentation::Sample s{std::stod(line.substr(a + 1, b - a - 1)), std::stod(line.substr(b + 1))};
    (line.compare(0, a, "approach") == 0 ? r.run.approach : r.run.loading).push_back(s);
  }
  return true;
}

/// One row: the run kept in `runs` for this setup if there is one, else a new run (kept
/// there when `runs` is set).
Row runRow(const HertzIndentation::Setup& setup, const std::string& variant, const std::string& runs) {
  if (!runs.empty()) {
    Row kept;
    kept.variant = variant;
    kept.run.setup = setup;
    if (loadRun(runFile(runs, setup), kept)) {
      std::fprintf(stderr, "R/dx = %d: frames read from %s\n", setup.cellsPerRadius, runFile(runs, setup).c_str());
      kept.cmp = HertzIndentation::compare(kept.run);
      return kept;
    }
  }
  char label[96];
  std::snprintf(label, sizeof label, "R/dx = %d%s%s", setup.cellsPerRadius, variant.empty() ? "" : ", ",
                variant.c_str());
  std::unique_ptr<mpm::io::ProgressBar> progress;  // made at the first frame, which knows the count
  Row r;
  r.variant = variant;
  const auto t0 = std::chrono::steady_clock::now();
  r.run = HertzIndentation::run(setup, [&](int frame, int frames) {
    if (!progress) progress = std::make_unique<mpm::io::ProgressBar>(label, frames);
    progress->update(frame);
  });
  r.wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (progress) progress->finish();
  r.cmp = HertzIndentation::compare(r.run);
  if (!runs.empty()) saveRun(runFile(runs, setup), r);
  return r;
}

/// Mean raw force of the loading frames nearest d = 0 (the standoff), over F_H(0.1 R).
double standoffShare(const HertzIndentation::Run& run) {
  double best = 1e30, force = std::nan("");
  for (const HertzIndentation::Sample& s : run.loading)
    if (std::fabs(s.depth) < best) best = std::fabs(s.depth), force = s.force;
  return force / HertzIndentation::hertzForce(HertzIndentation::kMaxDepth);
}

std::string markdownTable(const std::vector<Row>& rows) {
  std::ostringstream t;
  t << "| variant | R/dx | dx [mm] | particles | substeps | wall [s] | L2 error 0.02–0.1 R [%]"
       " | F/F_H − 1 at 0.1 R [%] | depth lost at 0.1 R [cells] | F at d = 0 / F_H(0.1 R) [%] |\n";
  t << "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const Row& r : rows) {
    const auto& s = r.run.setup;
    t << "| " << (r.variant.empty() ? "scene" : r.variant) << " | " << s.cellsPerRadius << " | "
      << num(1e3 * HertzIndentation::cellSize(s), 3) << " | " << r.run.particles << " | " << r.run.substeps
      << " | " << num(r.wallSeconds, 1) << " | " << num(100 * r.cmp.l2Error, 1) << " | "
      << num(100 * r.cmp.errorAtMaxDepth, 1) << " | " << num(r.cmp.depthLossCells, 3) << " | "
      << num(100 * standoffShare(r.run), 1) << " |\n";
  }
  return t.str();
}

/// The averaged force against Hertz at d = 0.01 R ... 0.1 R for one run.
std::string curveTable(const Row& r) {
  std::ostringstream t;
  t << "| d / R | F [mN] | F_H [mN] | F / F_H |\n|---:|---:|---:|---:|\n";
  for (int i = 1; i <= 10; ++i) {
    const double d = 0.01 * i * kR;
    const double f = HertzIndentation::averagedForce(r.run, d), fh = HertzIndentation::averagedForce(r.run, d, true);
    t << "| " << num(0.01 * i, 2) << " | " << num(1e3 * f, 4) << " | " << num(1e3 * fh, 4) << " | "
      << num(f / fh, 3) << " |\n";
  }
  return t.str();
}

std::string csvTable(const std::vector<Row>& rows) {
  std::ostringstream t;
  t << "variant,cells_per_radius,dx_m,slab_half_width_m,slab_thickness_m,loading_transits,particles,"
       "substeps,wall_s,l2_error,error_at_0.1R,depth_lost_cells,standoff_force_share\n";
  for (const Row& r : rows) {
    const auto& s = r.run.setup;
    t << (r.variant.empty() ? "scene" : r.variant) << ',' << s.cellsPerRadius << ','
      << num(HertzIndentation::cellSize(s), 6) << ',' << num(s.slabHalfWidth, 4) << ','
      << num(s.slabThickness, 4) << ',' << num(s.loadingTransits, 1) << ',' << r.run.particles << ','
      << r.run.substeps << ',' << num(r.wallSeconds, 2) << ',' << num(r.cmp.l2Error, 4) << ','
      << num(r.cmp.errorAtMaxDepth, 4) << ',' << num(r.cmp.depthLossCells, 4) << ','
      << num(standoffShare(r.run), 4) << '\n';
  }
  return t.str();
}

std::string curvesCsv(const std::vector<Row>& rows) {
  std::ostringstream t;
  t << "variant,cells_per_radius,depth_over_R,force_N,hertz_force_N\n";
  for (const Row& r : rows)
    for (int i = 0; i <= 24; ++i) {
      const double d = 0.005 * i * kR;
      t << (r.variant.empty() ? "scene" : r.variant) << ',' << r.run.setup.cellsPerRadius << ','
        << num(0.005 * i, 3) << ',' << HertzIndentation::averagedForce(r.run, d) << ','
        << HertzIndentation::averagedForce(r.run, d, true) << '\n';
    }
  return t.str();
}

/// Least-squares fit of e = eInf + c / N to the resolution rows' F/F_H - 1 at 0.1 R.
struct Fit {
  bool valid = false;
  double eInf = 0, c = 0;
};
Fit fitFirstOrder(const std::vector<Row>& rows) {
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  int n = 0;
  for (const Row& r : rows) {
    if (!r.variant.empty()) continue;
    const double x = 1.0 / r.run.setup.cellsPerRadius, y = r.cmp.errorAtMaxDepth;
    sx += x, sy += y, sxx += x * x, sxy += x * y, ++n;
  }
  Fit f;
  if (n < 3) return f;
  f.c = (n * sxy - sx * sy) / (n * sxx - sx * sx);
  f.eInf = (sy - f.c * sx) / n;
  f.valid = true;
  return f;
}





std::string markdownReport(const RunInfo& info, const Options& opt, const std::vector<Row>& rows) {
  HertzIndentation::Setup scene;
  scene.slabHalfWidth = scene.slabThickness = opt.slab * (float)kR;
  scene.loadingTransits = opt.loadingTransits;
  const double a = std::sqrt(kR * HertzIndentation::kMaxDepth);
  const double chi = a / scene.slabThickness;
  std::ostringstream m;
  const bool gpu = opt.backend == mpm::Backend::Cuda;
  m << info.header(std::string("Hertz contact: rigid sphere into an elastic slab, ") + (gpu ? "CUDA" : "CPU") +
                       " backend",
                   MPM_BENCH_BUILD_TYPE);
  if (gpu) m << "- GPU: " << mpm::cudaDeviceName() << "\n\n";
  m << "Scene (`mpm::scenes::HertzIndentation`, defined in mpm/scenes/standard_scenes.h): a kinematic"
       " sphere, R = "
    << num(1e3 * kR, 0) << " mm, frictionless (Frictional, friction 0, band 0), pressed into a slab"
       " of "
    << (opt.neoHookean ? "decoupled Neo-Hookean" : "fixed-corotated") << " material, E = "
    << num(HertzIndentation::kYoungsModulus / 1e3, 0) << " kPa, nu = " << num(HertzIndentation::kPoissonRatio, 2)
    << ", rho = " << num(HertzIndentation::kDensity, 0) << " kg/m^3, 8 particles per cell, "
    << num(2 * opt.slab, 1) << "R x " << num(2 * opt.slab, 1) << "R wide and H = " << num(opt.slab, 1)
    << "R thick, free sides, on a slip floor (the domain wall), gravity 0. "
    << (opt.whole ? "The whole slab is modelled."
                  : "A quarter of the slab is modelled, on mirror planes x = 0 and z = 0 through the sphere's"
                    " axis (`DomainSettings::mirrorLower`; tests/test_walls.cpp checks a quarter model against"
                    " the whole body to 4e-8 m): `particles` counts the stored quarter, forces are the whole"
                    " slab's.")
    << " Grid: dx = R / (R/dx), the slab's top surface on a node layer and the sphere's axis on a node"
       " column at every resolution.\n\n";
  m << "- Depth d: travel of the sphere since its bottom touched the slab's top surface (top particle"
       " layer plus half a particle spacing). The grid feels the sphere before that (the MPM standoff):"
       " the top particles put mass on the node layer one cell above the surface; the last column is"
       " the force at d = 0.\n"
       "- Loading: start 1.05 dx above the surface, approach at 5 V to d = −dx/4, then V = 0.1 R / ("
    << num(opt.loadingTransits, 0) << " H/c_p): the loading to 0.1 R lasts " << num(opt.loadingTransits, 0)
    << " P-wave transits of the slab (c_p = " << num(HertzIndentation::waveSpeed(), 2)
    << " m/s, H/c_p = " << num(1e3 * HertzIndentation::transitTime(scene), 2) << " ms); CFL 0.3 substeps.\n"
       "- Force: `Scene::shapeImpulse(id).linear.y` over each frame (0.002 R of travel) divided by the"
       " frame's length, averaged over the frames within "
    << num(HertzIndentation::kWindowTransits, 0)
    << " transits (one period of the slab's slowest ringing, measured with the sphere held still; the"
       " depth window is ±"
    << num(HertzIndentation::windowHalfDepth(scene) / kR, 4)
    << " R). F_H is averaged over the same frames.\n"
       "- L2 error: sqrt(sum (F − F_H)^2 / sum F_H^2) at d = 0.02 R, 0.025 R, ..., 0.1 R. Depth lost:"
       " d − d_H at d = 0.1 R, where F_H(d_H) = F, in cells.\n"
       "- The slab is finite: a layer of thickness H on a frictionless base is stiffer than the"
       " half-space by 0.76 a/H + 0.57 (a/H)^2 (Dimitriadis et al. 2002, nu = 0.3), "
    << num(100 * (0.757 * chi + 0.574 * chi * chi), 1) << "% at d = 0.1 R (a/H = " << num(chi, 3)
    << "); its free sides and its finite width make it softer. "
    << (opt.sensitivity > 0
            ? "The `slab` rows measure the net effect of 1.5x and 2x larger slabs (half-width = thickness);"
              " the `loading` row, of loading twice as slowly. Both at one resolution: they separate the"
              " scene's own departures from Hertz from the grid's.\n\n"
            : "This run has no sensitivity rows (--sensitivity 0).\n\n");
  m << "## Results\n\n" << markdownTable(rows) << "\n";
  const Fit fit = fitFirstOrder(rows);
  if (fit.valid) {
    m << "First-order fit of the resolution rows, F/F_H − 1 at 0.1 R = e_inf + c / (R/dx): e_inf = "
      << num(100 * fit.eInf, 1) << "%, c = " << num(100 * fit.c, 0) << "%";
    if (fit.c < 0 && std::fabs(fit.eInf) < 0.1) {
      const double need = -fit.c / (0.1 + fit.eInf);  // e_inf + c/N = -0.1
      m << "; |F/F_H − 1| <= 10% from R/dx ≈ " << num(need, 0);
    }
    m << ".\n\n";
  }
  const Row* finest = nullptr;
  for (const Row& r : rows)
    if (r.variant.empty() && (!finest || r.run.setup.cellsPerRadius > finest->run.setup.cellsPerRadius)) finest = &r;
  if (finest) {
    m << "## Force against depth at the finest resolution, R/dx = " << finest->run.setup.cellsPerRadius
      << "\n\n" << curveTable(*finest) << "\n";
  }
  return m.str();
}

void writeResults(const RunInfo& info, const Options& opt, const std::vector<Row>& rows) {
  writeResultFiles(opt.out, {{".md", markdownReport(info, opt, rows)},
                             {".csv", csvTable(rows)},
                             {"_curves.csv", curvesCsv(rows)}});
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  CLI::App app{"Hertz contact: rigid sphere into an elastic slab, force against depth at several resolutions"};
  app.add_option("--resolutions", opt.resolutions, "sphere radius in cells, R/dx, one row each")
      ->delimiter(',')
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--threads", opt.threads, "CPU threads; 0 = all")->check(CLI::NonNegativeNumber)->capture_default_str();
  addBackendOption(app, opt.backend);
  app.add_flag("--neo-hookean", opt.neoHookean, "the slab in decoupled Neo-Hookean instead of fixed corotated");
  app.add_option("--loading-transits", opt.loadingTransits,
                 "loading time from d = 0 to 0.1 R, in P-wave transits of the slab")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--slab", opt.slab, "slab half-width and thickness, in sphere radii")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--sensitivity", opt.sensitivity,
                 "R/dx of the rows that load twice as slowly and use 1.5x and 2x larger slabs; 0: none")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_flag("--whole", opt.whole, "model the whole slab (default: a quarter on the mirror planes x = z = 0)");
  app.add_option("--runs", opt.runs,
                 "folder keeping each row's frames; a row already there is read instead of run (resume a"
                 " study, or split it over processes and tabulate it once)")
      ->check(CLI::ExistingDirectory);
  app.add_option("--out", opt.out, "path stem: writes <out>.md, <out>.csv and <out>_curves.csv")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  if (app.count("--out") == 0 && opt.backend == mpm::Backend::Cuda) opt.out = resultsStem("hertz", true);

  RunInfo info = RunInfo::now(argc, argv);

  HertzIndentation::Setup base;
  base.slabHalfWidth = base.slabThickness = opt.slab * (float)kR;
  base.loadingTransits = opt.loadingTransits;
  base.backend = opt.backend;
  if (opt.neoHookean) base.material = mpm::MaterialModel::NeoHookeanDecoupled;
  base.threads = opt.threads;
  base.quarter = !opt.whole;

  std::vector<Row> rows;
  try {
    for (const int n : opt.resolutions) {
      HertzIndentation::Setup s = base;
      s.cellsPerRadius = n;
      rows.push_back(runRow(s, "", opt.runs));
      const Row& r = rows.back();
      std::fprintf(stderr, "  R/dx = %d: %zu particles, %.1f s, L2 error %.1f%%, F/F_H - 1 at 0.1 R %.1f%%\n", n,
                   r.run.particles, r.wallSeconds, 100 * r.cmp.l2Error, 100 * r.cmp.errorAtMaxDepth);
      writeResults(info, opt, rows);
    }
    if (opt.sensitivity > 0) {
      HertzIndentation::Setup slow = base;
      slow.cellsPerRadius = opt.sensitivity;
      slow.loadingTransits = 2 * base.loadingTransits;
      rows.push_back(runRow(slow, "loading " + num(slow.loadingTransits, 0) + " transits", opt.runs));
      writeResults(info, opt, rows);
      for (const float scale : {1.5f, 2.f}) {
        HertzIndentation::Setup big = base;
        big.cellsPerRadius = opt.sensitivity;
        big.slabHalfWidth = big.slabThickness = scale * base.slabThickness;
        rows.push_back(runRow(big, "slab " + num(scale * opt.slab, 1) + " R", opt.runs));
        writeResults(info, opt, rows);
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_hertz: %s\n", e.what());
    try {
      writeResults(info, opt, rows);
    } catch (const std::exception&) {
    }
    return 1;
  }

  info.complete = true;
  writeResults(info, opt, rows);
  std::printf("%s", markdownTable(rows).c_str());
  std::fprintf(stderr, "wrote %s.md, %s.csv and %s_curves.csv\n", opt.out.c_str(), opt.out.c_str(), opt.out.c_str());
  return 0;
}
