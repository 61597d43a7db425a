// Many scenes at once (SceneBatch): throughput of N copies of the README's embedding
// scene advanced by one SceneBatch against one copy stepped alone, per thread count.
//
// The scene: tests/embed_snippet.inc's tissue (9000 particles, dx 2 cm, Neo-Hookean
// E = 200 kPa, nu = 0.3) on a kinematic ground, and embed_world.inc's tool (a 6 cm box of
// 0.5 kg released at y = 0.2 m) as a dynamic shape under gravity, without Bullet. Each step
// advances 1/240 s, the Bullet coupler's tick in the README's stepSimulation(1/60, 10, 1/240).
//
// Per thread count T, three sets of the scene are built fresh and warmed up: one scene
// (cpuThreads = T), N scenes stepped one after another (each on T threads, the way without
// a batch) and N scenes in a SceneBatch of T threads. Each step is timed for the three in
// turn, so a change in the machine's load (it is shared) falls on all three; each row is
// the median over the repeats. Wall time from steady_clock, CPU time of the whole process.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "bench_options.h"
#include "bench_report.h"
#include "mpm/scene.h"
#include "mpm/scene_batch.h"

namespace {

using namespace mpm;

struct Options {
  int scenes = 16;
  std::vector<int> threads{1, 2};
  int warmup = 12;    ///< ticks before timing
  int ticks = 24;     ///< ticks per timed repeat
  int repeats = 3;
  float dt = 1.f / 240;
  std::string solver = "MlsMpm";
  Backend backend = Backend::Cpu;
  std::string out = mpm::bench::resultsStem("batch");
};

std::unique_ptr<Scene> embeddingScene(SolverType solver, Backend backend, int cpuThreads) {
  SceneSettings settings;  // tests/embed_snippet.inc
  settings.domain = {{-0.25f, -0.1f, -0.25f}, {0.25f, 0.4f, 0.25f}};
  settings.dx = 0.02f;
  settings.solver = solver;
  settings.backend = backend;
  settings.cpuThreads = cpuThreads;
  auto scene = std::make_unique<Scene>(settings);
  ParticleObjectDesc tissue;
  tissue.center = {0.f, 0.052f, 0.f};
  tissue.halfExtents = {0.15f, 0.05f, 0.15f};
  tissue.material = {MaterialModel::NeoHookeanDecoupled, 2e5f, 0.3f, 1000.f};
  scene->addParticleObject(tissue);
  ShapeDesc ground;  // embed_world.inc's ground plane y = 0, as a box
  ground.parts = {Geometry::box({0.24f, 0.04f, 0.24f})};
  ground.pose.position = {0.f, -0.04f, 0.f};
  scene->addShape(ground);
  ShapeDesc tool;  // embed_world.inc's tool
  tool.parts = {Geometry::box({0.03f, 0.03f, 0.03f})};
  tool.pose.position = {0.f, 0.2f, 0.f};
  tool.mass = 0.5f;
  const float I = 0.5f * (0.06f * 0.06f * 2.f) / 12.f;
  tool.inertia = {I, I, I};
  tool.gravity = {0.f, -9.81f, 0.f};
  scene->addShape(tool);
  return scene;
}

double cpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

struct Sample {
  double wall = 0, cpu = 0;
  double sceneSteps = 0, particleSubsteps = 0;
};

void add(Sample& sum, const Sample& s) {
  sum.wall += s.wall;
  sum.cpu += s.cpu;
  sum.sceneSteps += s.sceneSteps;
  sum.particleSubsteps += s.particleSubsteps;
}

template <class Step>
Sample timed(Step step) {
  Sample s;
  const auto w0 = std::chrono::steady_clock::now();
  const double c0 = cpuSeconds();
  step(s);
  s.cpu = cpuSeconds() - c0;
  s.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - w0).count();
  return s;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

struct Row {
  int threads = 0;
  std::string scenes;
  double wall = 0, cpu = 0;              ///< medians per repeat [s]
  double stepsPerSecond = 0, particleSubstepsPerSecond = 0;  ///< medians, per wall second
  double particleSubstepsPerCpuSecond = 0;                   ///< median
  double substepsPerTick = 0;
  std::string load;                      ///< 1-min load average after the row
};

Row summarize(int threads, const std::string& scenes, const std::vector<Sample>& samples) {
  Row r;
  r.threads = threads;
  r.scenes = scenes;
  std::vector<double> wall, cpu, sps, pss, psc;
  double substeps = 0;
  for (const Sample& s : samples) {
    wall.push_back(s.wall);
    cpu.push_back(s.cpu);
    sps.push_back(s.sceneSteps / s.wall);
    pss.push_back(s.particleSubsteps / s.wall);
    psc.push_back(s.particleSubsteps / s.cpu);
    substeps += s.particleSubsteps;
  }
  r.wall = median(wall);
  r.cpu = median(cpu);
  r.stepsPerSecond = median(sps);
  r.particleSubstepsPerSecond = median(pss);
  r.particleSubstepsPerCpuSecond = median(psc);
  double steps = 0;
  for (const Sample& s : samples) steps += s.sceneSteps;
  r.substepsPerTick = substeps / (9000.0 * steps);
  r.load = bench::loadAverage();
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace mpm::bench;
  Options opt;
  CLI::App app{"Throughput of a SceneBatch of the README's embedding scene against one scene"};
  app.add_option("--scenes", opt.scenes, "copies in the batch")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--threads", opt.threads, "thread counts")->delimiter(',')->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--warmup", opt.warmup, "ticks before timing")->check(CLI::NonNegativeNumber)->capture_default_str();
  app.add_option("--ticks", opt.ticks, "ticks per timed repeat")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--repeats", opt.repeats, "timed repeats; rows report medians")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--dt", opt.dt, "seconds per tick (scene step)")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--solver", opt.solver, "MlsMpm, StandardMpm, PbMpm")
      ->check(CLI::IsMember({"MlsMpm", "StandardMpm", "PbMpm"}))
      ->capture_default_str();
  app.add_option("--backend", opt.backend,
                 "cpu, or cuda: each scene on its own stream, the threads only launch its work and wait for it")
      ->transform(CLI::CheckedTransformer(std::map<std::string, Backend>{{"cpu", Backend::Cpu}, {"cuda", Backend::Cuda}}))
      ->capture_default_str();
  app.add_option("--out", opt.out, "path stem; writes <out>.md (empty: print only)")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  if (app.count("--out") == 0 && opt.backend == Backend::Cuda) opt.out = resultsStem("batch_cuda", true);
  const SolverType solver = solverTypes().at(opt.solver);

  RunInfo info = RunInfo::now(argc, argv);
  std::vector<Row> rows;
  for (int T : opt.threads) {
    // three sets at the same phase of the same scene: one alone, N stepped one after another
    // (each on T threads), N in a batch of T threads
    auto single = embeddingScene(solver, opt.backend, T);
    std::vector<std::unique_ptr<Scene>> serial, copies;
    std::vector<Scene*> all;
    for (int i = 0; i < opt.scenes; ++i) {
      serial.push_back(embeddingScene(solver, opt.backend, T));
      copies.push_back(embeddingScene(solver, opt.backend, T));
      all.push_back(copies.back().get());
    }
    SceneBatch batch(all, T);
    for (int t = 0; t < opt.warmup; ++t) {
      single->step(opt.dt);
      for (auto& sc : serial) sc->step(opt.dt);
      batch.step(opt.dt);
    }
    // timed tick by tick in turns, so a change in the machine's load falls on all three
    std::vector<Sample> one, seq, many;
    for (int r = 0; r < opt.repeats; ++r) {
      Sample a, b, c;
      for (int t = 0; t < opt.ticks; ++t) {
        add(a, timed([&](Sample& s) {
          const StepReport rep = single->step(opt.dt);
          s.sceneSteps += 1;
          s.particleSubsteps += (double)rep.substeps * single->particleCount();
        }));
        add(b, timed([&](Sample& s) {
          for (auto& sc : serial) {
            const StepReport rep = sc->step(opt.dt);
            s.sceneSteps += 1;
            s.particleSubsteps += (double)rep.substeps * sc->particleCount();
          }
        }));
        add(c, timed([&](Sample& s) {
          const std::vector<StepReport> reps = batch.step(opt.dt);
          for (size_t i = 0; i < reps.size(); ++i) {
            s.sceneSteps += 1;
            s.particleSubsteps += (double)reps[i].substeps * copies[i]->particleCount();
          }
        }));
      }
      one.push_back(a);
      seq.push_back(b);
      many.push_back(c);
      std::fprintf(stderr, "threads %d repeat %d: 1 scene %.2f s, %d one after another %.2f s, batch %.2f s (load %s)\n",
                   T, r + 1, a.wall, opt.scenes, b.wall, c.wall, loadAverage().c_str());
    }
    // every copy must be where the serial ones are: a scene's result does not depend on the
    // batch (on the CPU to the bit; the GPU's atomics add in no fixed order)
    std::vector<Vec3f> x0, xi;
    serial[0]->readPositions(serial[0]->particleObjects()[0], x0);
    for (auto& sc : copies) {
      sc->readPositions(sc->particleObjects()[0], xi);
      if (opt.backend == Backend::Cpu &&
          (xi.size() != x0.size() || std::memcmp(xi.data(), x0.data(), x0.size() * sizeof(Vec3f)) != 0))
        std::fprintf(stderr, "warning: batch copies differ from the scenes stepped alone\n");
    }
    rows.push_back(summarize(T, "1", one));
    rows.push_back(summarize(T, std::to_string(opt.scenes) + " one after another", seq));
    rows.push_back(summarize(T, std::to_string(opt.scenes) + " SceneBatch", many));
  }
  info.complete = true;

  std::ostringstream m;
  m << info.header("Batch throughput: " + std::to_string(opt.scenes) + " copies of the embedding scene against one",
                   MPM_BENCH_BUILD_TYPE);
  m << "Scene: the README's embedding tissue (9000 particles, dx 2 cm, Neo-Hookean E = 200 kPa), a kinematic "
       "ground and a 0.5 kg tool box falling onto it (a dynamic shape, no Bullet), "
    << solverName(solver) << (opt.backend == Backend::Cuda ? ", CUDA backend on " + cudaDeviceName() + " (each scene on its own stream)" : std::string()) << ", one scene step = " << num(opt.dt * 1000, 3) << " ms (the coupler's tick). "
    << opt.warmup << " warm-up steps, then " << opt.repeats << " repeats of " << opt.ticks
    << " steps; each step timed for the three sets in turn (so load changes fall on all three); medians of the "
       "repeats. Throughput is per wall second; the last ratio is the batch against the same scenes stepped one "
       "after another.\n\n";
  m << "| threads | scenes | wall per repeat [s] | CPU per repeat [s] | CPU / wall | scene-steps/s | "
       "M particle-substeps/s | substeps per step | throughput vs 1 scene | vs one after another | "
       "M particle-substeps per CPU-s | load after |\n";
  m << "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (size_t i = 0; i < rows.size(); ++i) {
    const Row& r = rows[i];
    const Row& base = rows[i - i % 3];
    const bool batched = i % 3 == 2;
    m << "| " << r.threads << " | " << r.scenes << " | " << num(r.wall, 2) << " | " << num(r.cpu, 2) << " | "
      << num(r.cpu / r.wall, 2) << " | " << num(r.stepsPerSecond, 1) << " | "
      << num(r.particleSubstepsPerSecond / 1e6, 2) << " | " << num(r.substepsPerTick, 1) << " | "
      << num(r.particleSubstepsPerSecond / base.particleSubstepsPerSecond, 2) << "x | "
      << (batched ? num(r.particleSubstepsPerSecond / rows[i - 1].particleSubstepsPerSecond, 2) + "x" : "") << " | "
      << num(r.particleSubstepsPerCpuSecond / 1e6, 2) << " | " << r.load << " |\n";
  }
  const std::string text = m.str();
  std::fputs(text.c_str(), stdout);
  if (!opt.out.empty()) writeResultFiles(opt.out, {{".md", text}});
  return 0;
}
