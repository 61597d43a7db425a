// The README's embedding scene against the clock (the aim: the embedding scene at
// E = 200 kPa at least real time): the user's Bullet world of tests/embed_world.inc (a
// ground plane, a 0.5 kg box of 6 cm dropped from 0.2 m) with the tissue of
// tests/embed_snippet.inc (9000 particles, decoupled Neo-Hookean E = 200 kPa, nu = 0.3,
// dx = 2 cm), stepped as the README does, stepSimulation(1/60, 10, 1/240), for `--seconds`
// of simulated time per solver and CPU thread count. Reports wall and CPU time (the
// process's, all threads), the real-time factor (simulated s / wall s), the substeps taken,
// and the box's resting height (the slab's top is at 0.102 m, so 0.132 m rests on it).
//
//   bench_embedding_realtime [--solvers MlsMpm,PbMpm] [--threads 1,2] [--seconds 3]
//                            [--variants cfl0.3,default,every4] [--out bench/results/<machine>/embedding_realtime]
//
// A variant is `default` (the solver's own cflNumber, the tissue advanced every Bullet
// tick) or '+'-joined changes to it: `cflX` sets SubstepPolicy::cflNumber = X (cfl0.3: the
// one default of every solver in earlier versions), `everyN` advances the tissue once every N Bullet ticks
// (Coupler::setTissueInterval). Each solver and thread count runs every variant in turn.
#include <btBulletDynamicsCommon.h>

#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "bench_options.h"
#include "bench_report.h"
#include "mpm/scene.h"
#include "mpm_bullet/coupler.h"

