// Accuracy against cost on the cylinder of Horton et al. 2010 (
// mpm::scenes::CylinderBetweenPlates): every solver at three resolutions, 20 %
// compression with bonded ends and with slip (frictionless) ends, 20 % extension and 20 %
// shear with bonded ends, over the T = 3 s ramp
// u(t) = D (10 - 15 s + 6 s^2) s^3. The ends are two kinematic box plates (Bonded contact;
// Frictional with friction 0 for slip ends); the top one is moved with the ramp and its
// force is the impulse the material gave it over a frame divided by the frame.
//
//   bench_accuracy (default: bench/results/<machine>/accuracy, bench/machine.sh)
//   bench/plot_accuracy.py OUT.csv OUT.png
//
// References: bonded compression, CalculiX extrapolated to zero mesh size
// (tests/reference/cylinder_compression_extrapolated.csv); slip compression, the closed-form
// homogeneous uniaxial solution (third column of cylinder_compression_slip.csv); bonded
// extension, MTLED's converged curve at 0.5 cm (cylinder_extension_mtled.csv, within 0.7 % of
// a CalculiX extension reference held outside the repository). Shear has no reference: its
// forces are reported without an error.
//
// Writes <out>.md (header naming machine and command, the tables), <out>.csv (one row per
// run) and <out>_curves.csv (the force at every sample time of every run).
#include <cmath>
#include <cstdio>
#include <exception>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "bench_options.h"
#include "bench_report.h"
#include "mpm/error.h"
#include "mpm/scene.h"
#include "scenes/standard_scenes.h"

