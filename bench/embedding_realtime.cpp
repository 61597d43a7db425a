// The README's embedding scene against the clock (issue 19, "the embedding scene at
// E = 200 kPa: at least real time"): the user's Bullet world of tests/embed_world.inc (a
// ground plane, a 0.5 kg box of 6 cm dropped from 0.2 m) with the tissue of
// tests/embed_snippet.inc (9000 particles, decoupled Neo-Hookean E = 200 kPa, nu = 0.3,
// dx = 2 cm), stepped as the README does, stepSimulation(1/60, 10, 1/240), for `--seconds`
// of simulated time per solver and CPU thread count. Reports wall and CPU time (the
// process's, all threads), the real-time factor (simulated s / wall s), the substeps taken,
// and the box's resting height (the slab's top is at 0.102 m, so 0.132 m rests on it).
//
//   bench_embedding_realtime [--solvers MlsMpm,PbMpm] [--threads 1,2] [--seconds 3]
//                            [--cfl 0.3] [--out bench/results/embedding_realtime]
//
// --cfl sets SubstepPolicy::cflNumber (unset: the library's default).
#include <btBulletDynamicsCommon.h>

#include <time.h>

#include <chrono>
#include <cmath>
#include <cstdio>
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
  float cfl = 0.f;  ///< 0: the solver's default
  std::string out = "bench/results/embedding_realtime";
};

struct Row {
  std::string solver;
  int threads = 0;
  double simulated = 0, wall = 0, cpu = 0;
  long long substeps = 0;
  double maxSubstep = 0;  ///< [ms] the policy's substep bound at the end
  double toolHeight = 0;  ///< [m] the box's centre at the end
};

double cpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

Row run(mpm::SolverType solverType, int threads, const Options& opt) {
#include "../tests/embed_world.inc"
  // tests/embed_snippet.inc's scene, with the solver, backend and threads chosen here
  mpm::SceneSettings settings;
  settings.domain = {{-0.25f, -0.1f, -0.25f}, {0.25f, 0.4f, 0.25f}};
  settings.dx = 0.02f;
  settings.solver = solverType;
  settings.backend = mpm::Backend::Cpu;
  settings.cpuThreads = threads;
  if (opt.cfl > 0.f) settings.substeps.cflNumber = opt.cfl;
  mpm::Scene scene(settings);
  mpm::ParticleObjectDesc tissue;
  tissue.center = {0.f, 0.052f, 0.f};
  tissue.halfExtents = {0.15f, 0.05f, 0.15f};
  tissue.material = {mpm::MaterialModel::NeoHookeanDecoupled, 2e5f, 0.3f, 1000.f};
  scene.addParticleObject(tissue);
  mpm::bullet::Coupler coupler(world, scene);
  coupler.addRigidBody(ground);
  coupler.addRigidBody(tool);

  const int frames = (int)std::lround(opt.seconds * 60);
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
  r.threads = threads;
  r.simulated = scene.time();
  r.substeps = scene.timings().substeps;
  r.maxSubstep = 1e3 * (double)scene.maxSubstep();
  r.toolHeight = tool->getCenterOfMassPosition().y();
  world->removeRigidBody(&toolBody);
  world->removeRigidBody(&groundBody);
  return r;
}

std::string csv(const std::vector<Row>& rows) {
  std::ostringstream s;
  s << "solver,threads,simulated_s,wall_s,cpu_s,realtime_wall,realtime_cpu,substeps,substeps_per_s,max_substep_ms,"
       "tool_height_m\n";
  for (const Row& r : rows)
    s << r.solver << ',' << r.threads << ',' << r.simulated << ',' << r.wall << ',' << r.cpu << ','
      << r.simulated / r.wall << ',' << r.simulated / r.cpu << ',' << r.substeps << ',' << r.substeps / r.simulated
      << ',' << r.maxSubstep << ',' << r.toolHeight << '\n';
  return s.str();
}

std::string markdown(const RunInfo& info, const Options& opt, const std::vector<Row>& rows) {
  std::ostringstream s;
  s << info.header("The README's embedding scene against the clock", MPM_BENCH_BUILD_TYPE);
  s << "tests/embed_world.inc's world (a 0.5 kg box of 6 cm dropped from 0.2 m on a ground plane) with "
       "tests/embed_snippet.inc's tissue (9000 particles, decoupled Neo-Hookean E = 200 kPa, nu = 0.3, "
       "rho = 1000, dx = 2 cm), `stepSimulation(1/60, 10, 1/240)` for "
    << num(opt.seconds, 1) << " s simulated; cflNumber "
    << (opt.cfl > 0.f ? num(opt.cfl, 3) : std::string("the library's default"))
    << ". Real time = simulated s / wall s (CPU: / process CPU s, all threads). The box "
       "rests on the slab at 0.132 m.\n\n";
  s << "| solver | threads | wall [s] | CPU [s] | real time (wall) | real time (CPU) | substeps | substeps / "
       "simulated s | substep bound [ms] | box height [m] |\n";
  s << "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const Row& r : rows)
    s << "| " << r.solver << " | " << r.threads << " | " << num(r.wall, 2) << " | " << num(r.cpu, 2) << " | "
      << num(r.simulated / r.wall, 2) << "x | " << num(r.simulated / r.cpu, 2) << "x | " << r.substeps << " | "
      << num(r.substeps / r.simulated, 0) << " | " << num(r.maxSubstep, 3) << " | " << num(r.toolHeight, 4)
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
  app.add_option("--cfl", opt.cfl, "SubstepPolicy::cflNumber (unset: the solver's default)")->check(CLI::Range(0.f, 1.f));
  app.add_option("--out", opt.out, "result files' stem (.md, .csv)")->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  RunInfo info = RunInfo::now(argc, argv);
  std::vector<Row> rows;
  for (const std::string& name : opt.solvers)
    for (int threads : opt.threads) {
      rows.push_back(run(solverTypes().at(name), threads, opt));
      const Row& r = rows.back();
      std::printf("%-12s %d thread(s): %.2f s simulated in %.2f s wall (%.2fx real time), %.2f s CPU (%.2fx), "
                  "%lld substeps, box at %.4f m\n",
                  r.solver.c_str(), r.threads, r.simulated, r.wall, r.simulated / r.wall, r.cpu, r.simulated / r.cpu,
                  r.substeps, r.toolHeight);
      std::fflush(stdout);
      writeResultFiles(opt.out, {{".md", markdown(info, opt, rows)}, {".csv", csv(rows)}});
    }
  info.complete = true;
  writeResultFiles(opt.out, {{".md", markdown(info, opt, rows)}, {".csv", csv(rows)}});
  return 0;
}