namespace {

using namespace mpm::bench;

struct Options {
  std::vector<std::string> solvers{"MlsMpm", "PbMpm", "StandardMpm"};
  std::vector<int> threads{1, 2};
  double seconds = 3;
  std::vector<std::string> variants{"cfl0.3", "default"};
  std::string out = mpm::bench::resultsStem("embedding_realtime");
};

struct Variant {
  std::string name;
  float cfl = 0.f;  ///< 0: the solver's default
  int tissueEvery = 1;
};

Variant parseVariant(const std::string& name) {
  Variant v{name};
  std::stringstream parts(name);
  std::string part;
  while (std::getline(parts, part, '+')) {
    try {
      if (part == "default") continue;
      if (part.rfind("cfl", 0) == 0) {
        v.cfl = std::stof(part.substr(3));
        if (v.cfl > 0.f && v.cfl <= 1.f) continue;
      } else if (part.rfind("every", 0) == 0) {
        v.tissueEvery = std::stoi(part.substr(5));
        if (v.tissueEvery >= 1) continue;
      }
    } catch (const std::exception&) {
    }
    throw CLI::ValidationError("--variants", "'" + part + "' is none of default, cflX (0 < X <= 1), everyN (N >= 1)");
  }
  return v;
}

struct Row {
  std::string solver, variant;
  int threads = 0;
  double simulated = 0, wall = 0, cpu = 0;
  long long substeps = 0;
  double maxSubstep = 0;  ///< [ms] the policy's substep bound at the end
  double toolHeight = 0;  ///< [m] the box's centre at the end
  double stages = 0;      ///< [s] wall time in the solver's named stages (Scene::timings)
  mpm::StageTimings split;  ///< those stages one by one
  uint64_t positionsHash = 0;  ///< of the tissue at the end (bench_report.h)
};

/// The stages' wall time per substep [us]: sort / P2G / grid / contact / G2P.
std::string stageSplit(const Row& r, const char* sep) {
  const mpm::StageTimings& t = r.split;
  const double per = 1e6 / (double)std::max(1LL, r.substeps);
  std::ostringstream s;
  s << std::fixed << std::setprecision(0) << t.sort * per << sep << t.p2g * per << sep << t.gridUpdate * per << sep
    << t.contact * per << sep << t.g2p * per;
  return s.str();
}

double cpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

Row run(mpm::SolverType solverType, int threads, const Variant& variant, double seconds) {
#include "../tests/embed_world.inc"
  // tests/embed_snippet.inc's scene, with the solver, backend and threads chosen here
  mpm::SceneSettings settings;
  settings.domain = {{-0.25f, -0.1f, -0.25f}, {0.25f, 0.4f, 0.25f}};
  settings.dx = 0.02f;
  settings.solver = solverType;
  settings.backend = mpm::Backend::Cpu;
  settings.cpuThreads = threads;
  settings.substeps.cflNumber = variant.cfl;
  mpm::Scene scene(settings);
  mpm::ParticleObjectDesc tissue;
  tissue.center = {0.f, 0.052f, 0.f};
  tissue.halfExtents = {0.15f, 0.05f, 0.15f};
  tissue.material = {mpm::MaterialModel::NeoHookeanDecoupled, 2e5f, 0.3f, 1000.f};
  const auto tissueId = scene.addParticleObject(tissue);
  mpm::bullet::Coupler coupler(world, scene);
  coupler.addRigidBody(ground);
  coupler.addRigidBody(tool);
  coupler.setTissueInterval(variant.tissueEvery);

  const int frames = (int)std::lround(seconds * 60);
  const double cpu0 = cpuSeconds();
  const auto t0 = std::chrono::steady_clock::now();
  for (int f = 0; f < frames; ++f) {
    world->stepSimulation(1.f / 60, 10, 1.f / 240);
    coupler.rethrowError();
  }
  Row r;
  r.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.cpu = cpuSeconds() - cpu0;
  r.solver = solverName(solverType);
  r.variant = variant.name;
  r.threads = threads;
  r.simulated = scene.time();
  const mpm::StageTimings st = scene.timings();
  r.substeps = st.substeps;
  r.stages = st.sort + st.p2g + st.gridUpdate + st.contact + st.g2p;
  r.split = st;
  r.maxSubstep = 1e3 * (double)scene.maxSubstep();
  r.toolHeight = tool->getCenterOfMassPosition().y();
  std::vector<mpm::Vec3f> x;
  scene.readPositions(tissueId, x);
  r.positionsHash = positionsHash(x);
  world->removeRigidBody(&toolBody);
  world->removeRigidBody(&groundBody);
  return r;
}

std::string csv(const std::vector<Row>& rows) {
  std::ostringstream s;
  s << "solver,variant,threads,simulated_s,wall_s,cpu_s,realtime_wall,realtime_cpu,substeps,substeps_per_s,max_substep_ms,"
       "tool_height_m,stages_s,sort_us,p2g_us,grid_us,contact_us,g2p_us\n";
  for (const Row& r : rows)
    s << r.solver << ',' << r.variant << ',' << r.threads << ',' << r.simulated << ',' << r.wall << ',' << r.cpu << ','
      << r.simulated / r.wall << ',' << r.simulated / r.cpu << ',' << r.substeps << ',' << r.substeps / r.simulated
      << ',' << r.maxSubstep << ',' << r.toolHeight << ',' << r.stages << ',' << stageSplit(r, ",") << '\n';
  return s.str();
}

std::string markdown(const RunInfo& info, const Options& opt, const std::vector<Row>& rows) {
  std::ostringstream s;
  s << info.header("The README's embedding scene against the clock", MPM_BENCH_BUILD_TYPE);
  s << "tests/embed_world.inc's world (a 0.5 kg box of 6 cm dropped from 0.2 m on a ground plane) with "
       "tests/embed_snippet.inc's tissue (9000 particles, decoupled Neo-Hookean E = 200 kPa, nu = 0.3, "
       "rho = 1000, dx = 2 cm), `stepSimulation(1/60, 10, 1/240)` for "
    << num(opt.seconds, 1)
    << " s simulated. Variants: `default` is the solver's own cflNumber (defaultCflNumber) with the tissue "
       "advanced every Bullet tick; `cflX` sets cflNumber = X (cfl0.3 is every solver's default before issue "
       "19); `everyN` advances the tissue once every N ticks (Coupler::setTissueInterval). Real time = "
       "simulated s / wall s (CPU: / process CPU s, all threads); ms per "
       "substep = wall / substeps (PB-MPM: a substep is its iterations); in stages = the share of the wall time in "
       "the solver's named stages (the rest: Bullet, the coupling, the scene's per-advance work), and those "
       "stages per substep in us (Scene::timings: sort / P2G / grid update / contact / G2P; the grid update "
       "runs in P2G's pass, and so does PB-MPM's G2P of every cycle but its last, in the next cycle's P2G: "
       "both are counted in P2G). The box rests on the slab at 0.132 m.\n\n";
  s << "| solver | variant | threads | wall [s] | CPU [s] | real time (wall) | real time (CPU) | substeps | substeps / "
       "simulated s | ms per substep | in stages | stages [us / substep] | substep bound [ms] | box height [m] |\n";
  s << "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const Row& r : rows)
    s << "| " << r.solver << " | " << r.variant << " | " << r.threads << " | " << num(r.wall, 2) << " | " << num(r.cpu, 2) << " | "
      << num(r.simulated / r.wall, 2) << "x | " << num(r.simulated / r.cpu, 2) << "x | " << r.substeps << " | "
      << num(r.substeps / r.simulated, 0) << " | " << num(1e3 * r.wall / (double)r.substeps, 3) << " | "
      << num(100 * r.stages / r.wall, 0) << " % | " << stageSplit(r, " / ") << " | " << num(r.maxSubstep, 3) << " | " << num(r.toolHeight, 4)
      << " |\n";
  return s.str();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"The README's embedding scene: real-time factor per solver and thread count"};
  Options opt;
  addSolversOption(app, opt.solvers);
  app.add_option("--threads", opt.threads, "CPU thread counts")->delimiter(',')->capture_default_str();
  app.add_option("--seconds", opt.seconds, "simulated seconds per run")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--variants", opt.variants, "default, cflX, everyN, or '+'-joined (cfl0.3+every4)")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--out", opt.out, "result files' stem (.md, .csv)")->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  std::vector<Variant> variants;
  try {
    for (const std::string& v : opt.variants) variants.push_back(parseVariant(v));
  } catch (const CLI::Error& e) {
    return app.exit(e);
  }
  RunInfo info = RunInfo::now(argc, argv);
  std::vector<Row> rows;
  for (const std::string& name : opt.solvers)
    for (int threads : opt.threads)
      for (const Variant& variant : variants) {
        rows.push_back(run(solverTypes().at(name), threads, variant, opt.seconds));
        const Row& r = rows.back();
        std::printf("%-12s %-14s %d thread(s): %.2f s simulated in %.2f s wall (%.2fx real time), %.2f s CPU "
                    "(%.2fx), %lld substeps, box at %.4f m; us per substep in sort / P2G / grid / contact / G2P: %s; positions hash %016llx\n",
                    r.solver.c_str(), r.variant.c_str(), r.threads, r.simulated, r.wall, r.simulated / r.wall, r.cpu,
                    r.simulated / r.cpu, r.substeps, r.toolHeight, stageSplit(r, " / ").c_str(), (unsigned long long)r.positionsHash);
        std::fflush(stdout);
        writeResultFiles(opt.out, {{".md", markdown(info, opt, rows)}, {".csv", csv(rows)}});
      }
  info.complete = true;
  writeResultFiles(opt.out, {{".md", markdown(info, opt, rows)}, {".csv", csv(rows)}});
  return 0;
}