namespace {

using namespace mpm;
using namespace mpm::bench;
using scenes::CylinderBetweenPlates;
using Loading = CylinderBetweenPlates::Loading;

const std::vector<std::string> kCaseNames{"compression-bonded", "compression-slip", "extension-bonded",
                                          "shear-bonded"};

struct Options {
  std::vector<std::string> solvers{"Mtled", "MlsMpm", "StandardMpm", "PbMpm"};
  std::vector<std::string> cases = kCaseNames;
  /// H / dx: cells (MPM) or node intervals (MTLED) over the height; 10, 14, 20 are
  /// dx = 1, 0.714, 0.5 cm. Whole numbers keep both plate faces on node layers and the
  /// particle lattice (dx / 2) filling the height exactly.
  std::vector<int> resolutions{10, 14, 20};
  bool quick = false;                              ///< the coarsest resolution only
  int threads = 1;
  double frame = 0.01;  ///< [s]; the forces are sampled every 0.1 s
  std::string referenceDir = std::string(MPM_SOURCE_DIR) + "/tests/reference";
  std::string out = mpm::bench::resultsStem("accuracy");
};

/// One of the four experiments.
struct Case {
  std::string name;
  Loading loading;
  ContactMode ends;
  std::string referenceFile;  ///< "" when there is none
  int referenceColumn = 1;
};

Case makeCase(const std::string& name) {
  if (name == "compression-bonded")
    return {name, Loading::Compression, ContactMode::Bonded, "cylinder_compression_extrapolated.csv", 1};
  if (name == "compression-slip")  // t, FE force, closed-form force
    return {name, Loading::Compression, ContactMode::Frictional, "cylinder_compression_slip.csv", 2};
  if (name == "extension-bonded")
    return {name, Loading::Extension, ContactMode::Bonded, "cylinder_extension_mtled.csv", 1};
  return {name, Loading::Shear, ContactMode::Bonded, "", 0};
}

struct Row {
  std::string solver, caseName;
  double resolution = 0;  ///< [cm]
  bool ok = false;
  std::string message;    ///< why it stopped, if it did
  CylinderBetweenPlates::Run run;
  double l2Error = std::nan("");     ///< sqrt(sum (F - F_ref)^2 / sum F_ref^2) over 0.1 s .. 3 s
  double finalError = std::nan("");  ///< F(T) / F_ref(T) - 1
  double referenceFinal = std::nan("");
  double finalAxial() const { return run.axialForce.empty() ? std::nan("") : run.axialForce.back(); }
  /// Index of the sample of largest |force| in `f`; -1 if none.
  static int peak(const std::vector<double>& f) {
    int best = -1;
    for (size_t i = 0; i < f.size(); ++i)
      if (best < 0 || std::abs(f[i]) > std::abs(f[best])) best = (int)i;
    return best;
  }
  /// First sample time after the peak where |F| fell below 1 % of the peak (the plate let
  /// go of the material); NaN if it never did.
  double letGo(const std::vector<double>& f) const {
    const int p = peak(f);
    if (p < 0) return std::nan("");
    for (size_t i = p; i < f.size(); ++i)
      if (std::abs(f[i]) < 0.01 * std::abs(f[p])) return run.time[i];
    return std::nan("");
  }
  double peakValue(const std::vector<double>& f) const { const int p = peak(f); return p < 0 ? std::nan("") : f[p]; }
  double peakTime(const std::vector<double>& f) const { const int p = peak(f); return p < 0 ? std::nan("") : run.time[p]; }
  double finalShear() const { return run.shearForce.empty() ? std::nan("") : run.shearForce.back(); }
  double wallPerSimulated() const { return run.simulated > 0 ? run.wallSeconds / run.simulated : std::nan(""); }
};

/// Compares the run's axial force with the reference column at the sample times.
void compare(Row& row, const std::vector<std::vector<double>>& ref, int column) {
  double diff2 = 0, ref2 = 0;
  for (size_t i = 0; i < row.run.time.size(); ++i) {
    const double expected = CylinderBetweenPlates::at(ref[0], ref[column], row.run.time[i]);
    if (std::isnan(expected)) throw Error("no reference value at t = " + num(row.run.time[i], 3));
    diff2 += (row.run.axialForce[i] - expected) * (row.run.axialForce[i] - expected);
    ref2 += expected * expected;
  }
  row.l2Error = std::sqrt(diff2 / ref2);
  row.referenceFinal = CylinderBetweenPlates::at(ref[0], ref[column], CylinderBetweenPlates::kRampTime);
  row.finalError = row.finalAxial() / row.referenceFinal - 1;
}

Row runOne(const Options& opt, const std::string& solver, const Case& c, int cellsOverHeight) {
  const double resolutionCm = 100 * CylinderBetweenPlates::kHeight / cellsOverHeight;
  Row row;
  row.solver = solver;
  row.caseName = c.name;
  row.resolution = resolutionCm;
  CylinderBetweenPlates::Setup setup;
  setup.solver = solverTypes().at(solver);
  setup.resolution = resolutionCm / 100;
  setup.ends = c.ends;
  setup.threads = opt.threads;
  try {
    double reported = 0;
    row.run = CylinderBetweenPlates::run(setup, c.loading, opt.frame, 0.1, [&](double t) {
      if (t < reported + 0.5) return;
      reported = t;
      std::fprintf(stderr, "  ... t = %.2f s\n", t);
    });
    row.ok = row.run.time.size() >= 30;
    if (!row.ok) row.message = "fewer samples than the 30 reference times";
    if (!c.referenceFile.empty())
      compare(row, CylinderBetweenPlates::readCsv(opt.referenceDir + "/" + c.referenceFile), c.referenceColumn);
  } catch (const std::exception& e) {
    row.ok = false;
    row.message = e.what();
  }
  return row;
}

std::string pct(double v) { return std::isnan(v) ? "–" : num(100 * v, 2) + " %"; }

std::string markdownReport(const RunInfo& info, const Options& opt, const std::vector<Row>& rows) {
  std::ostringstream m;
  m << info.header("Accuracy against cost: the cylinder between plates, every solver, CPU backend", MPM_BENCH_BUILD_TYPE);
  m << "Scene `mpm::scenes::CylinderBetweenPlates`: R = 5 cm, H = 10 cm, decoupled Neo-Hookean mu = 1007 Pa, K = 50001 Pa"
       " (nu = 0.49), rho = 1000 kg/m^3, no gravity, between two kinematic box plates (Bonded contact; slip ends:"
       " Frictional, friction 0; MPM: contact band half a cell, so the node layer nearest each face follows the"
       " plate, ContactParams::band). The top plate follows u(t) = D (10 − 15 s + 6 s²) s³, s = t / T, T = 3 s,"
       " D = 2 cm (20 % of H): down (compression), up (extension) or sideways along x (shear). MPM solvers: grid"
       " cell dx = the resolution, 8 particles per cell (H / dx = 10, 14, 20 for 1, 0.714, 0.5 cm: whole cells, so both"
       " plate faces lie on node layers and the particle lattice fills the height exactly), substeps by the CFL policy (0.3 dx / (c_p + speed));"
       " PB-MPM: 10 iterations, its step bound by the particle and plate speed only (one step per frame here), so"
       " its stiffness depends on the frame. MTLED: node spacing = the resolution, smoothed strain (the default),"
       " substep 0.5 of eq. 37; end nodes held by a band of a tenth of the spacing. Frames of "
    << num(1e3 * opt.frame, 0)
    << " ms, each centred on its sample time (the first is half a frame); the force is the top plate's impulse"
       " over the frame divided by its length, sampled every 0.1 s. "
    << opt.threads << " CPU thread" << (opt.threads == 1 ? "" : "s") << " per run (0 = all).\n\n"
    << "Errors: *L2* = sqrt(Σ (F − F_ref)² / Σ F_ref²) over t = 0.1, 0.2, ..., 3 s of the axial force; *final* ="
       " F(3 s) / F_ref(3 s) − 1 (negative: softer). References: bonded compression, CalculiX extrapolated to zero"
       " mesh size (" << num(CylinderBetweenPlates::kBondedFinalForce, 4)
    << " N at 3 s, ± 0.6 %); slip compression, the closed-form homogeneous uniaxial solution (−5.9964 N at 3 s);"
       " bonded extension, MTLED's curve at 0.5 cm (4.6828 N at 3 s; MTLED converges to it from above and lies"
       " within 0.7 % of a CalculiX extension reference held outside the repository, so MTLED's own 0.5 cm row"
       " compares with itself). Shear has no reference: its forces are listed. Wall and CPU time: the stepping only"
       " (not the set-up); *wall / sim s*: wall time per simulated second (3.005 s simulated).\n\n";
  m << "## Against a reference\n\n"
       "| solver | case | resolution [cm] | particles / nodes | substeps | wall [s] | CPU [s] | wall / sim s |"
       " L2 error | final error | F(3 s) [N] |\n|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const Row& r : rows) {
    if (makeCase(r.caseName).referenceFile.empty()) continue;
    m << "| " << r.solver << " | " << r.caseName << " | " << num(r.resolution, 3) << " | " << r.run.particles << " | "
      << r.run.substeps << " | " << num(r.run.wallSeconds, 1) << " | " << num(r.run.cpuSeconds, 1) << " | "
      << num(r.wallPerSimulated(), 2) << " | " << (r.ok ? pct(r.l2Error) : "**failed**") << " | "
      << pct(r.finalError) << " | " << num(r.finalAxial(), 4) << " |\n";
  }
  m << "\n## Extension and shear: holding on\n\n"
       "| solver | case | resolution [cm] | particles / nodes | substeps | wall [s] | CPU [s] | wall / sim s |"
       " axial F(3 s) [N] | shear F(3 s) [N] | largest axial F [N] (at t [s]) | largest shear F [N] (at t [s]) |"
       " force lost at t [s] |\n|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|\n";
  for (const Row& r : rows) {
    if (r.caseName.rfind("compression", 0) == 0) continue;
    m << "| " << r.solver << " | " << r.caseName << " | " << num(r.resolution, 3) << " | " << r.run.particles << " | "
      << r.run.substeps << " | " << num(r.run.wallSeconds, 1) << " | " << num(r.run.cpuSeconds, 1) << " | "
      << num(r.wallPerSimulated(), 2) << " | " << (r.ok ? num(r.finalAxial(), 4) : "**failed**") << " | "
      << num(r.finalShear(), 4) << " | " << num(r.peakValue(r.run.axialForce), 4) << " ("
      << num(r.peakTime(r.run.axialForce), 1) << ") | " << num(r.peakValue(r.run.shearForce), 4) << " ("
      << num(r.peakTime(r.run.shearForce), 1) << ") | ";
    const bool shear = r.caseName.rfind("shear", 0) == 0;
    const double lost = r.letGo(shear ? r.run.shearForce : r.run.axialForce);
    m << (std::isnan(lost) ? "held" : num(lost, 1)) << " |\n";
  }
  m << "\nForces are those the top plate applies to the cylinder. Axial: y, negative pushes it down"
       " (compression), positive pulls it up (extension). Shear: x, positive along the plate's motion. *Force lost*:"
       " the first sample after the largest force (axial for extension, shear for shear) where it is below 1 % of"
       " that largest: the plate has let go of the material; *held*: it never did.\n";
  bool failures = false;
  for (const Row& r : rows) failures |= !r.ok;
  if (failures) {
    m << "\n## Failed runs\n\n";
    for (const Row& r : rows)
      if (!r.ok) m << "- " << r.solver << ", " << r.caseName << ", " << num(r.resolution, 3) << " cm: " << r.message << "\n";
  }
  return m.str();
}

/// A CSV cell: empty for NaN.
std::string csvNum(double v, int decimals) { return std::isnan(v) ? "" : num(v, decimals); }

std::string csvTable(const std::vector<Row>& rows) {
  std::ostringstream t;
  t << "solver,case,resolution_cm,particles,substeps,substep_s,wall_s,cpu_s,simulated_s,wall_per_sim_s,ok,"
       "l2_error,final_error,final_axial_N,final_shear_N,reference_final_N,peak_axial_N,peak_axial_t_s,peak_shear_N,"
       "peak_shear_t_s\n";
  for (const Row& r : rows)
    t << r.solver << ',' << r.caseName << ',' << num(r.resolution, 4) << ',' << r.run.particles << ','
      << r.run.substeps << ',' << r.run.substepDt << ',' << num(r.run.wallSeconds, 3) << ','
      << num(r.run.cpuSeconds, 3) << ',' << num(r.run.simulated, 3) << ',' << csvNum(r.wallPerSimulated(), 4) << ','
      << (r.ok ? 1 : 0) << ',' << csvNum(r.l2Error, 5) << ','
      << csvNum(r.finalError, 5) << ','
      << csvNum(r.finalAxial(), 5) << ','
      << csvNum(r.finalShear(), 5) << ','
      << csvNum(r.referenceFinal, 5) << ',' << csvNum(r.peakValue(r.run.axialForce), 5)
      << ',' << csvNum(r.peakTime(r.run.axialForce), 2) << ',' << csvNum(r.peakValue(r.run.shearForce), 5) << ','
      << csvNum(r.peakTime(r.run.shearForce), 2) << '\n';
  return t.str();
}

std::string curvesTable(const std::vector<Row>& rows) {
  std::ostringstream t;
  t << "solver,case,resolution_cm,t_s,axial_N,shear_N\n";
  for (const Row& r : rows)
    for (size_t i = 0; i < r.run.time.size(); ++i)
      t << r.solver << ',' << r.caseName << ',' << num(r.resolution, 4) << ',' << num(r.run.time[i], 3) << ','
        << num(r.run.axialForce[i], 6) << ',' << num(r.run.shearForce[i], 6) << '\n';
  return t.str();
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  CLI::App app{"Cylinder between plates: force error against run time, every solver at three resolutions"};
  addSolversOption(app, opt.solvers);
  app.add_option("--cases", opt.cases, "experiments to run")
      ->delimiter(',')
      ->check(CLI::IsMember(kCaseNames))
      ->capture_default_str();
  app.add_option("--resolutions", opt.resolutions,
                 "H / dx (MPM cells or MTLED node intervals over the 10 cm height), one row each")
      ->delimiter(',')
      ->check(CLI::Range(4, 40))
      ->capture_default_str();
  app.add_flag("--quick", opt.quick, "the coarsest resolution only (a smoke run)");
  app.add_option("--threads", opt.threads, "CPU threads per run; 0 = all")->check(CLI::NonNegativeNumber)->capture_default_str();
  app.add_option("--frame", opt.frame, "frame length [s]; must divide 0.1 s")
      ->check(CLI::Range(0.001, 0.05))
      ->capture_default_str();
  app.add_option("--reference-dir", opt.referenceDir, "folder of the CalculiX reference CSVs")->capture_default_str();
  app.add_option("--out", opt.out, "path stem: writes <out>.md, <out>.csv and <out>_curves.csv")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  if (std::abs(0.1 / opt.frame - std::round(0.1 / opt.frame)) > 1e-6) {
    std::fprintf(stderr, "--frame must divide 0.1 s\n");
    return 2;
  }
  if (opt.quick) {
    int coarsest = 1000;
    for (int r : opt.resolutions) coarsest = std::min(coarsest, r);
    opt.resolutions = {coarsest};
  }

  RunInfo info = RunInfo::now(argc, argv);
  std::vector<Row> rows;
  const auto write = [&] {
    writeResultFiles(opt.out, {{".md", markdownReport(info, opt, rows)},
                               {".csv", csvTable(rows)},
                               {"_curves.csv", curvesTable(rows)}});
  };
  // the compression cases (the ones with a reference) first, then extension and shear; in each
  // group the coarse rows of every solver and case first, so a stopped study covers them
  for (const bool compression : {true, false})
  for (const int resolution : opt.resolutions)
    for (const std::string& caseName : opt.cases)
      for (const std::string& solver : opt.solvers) {
        if ((caseName.rfind("compression", 0) == 0) != compression) continue;
        std::fprintf(stderr, "%s, %s, H/dx = %d ...\n", solver.c_str(), caseName.c_str(), resolution);
        Row r = runOne(opt, solver, makeCase(caseName), resolution);
        std::fprintf(stderr, "%s, %s, H/dx = %d: %zu particles, %lld substeps, wall %.1f s, CPU %.1f s; L2 %s, final %s,"
                     " F(3 s) %.4f N, shear %.4f N%s%s\n",
                     solver.c_str(), caseName.c_str(), resolution, r.run.particles, r.run.substeps, r.run.wallSeconds,
                     r.run.cpuSeconds, pct(r.l2Error).c_str(), pct(r.finalError).c_str(), r.finalAxial(),
                     r.finalShear(), r.ok ? "" : "; FAILED: ", r.message.c_str());
        rows.push_back(std::move(r));
        write();
      }
  info.complete = true;
  write();
  std::fprintf(stderr, "wrote %s.md, %s.csv and %s_curves.csv\n", opt.out.c_str(), opt.out.c_str(), opt.out.c_str());
  return 0;
}
