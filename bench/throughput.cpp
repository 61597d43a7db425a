// Throughput on the CRESSim scene (BENCH_SCENES.md section 1): for each box half-size and
// thread count, ms per frame, million particle-substeps per second, the share of each
// named step stage, and bytes per particle. Prints a markdown table and writes it, with a
// header naming the machine and the command, to <out>.md and <out>.csv.
//
//   bench_throughput --sizes 1,2.5 --threads 1,2 --frames 50 --out /tmp/throughput
//
// Scene variants (--variants) make pairs that check "pay only for what a scene
// uses": far-shapes (four kinematic shapes in the domain's top corners, far from every
// particle), big-domain (the domain 8x larger in node count, the box the same), neo-hookean
// (the other elastic law), many-shapes (100 small kinematic spheres resting on the box; -400:
// 400), thread (a thread of 100 dynamic segments lying on it). The memory bandwidth of the
// machine is measured at the start of the run (bandwidth.h) and each row's achieved bytes
// per second is set against it.
//
//   bench_throughput --sizes 1,2.5 --variants plain,far-shapes,big-domain
//   bench_throughput --bandwidth-only --threads 1,2
//   bench_throughput --trajectory /tmp/com.csv --sizes 1 --frames 250   # physics check
//
// Wall time only means something on an idle machine: bench/run_throughput.sh checks that
// first. Nothing here asserts on time.
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <exception>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>

#include "mpm/error.h"
#include "mpm/output.h"
#include "mpm/scene.h"
#include "bandwidth.h"
#include "bench_options.h"
#include "bench_report.h"
#include "scenes/standard_scenes.h"

namespace {

using namespace mpm::bench;

using mpm::scenes::CressimBench;


constexpr int kWarmupFrames = 2;                   // untimed frames before each timed run

/// Particle bytes an explicit substep (MLS-MPM, standard MPM) must move at the least, from
/// the layout in mpm/src/core/particle_state.h: read x, v, C, F, mass, volume0, object
/// (12 + 12 + 36 + 36 + 4 + 4 + 4 = 108) and write back x, v, C, F (96). `local` is only
/// touched by the per-frame reorder, and the grid (in cache at these sizes) is not counted.
constexpr double kBytesPerParticleSubstep = 2 * sizeof(mpm::Vec3f) + 2 * sizeof(mpm::Mat3f) + 3 * 4 +
                                            2 * sizeof(mpm::Vec3f) + 2 * sizeof(mpm::Mat3f);
static_assert(kBytesPerParticleSubstep == 204, "particle layout changed: recount the bytes");

/// A variant of the CRESSim scene, for the "pay only for what a scene uses" pairs.
struct SceneVariant {
  std::string name;  ///< plain, far-shapes, big-domain, neo-hookean, slicer, slicer-tough, many-shapes(-400), thread

  static SceneVariant parse(const std::string& name) {
    if (name == "plain" || name == "far-shapes" || name == "big-domain" || name == "neo-hookean" ||
        name == "slicer" || name == "slicer-tough" || name == "many-shapes" || name == "many-shapes-400" ||
        name == "thread")
      return SceneVariant{name};
    throw mpm::InvalidArgument("--variants", name,
                               "is not plain, far-shapes, big-domain, neo-hookean, slicer, slicer-tough, many-shapes,"
                               " many-shapes-400 or thread");
  }
  /// big-domain: [-11.1, 11.1]^3, 111 cells per axis (8.1x the nodes of 56^3), grown by
  /// whole grid blocks (7 x 0.8 m) on each side so the box sits on the grid exactly as in
  /// the plain scene.
  void adjust(mpm::SceneSettings& s) const {
    if (name == "big-domain") {
      s.domain.lower = {-11.1f, -11.1f, -11.1f};
      s.domain.upper = {11.1f, 11.1f, 11.1f};
    }
  }
  mpm::ParticleObjectDesc box(float halfSize) const {
    mpm::ParticleObjectDesc d = CressimBench::box(halfSize);
    if (name == "neo-hookean") d.material.model = mpm::MaterialModel::NeoHookeanDecoupled;
    if (name == "slicer-tough") d.material.fractureToughness = 1000.f;
    return d;
  }
  /// slicer, slicer-tough: a blade across the whole box (its plane z = 0.05, off the node
  /// layers), its edge starting 0.2 m above the box's top and moving down at 2 m/s, so it
  /// cuts into the falling box through the timed frames; slicer-tough adds the resistance
  /// to cutting (G_c 1000 J/m^2).
  void addSlicer(mpm::Scene& scene, float halfSize) const {
    if (name != "slicer" && name != "slicer-tough") return;
    mpm::QuadSlicerDesc d;
    d.halfLength = halfSize + 0.5f;
    d.width = 2.f * halfSize + 1.f;
    d.pose.position = {0.f, halfSize + 0.2f, 0.05f};
    d.linearVelocity = {0.f, -2.f, 0.f};
    scene.addSlicer(d);
  }
  /// far-shapes: a kinematic box, sphere, capsule and cylinder of size 0.3 m centred at
  /// (+-4.6, 4.6, +-4.6), at least 1.5 m (7 cells) from the box's top corner at half-size 2.5
  /// before it falls; none near the particles at half-sizes up to 2.5.
  void addShapes(mpm::Scene& scene) const {
    if (name != "far-shapes") return;
    const mpm::GeometryType types[4] = {mpm::GeometryType::Box, mpm::GeometryType::Sphere,
                                        mpm::GeometryType::Capsule, mpm::GeometryType::Cylinder};
    for (int i = 0; i < 4; ++i) {
      mpm::ShapeDesc d;
      mpm::Geometry g;
      g.type = types[i];
      g.halfExtents = {0.3f, 0.3f, 0.3f};
      g.radius = 0.3f;
      g.halfHeight = 0.3f;
      d.parts.push_back(g);
      d.pose.position = {(i & 1) ? 4.6f : -4.6f, 4.6f, (i & 2) ? 4.6f : -4.6f};
      scene.addShape(d);
    }
  }
  /// many-shapes, many-shapes-400 (a 100-link thread is 100 bodies): 10 x 10
  /// (20 x 20) kinematic spheres in a square pattern over the box's top face, a tenth of a
  /// cell into it. Radius 1.5 dx where the pattern leaves room (0.4 of its pitch otherwise:
  /// 0.4 dx at 8000 particles, 1 dx at 125k); one under 0.75 dx reaches the grid as 0.75 dx
  /// thick (PartView::band), like a thread's link. The box falls: each frame the spheres are
  /// given its free fall (Followers::follow), as a coupler gives shapes their bodies' motion
  /// every tick, so they stay on it, and they sink into it at 0.1 dx/s: falling with the box
  /// alone, nothing approaches them and no node exchanges momentum (measured: impulse 0);
  /// sinking, all 100 push on the box in almost every frame of the run.
  /// thread: the same for a thread (mpm/curves.h, LineSegmentsDesc) of 100 dynamic segments
  /// of about 0.9 dx (radius 0.1 dx, 50 g/m, friction 0.2), lying in seven rows 0.3 of the
  /// box's half-size apart across its top face, its centre line a tenth of a cell into it:
  /// 100 bodies, each with the four contact passes of a dynamic body per substep (three
  /// measuring), and each band node asking the thread's other segments whether they are
  /// nearer (nearerSegment), as the suturing demo's thread does.
  struct Followers {
    std::vector<mpm::ShapeId> ids;
    mpm::CurveId thread;
    std::vector<mpm::Vec3f> points;  ///< the thread's points at time 0 [m]
    float top = 0;   ///< the centres' height at time 0 [m]
    float sink = 0;  ///< their speed into the box [m/s]
    /// Places the spheres (and the thread's points) on the box's free fall at the scene's
    /// time (a kinematic shape moves on at constant velocity within a frame: 0.5 g dt^2 =
    /// 0.2 mm behind at its end).
    void follow(mpm::Scene& scene) const {
      const float t = (float)scene.time(), g = scene.settings().gravity.y;
      const mpm::Vec3f velocity{0.f, g * t - sink, 0.f};
      for (const mpm::ShapeId id : ids) {
        mpm::ShapeState s = scene.shapeState(id);
        s.pose.position.y = top + 0.5f * g * t * t - sink * t;
        s.linearVelocity = velocity;
        scene.setShapeState(id, s);
      }
      if (points.empty()) return;
      std::vector<mpm::Vec3f> x = points;
      for (mpm::Vec3f& p : x) p.y = p.y + 0.5f * g * t * t - sink * t;
      scene.setCurvePoints(thread, x, std::vector<mpm::Vec3f>(x.size(), velocity));
    }
  };
  Followers addFollowers(mpm::Scene& scene, float halfSize) const {
    Followers out;
    if (name == "thread") return addThread(scene, halfSize);
    if (name != "many-shapes" && name != "many-shapes-400") return out;
    const int perSide = name == "many-shapes" ? 10 : 20;
    const float dx = scene.settings().dx, pitch = 2.f * halfSize / (float)perSide;
    const float radius = std::min(1.5f * dx, 0.4f * pitch);
    out.top = halfSize + std::max(radius, 0.75f * dx) - 0.1f * dx;
    out.sink = 0.1f * dx;
    for (int i = 0; i < perSide; ++i)
      for (int k = 0; k < perSide; ++k) {
        mpm::ShapeDesc d;
        d.parts.push_back(mpm::Geometry::sphere(radius));
        d.pose.position = {-halfSize + (i + 0.5f) * pitch, out.top, -halfSize + (k + 0.5f) * pitch};
        out.ids.push_back(scene.addShape(d));
      }
    return out;
  }
  /// The thread: 101 points at equal steps along seven rows along x (0.9 of the half-size
  /// either side) joined at alternate ends, its centre line 0.1 dx below the top face.
  Followers addThread(mpm::Scene& scene, float halfSize) const {
    Followers out;
    const float dx = scene.settings().dx, reach = 0.9f * halfSize;
    constexpr int kRows = 7, kSegments = 100;
    const float spacing = 2.f * reach / (float)(kRows - 1), row = 2.f * reach;
    const float length = kRows * row + (kRows - 1) * spacing;
    out.top = halfSize - 0.1f * dx;
    out.sink = 0.1f * dx;
    for (int i = 0; i <= kSegments; ++i) {
      float s = length * (float)i / (float)kSegments;  // along the path
      int r = 0;
      while (r < kRows - 1 && s > row + spacing) {
        s -= row + spacing;
        ++r;
      }
      const float z = -reach + spacing * (float)r + std::max(0.f, s - row);  // on a turn past the row's end
      const float along = std::min(s, row);
      const float x = (r % 2 == 0) ? -reach + along : reach - along;
      out.points.push_back({x, out.top, z});
    }
    mpm::LineSegmentsDesc d;
    d.points = out.points;
    d.radius = 0.1f * dx;
    d.friction = 0.2f;
    d.linearDensity = 0.05f;
    d.gravity = scene.settings().gravity;
    out.thread = scene.addCurve(d);
    return out;
  }
};
constexpr size_t kLargeRunParticles = 500000;      // above this, --frames-large applies

/// A solver as the benchmark runs it: MLS-MPM and standard MPM take CressimBench's 10
/// substeps of 0.002 s per frame; PB-MPM one step of 0.02 s with `iterations` iterations
/// (CRESSim-MPM, section III-D).
struct SolverCase {
  std::string name;  ///< as given on the command line: mls, standard, pb<iterations>
  mpm::SolverType type = mpm::SolverType::MlsMpm;
  int iterations = 1;  ///< P2G-G2P cycles per substep (1 for the explicit solvers)

  static SolverCase parse(const std::string& name) {
    SolverCase c;
    c.name = name;
    if (name == "mls") return c;
    if (name == "standard") {
      c.type = mpm::SolverType::StandardMpm;
      return c;
    }
    if (name.rfind("pb", 0) == 0 && name.size() > 2 &&
        name.find_first_not_of("0123456789", 2) == std::string::npos) {
      c.type = mpm::SolverType::PbMpm;
      c.iterations = std::stoi(name.substr(2));
      return c;
    }
    throw mpm::InvalidArgument("--solvers", name, "is not mls, standard or pb<iterations> (e.g. pb10)");
  }
  std::string label() const {
    switch (type) {
      case mpm::SolverType::MlsMpm: return "MLS-MPM";
      case mpm::SolverType::StandardMpm: return "standard MPM";
      case mpm::SolverType::PbMpm: return "PB-MPM " + std::to_string(iterations) + " it";
      case mpm::SolverType::Mtled: return "MTLED";
    }
    return name;
  }
  mpm::SceneSettings settings(int threads, const SceneVariant& variant,
                              mpm::Backend backend = mpm::Backend::Cpu) const {
    mpm::SceneSettings s = CressimBench::settings(backend, threads);
    variant.adjust(s);
    s.solver = type;
    if (type == mpm::SolverType::PbMpm) {
      s.pbMpm.iterations = iterations;
      s.substeps.fixedSubsteps = 1;  // dt = 0.02 s
    }
    return s;
  }
};

/// What the command line asks for.
struct Options {
  std::vector<std::string> solvers{"mls", "standard", "pb10", "pb20"};  ///< SolverCase names
  std::vector<std::string> variants{"plain"};  ///< SceneVariant names
  std::vector<float> sizes{0.5f, 1.f, 1.5f, 2.5f, 5.f};  ///< box half-sizes [m]
  std::vector<int> threads{1, 2};                          ///< CPU worker threads per run
  mpm::Backend backend = mpm::Backend::Cpu;                ///< of every run
  int frames = 100;       ///< timed frames per run
  int framesLarge = 20;   ///< timed frames per run above kLargeRunParticles particles
  int repeats = 3;        ///< runs per row; the row reports their median
  /// A run during which other processes used more CPU than this [cores] is redone.
  double maxOtherLoad = 0.1;
  int retries = 10;         ///< redos of one run on a busy machine before keeping a busy one
  double retryWait = 20;    ///< pause before a redo [s]
  std::string out = mpm::bench::resultsStem("throughput");  ///< path stem of the .md and .csv files
  int bandwidthMiB = 256;      ///< array size of the bandwidth measurement; 0 skips it
  bool bandwidthOnly = false;  ///< measure the bandwidth, print it as CSV, and stop
  std::string trajectory;      ///< physics check: write the box's centre of mass per frame here
  std::string checkpoint;      ///< time Scene::save / load of the scene to this file instead
};

/// CRESSim-MPM v2.2.0 CPU solvers, serial, in M particle-substeps/s (PB-MPM: M
/// particle-iterations/s), from BENCH_SCENES.md section 1.
struct PeerFigure {
  size_t particles;
  double mlsMpm;
  double standardMpm;
  double pbMpm;
};
constexpr PeerFigure kCressim[] = {
    {8000, 0.73, 0.88, 0.67},
    {125000, 0.81, 0.97, 0.81},
    {1000000, 0.81, 0.96, 0.72},
};

/// CRESSim's serial figure for this solver at exactly this particle count, or NaN.
double cressimFigure(const SolverCase& solver, size_t particles) {
  for (const PeerFigure& f : kCressim)
    if (f.particles == particles)
      return solver.type == mpm::SolverType::MlsMpm        ? f.mlsMpm
             : solver.type == mpm::SolverType::StandardMpm ? f.standardMpm
                                                           : f.pbMpm;
  return std::nan("");
}

/// One timed run: `frames` frames of a fresh scene after the warm-up.
struct RunSample {
  double wallSeconds = 0;   ///< steady-clock time of the timed frames [s]
  double cpuSeconds = 0;    ///< process CPU time (all threads) of the timed frames [s]
  long long substeps = 0;   ///< substeps the timed frames took
  mpm::StageTimings stages; ///< the library's per-stage times over the timed frames
  double otherLoad = 0;     ///< CPU used by other processes during the timed frames [cores]
  bool abandoned = false;   ///< stopped early because the machine was busy; not a result
  uint64_t positionsHash = 0;  ///< of the particles at the end (bench_report.h)
};

/// One table row: a solver at a half-size and a thread count, over all its repeats.
struct Row {
  SolverCase solver;
  SceneVariant variant;
  float halfSize = 0;
  size_t particles = 0;
  int threads = 0;
  mpm::Backend backend = mpm::Backend::Cpu;
  int frames = 0;
  size_t memoryBytes = 0;
  std::vector<RunSample> samples;

  // derived by summarise()
  bool summarised = false;
  double msPerFrame = 0, msMin = 0, msMax = 0;
  double cpuMsPerFrame = 0;
  double mps = 0;  ///< million particle-substeps (PB-MPM: particle-iterations) per second
  double sortShare = 0, p2gShare = 0, gridShare = 0, g2pShare = 0, otherShare = 0;  ///< [%]
  double bytesPerParticle = 0;
  double achievedGBs = 0;  ///< kBytesPerParticleSubstep at this row's M/s [1e9 bytes/s]
  double otherLoad = 0;  ///< the most CPU other processes used during one of the runs [cores]
  int redone = 0;        ///< runs redone because the machine was busy
  double speedup = std::nan("");  ///< ms/frame at 1 thread over this row's; NaN without a 1-thread row
  double vsPlain = std::nan("");  ///< this row's ms/frame over the plain scene's (same solver, size, threads)
  double cressim = std::nan("");  ///< CRESSim's serial M/s for this solver at this particle count
};

double processCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/// CPU time all processes have used since boot [s], from /proc/stat; NaN if unreadable.
double machineBusySeconds() {
  std::ifstream in("/proc/stat");
  std::string cpu;
  unsigned long long user = 0, nice = 0, system = 0, idle = 0, iowait = 0, irq = 0, softirq = 0,
                     steal = 0;
  if (!(in >> cpu >> user >> nice >> system >> idle >> iowait >> irq >> softirq >> steal) ||
      cpu != "cpu")
    return std::nan("");
  return (double)(user + nice + system + irq + softirq + steal) / (double)sysconf(_SC_CLK_TCK);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// Particle count of the box at `halfSize`, read from a scene rather than recomputed, so
/// that the frame count follows what the library actually samples.
size_t particlesAt(float halfSize) {
  mpm::Scene scene(CressimBench::settings(mpm::Backend::Cpu, 1));
  scene.addParticleObject(CressimBench::box(halfSize));
  return scene.particleCount();
}

/// Builds the scene, runs the warm-up and times `row.frames` frames. With `maxOtherLoad`
/// finite, abandons the run as soon as other processes are seen to take more CPU than that.
RunSample timeRun(Row& row, double maxOtherLoad, mpm::io::ProgressBar& progress,
                  long long& framesDone) {
  mpm::Scene scene(row.solver.settings(row.threads, row.variant, row.backend));
  const mpm::ParticleObjectId box = scene.addParticleObject(row.variant.box(row.halfSize));
  row.variant.addShapes(scene);
  row.variant.addSlicer(scene, row.halfSize);
  const SceneVariant::Followers followers = row.variant.addFollowers(scene, row.halfSize);
  for (int f = 0; f < kWarmupFrames; ++f) {
    followers.follow(scene);
    scene.step(CressimBench::kFrameDt);
    progress.update(++framesDone);
  }
  scene.resetTimings();

  RunSample s;
  const auto wall0 = std::chrono::steady_clock::now();
  const double cpu0 = processCpuSeconds();
  const double busy0 = machineBusySeconds();
  double nextLoadCheck = 1.0;  // [s into the run] /proc/stat is read about once a second
  for (int f = 0; f < row.frames; ++f) {
    followers.follow(scene);
    s.substeps += scene.step(CressimBench::kFrameDt).substeps;
    progress.update(++framesDone);
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    if (std::isfinite(maxOtherLoad) && elapsed >= nextLoadCheck && f + 1 < row.frames) {
      nextLoadCheck = elapsed + 1.0;
      const double other = (machineBusySeconds() - busy0 - (processCpuSeconds() - cpu0)) / elapsed;
      if (other > maxOtherLoad) {
        s.otherLoad = other;
        s.abandoned = true;
        return s;
      }
    }
  }
  s.cpuSeconds = processCpuSeconds() - cpu0;
  s.wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  // /proc/stat counts in clock ticks (10 ms): noise of about 0.02 s over the run
  s.otherLoad = std::max(0.0, (machineBusySeconds() - busy0 - s.cpuSeconds) / s.wallSeconds);
  s.stages = scene.timings();
  std::vector<mpm::Vec3f> x;
  scene.readPositions(box, x);
  s.positionsHash = positionsHash(x);
  row.particles = scene.particleCount();
  row.memoryBytes = scene.memoryBytes();
  return s;
}

/// Times one run and appends it to the row. A run during which other processes take CPU
/// (on 2 cores, one busy neighbour stalls every OpenMP barrier) is abandoned and redone
/// after a pause; the last try runs to the end whatever the load, and the row says so.
void runOnce(Row& row, const Options& opt, mpm::io::ProgressBar& progress,
             long long& framesDone) {
  const long long framesBefore = framesDone;
  for (int attempt = 0;; ++attempt) {
    framesDone = framesBefore;
    const bool last = attempt >= opt.retries;
    RunSample s = timeRun(row, last ? INFINITY : opt.maxOtherLoad, progress, framesDone);
    if (!s.abandoned && (last || !(s.otherLoad > opt.maxOtherLoad))) {
      row.samples.push_back(s);
      std::fprintf(stderr, "\n%s %s, %zu particles, %d thread(s): positions hash %016llx\n", row.solver.name.c_str(),
                   row.variant.name.c_str(), row.particles, row.threads, (unsigned long long)s.positionsHash);
      return;
    }
    row.redone++;
    std::fprintf(stderr,
                 "\nbusy machine: other processes use %.2f cores during the %zu-particle,"
                 " %d-thread run; redoing it in %g s (%d/%d)\n",
                 s.otherLoad, row.particles, row.threads, opt.retryWait, attempt + 1, opt.retries);
    std::this_thread::sleep_for(std::chrono::duration<double>(opt.retryWait));
  }
}

/// Fills the derived columns of one row from its samples.
void summarise(Row& r) {
  std::vector<double> ms, cpuMs;
  double wall = 0, sort = 0, p2g = 0, grid = 0, g2p = 0;
  long long substeps = 0;
  r.otherLoad = 0;
  for (const RunSample& s : r.samples) {
    r.otherLoad = std::max(r.otherLoad, s.otherLoad);
    ms.push_back(1e3 * s.wallSeconds / r.frames);
    cpuMs.push_back(1e3 * s.cpuSeconds / r.frames);
    wall += s.wallSeconds;
    sort += s.stages.sort;
    p2g += s.stages.p2g;
    grid += s.stages.gridUpdate;
    g2p += s.stages.g2p;
    substeps += s.substeps;
  }
  r.msPerFrame = median(ms);
  r.msMin = *std::min_element(ms.begin(), ms.end());
  r.msMax = *std::max_element(ms.begin(), ms.end());
  r.cpuMsPerFrame = median(cpuMs);
  const double substepsPerFrame = (double)substeps / ((double)r.frames * r.samples.size());
  r.mps = (double)r.particles * substepsPerFrame * r.solver.iterations / (1e-3 * r.msPerFrame) / 1e6;
  // shares of the timed wall time, summed over repeats; "other" is what lies outside the
  // four stages (starting the step's worker thread, the end-of-step check)
  r.sortShare = 100.0 * sort / wall;
  r.p2gShare = 100.0 * p2g / wall;
  r.gridShare = 100.0 * grid / wall;
  r.g2pShare = 100.0 * g2p / wall;
  r.otherShare = 100.0 - r.sortShare - r.p2gShare - r.gridShare - r.g2pShare;
  r.bytesPerParticle = (double)r.memoryBytes / (double)r.particles;
  r.achievedGBs = r.mps * kBytesPerParticleSubstep / 1e3;
  // CRESSim's figures are its serial CPU solvers': no peer for a GPU row
  r.cressim = r.backend == mpm::Backend::Cpu ? cressimFigure(r.solver, r.particles) : std::nan("");
  r.summarised = true;
}

/// Speed-up of each row over the 1-thread row of the same solver and half-size.
void fillSpeedups(std::vector<Row>& rows) {
  for (Row& r : rows)
    for (const Row& one : rows)
      if (one.solver.name == r.solver.name && one.variant.name == r.variant.name &&
          one.halfSize == r.halfSize && one.threads == 1)
        r.speedup = one.msPerFrame / r.msPerFrame;
  for (Row& r : rows)
    for (const Row& plain : rows)
      if (plain.variant.name == "plain" && plain.solver.name == r.solver.name && plain.halfSize == r.halfSize &&
          plain.threads == r.threads && plain.summarised)
        r.vsPlain = r.msPerFrame / plain.msPerFrame;
}

/// With scene variants: each variant's time against the plain scene's, the pay-for-use pairs.
std::string pairsTable(const std::vector<Row>& rows) {
  std::ostringstream t;
  bool any = false;
  for (const Row& r : rows) any = any || r.variant.name != "plain";
  if (!any) return "";
  t << "## Pay only for what a scene uses: each variant against the plain scene\n\n"
       "Medians of the repeats, and the fastest runs' ratio (on a busy machine the fastest run is"
       " the least disturbed) and the CPU time's (all threads; less sensitive to other load than"
       " wall time).\n\n"
       "| solver | scene | particles | threads | ms/frame | plain ms/frame | time / plain |"
       " fastest / plain's fastest | CPU time / plain's | bytes/particle | plain bytes/particle |\n"
       "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const Row& r : rows) {
    if (r.variant.name == "plain" || !r.summarised) continue;
    for (const Row& p : rows)
      if (p.variant.name == "plain" && p.solver.name == r.solver.name && p.halfSize == r.halfSize &&
          p.threads == r.threads && p.summarised)
        t << "| " << r.solver.label() << " | " << r.variant.name << " | " << r.particles << " | " << r.threads
          << " | " << num(r.msPerFrame, 2) << " | " << num(p.msPerFrame, 2) << " | " << num(r.vsPlain, 3)
          << " | " << num(r.msMin / p.msMin, 3) << " | " << num(r.cpuMsPerFrame / p.cpuMsPerFrame, 3)
          << " | " << num(r.bytesPerParticle, 0) << " | " << num(p.bytesPerParticle, 0) << " |\n";
  }
  t << "\nWhat each pair measures:\n\n"
       "- far-shapes: a shape anywhere in the scene turns on the accumulation of each node's material"
       " centroid (w m x_p, for thin shapes) in P2G (`scatterParticles`, mpm/src/solvers/substep_stages.h),"
       " whatever its distance; the contact tests each shape against each active block's bounds"
       " before any node, and G2P tests each particle against each part's bounds (`pushOutOfParts`).\n"
       "- big-domain: the active blocks follow the particles; only the dense block table (one int per"
       " 4^3 nodes) grows with the domain, which shows in bytes/particle at small particle counts.\n"
       "- neo-hookean: the library has no plasticity model (fixed corotated and decoupled Neo-Hookean"
       " are both purely elastic), so there is no \"elastic skips plasticity\" pair to make; this row"
       " compares the two elastic laws (Neo-Hookean needs no polar decomposition).\n"
       "- slicer, slicer-tough: the cost of a cut in progress (each substep records the blade on the"
       " particles beside it; a cut particle transfers through its own side's nodes, transfer/cut.h);"
       " slicer-tough adds the resistance to cutting. Plain runs no cut code: the transfers branch on"
       " a scene flag that stays off until a slicer is added.\n"
       "- thread: a thread of 100 dynamic segments (about 0.9 dx each) lying in seven rows on the box's top"
       " face, following its fall and sinking into it at 0.1 dx/s\n"
       "- many-shapes, many-shapes-400: 100 (400) small kinematic spheres resting on the box's top"
       " face, given its free fall every frame (a 100-link thread is 100 bodies); the cost"
       " of contact with many shapes at once (the contact pass, the push-out in G2P, the material"
       " centroids in P2G, the shapes' upload each frame).\n\n";
  return t.str();
}

/// The results as a markdown table.
std::string markdownTable(const std::vector<Row>& rows, const Options& opt) {
  std::ostringstream t;
  t << "| solver | scene | half-size [m] | particles | threads | frames | ms/frame | CPU ms/frame | M/s"
       " | particle GB/s | sort % | P2G % | grid % | G2P % | other % | bytes/particle | speed-up vs 1 thread"
       " | CRESSim M/s | ratio to CRESSim | other load [cores] |\n";
  t << "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const Row& r : rows) {
    t << "| " << r.solver.label() << " | " << r.variant.name << " | " << num(r.halfSize, 1) << " | " << r.particles << " | " << r.threads << " | "
      << r.frames << " | " << num(r.msPerFrame, 2) << " | " << num(r.cpuMsPerFrame, 2) << " | "
      << num(r.mps, 2) << " | " << num(r.achievedGBs, 2) << " | " << num(r.sortShare, 1) << " | " << num(r.p2gShare, 1) << " | "
      << num(r.gridShare, 1) << " | " << num(r.g2pShare, 1) << " | " << num(r.otherShare, 1)
      << " | " << num(r.bytesPerParticle, 0) << " | " << num(r.speedup, 2) << " | "
      << num(r.cressim, 2) << " | " << num(r.mps / r.cressim, 2) << " | "
      << num(r.otherLoad, 2) << (r.otherLoad > opt.maxOtherLoad ? " (busy)" : "") << " |\n";
  }
  return t.str();
}

std::string csvTable(const std::vector<Row>& rows) {
  std::ostringstream t;
  t << "solver,variant,iterations,half_size_m,particles,threads,frames,repeats,ms_per_frame_median,ms_per_frame_min,"
       "ms_per_frame_max,cpu_ms_per_frame,m_particle_substeps_per_s,particle_gb_per_s,sort_pct,p2g_pct,grid_pct,"
       "g2p_pct,other_pct,memory_bytes,bytes_per_particle,speedup_vs_1_thread,"
       "cressim_m_per_s,ratio_to_cressim,other_load_cores,runs_redone\n";
  auto field = [](double v, int decimals) { return std::isnan(v) ? std::string() : num(v, decimals); };
  for (const Row& r : rows) {
    t << r.solver.name << ',' << r.variant.name << ',' << r.solver.iterations << ',' << num(r.halfSize, 3) << ',' << r.particles << ',' << r.threads << ',' << r.frames << ','
      << r.samples.size() << ',' << num(r.msPerFrame, 3) << ',' << num(r.msMin, 3) << ','
      << num(r.msMax, 3) << ',' << num(r.cpuMsPerFrame, 3) << ',' << num(r.mps, 4) << ','
      << num(r.achievedGBs, 3) << ','
      << num(r.sortShare, 2) << ',' << num(r.p2gShare, 2) << ',' << num(r.gridShare, 2) << ','
      << num(r.g2pShare, 2) << ',' << num(r.otherShare, 2) << ',' << r.memoryBytes << ','
      << num(r.bytesPerParticle, 1) << ',' << field(r.speedup, 3) << ',' << field(r.cressim, 2)
      << ',' << field(r.mps / r.cressim, 3) << ',' << num(r.otherLoad, 3) << ',' << r.redone
      << '\n';
  }
  return t.str();
}





/// The bandwidth lines of the report, or a note that none was measured.
std::string bandwidthText(const std::vector<Bandwidth>& bw) {
  std::ostringstream m;
  if (bw.empty()) return "Memory bandwidth: not measured in this run (--bandwidth-mib 0).\n\n";
  m << "Memory bandwidth measured at the start of this run (bench/bandwidth.h: float arrays of "
    << bw[0].arrayBytes / (1 << 20) << " MiB, best of 8 passes; 12 bytes per element counted):\n\n"
       "| threads | triad a = b + s c [GB/s] | in-place update a += s b [GB/s] |\n|---:|---:|---:|\n";
  for (const Bandwidth& b : bw)
    m << "| " << b.threads << " | " << num(b.triadGBs, 2) << " | " << num(b.updateGBs, 2) << " |\n";
  m << "\n";
  return m.str();
}

std::vector<Bandwidth> measureBandwidths(const Options& opt) {
  std::vector<Bandwidth> bw;
  if (opt.bandwidthMiB <= 0) return bw;
  for (const int t : opt.threads) bw.push_back(measureBandwidth(t, (size_t)opt.bandwidthMiB));
  return bw;
}

std::string markdownReport(const RunInfo& info, const Options& opt, const std::vector<Row>& rows,
                           const std::vector<Bandwidth>& bw) {
  std::ostringstream m;
  const bool gpu = opt.backend == mpm::Backend::Cuda;
  m << info.header(std::string("Throughput: CRESSim scene, ") + (gpu ? "CUDA" : "CPU") + " backend",
                   MPM_BENCH_BUILD_TYPE);
  if (gpu)
    m << "- GPU: " << mpm::cudaDeviceName()
      << " (threads: the host's OpenMP threads, which only launch kernels; no peer ratio, CRESSim's"
         " figures being its serial CPU solvers'; the stage shares are host timers around asynchronous"
         " launches, so the kernels' time lands in the stage that waits for the device, binning, which"
         " reads the active-block count back: they do not split the GPU's time)\n\n";
  if (std::any_of(rows.begin(), rows.end(), [&](const Row& r) { return r.otherLoad > opt.maxOtherLoad; }))
    m << "**Preliminary: rows marked (busy) ran while other processes took more than " << opt.maxOtherLoad
      << " cores; their times and ratios are not for quoting. Rerun on an idle machine.**\n\n";
  m << "Scene (BENCH_SCENES.md section 1, `mpm::scenes::CressimBench`): grid [-5.5, 5.5]^3,"
       " cell 0.2; a box of particles at spacing 0.1, mass 10 each, centred at the origin;"
       " fixed corotated, E = 5e5, nu = 0.4; gravity (0, -1, 0). MLS-MPM and standard MPM take "
    << CressimBench::kSubstepsPerFrame << " substeps per " << CressimBench::kFrameDt
    << " s frame; PB-MPM one step of " << CressimBench::kFrameDt
    << " s with 10 or 20 iterations (CRESSim-MPM, section III-D).\n\n";
  m << "Method: each run builds a fresh scene, steps " << kWarmupFrames
    << " untimed warm-up frames, then times `frames` calls of `Scene::step(" << CressimBench::kFrameDt
    << ")` (" << opt.frames << " frames; " << opt.framesLarge << " above " << kLargeRunParticles
    << " particles). Each row is " << opt.repeats
    << " such runs (thread counts interleaved within each repeat).\n\n";
  m << "- ms/frame: median steady-clock wall time over the repeats (min and max in the CSV).\n"
       "- CPU ms/frame: median process CPU time, all threads.\n"
       "- M/s: million particle-substeps per second at the median wall time; for PB-MPM,"
       " particle-iterations (each iteration is a full P2G, grid update and G2P).\n"
       "- sort / P2G / grid / G2P %: the library's `StageTimings` (sort: binning particles into"
       " grid blocks, activating blocks, the per-frame reorder; P2G includes setting the nodes and, run in its"
       " pass, the grid update (velocity, gravity, walls: the grid column is 0 without mirror"
       " planes) and PB-MPM's G2P of every cycle but its last; G2P includes the F update), summed over the"
       " repeats, as shares of"
       " the timed wall time; other: the rest (the step's worker-thread start, end-of-step check).\n"
       "- particle GB/s: M/s times "
    << kBytesPerParticleSubstep
    << " bytes, the particle state an explicit substep must read and write at the least (read x, v,"
       " C, F, mass, volume0, object: 108 B; write x, v, C, F: 96 B; the grid not counted), to set"
       " against the measured bandwidth below. For PB-MPM rows it is per iteration and only"
       " indicative.\n"
       "- scene: plain is the CRESSim scene; far-shapes adds a kinematic box, sphere, capsule and"
       " cylinder (0.3 m) at (+-4.6, 4.6, +-4.6), far from every particle up to half-size 2.5;"
       " big-domain grows the domain to [-11.1, 11.1]^3 (8.1x the nodes; the box on the grid as"
       " in plain); neo-hookean uses the decoupled Neo-Hookean law instead of fixed corotated;"
       " slicer adds a blade across the box moving down at 2 m/s from 0.2 m above it (slicer-tough:"
       " with G_c 1000 J/m^2); many-shapes puts 10 x 10 kinematic spheres (radius 1.5 dx, at most 0.4"
       " of their pitch) on the box's top face, a tenth of a cell into it, moved with its free fall"
       " each frame and sinking into it at 0.1 dx/s (many-shapes-400: 20 x 20); thread lays a thread"
       " of 100 dynamic segments (radius 0.1 dx, 50 g/m, friction 0.2) in seven rows across the top"
       " face, its points moved the same way.\n"
       "- bytes/particle: `Scene::memoryBytes()` (particles, sort scratch and grid blocks) over"
       " the particle count, after the run.\n"
       "- speed-up vs 1 thread: ms/frame of the 1-thread row of the same size, from this run,"
       " over this row's.\n"
       "- ratio to CRESSim: this row's M/s over CRESSim-MPM's serial figure for the same solver"
       " at the same particle count. CRESSim's CPU solvers are serial, so on rows with more threads the ratio"
       " includes our threading.\n"
       "- other load: the most CPU that other processes used during one of the row's runs"
       " (from /proc/stat), in cores. A run with more than "
    << opt.maxOtherLoad << " (checked about once a second) is abandoned and redone after "
    << opt.retryWait << " s, up to " << opt.retries
    << " times; the last try is kept whatever the load, and \"(busy)\" marks its row.\n\n";
  m << bandwidthText(bw);
  m << "## Results\n\n" << markdownTable(rows, opt) << "\n";
  m << pairsTable(rows);
  m << "## Peer figures: CRESSim-MPM v2.2.0, CPU solvers (serial)\n\n"
       "From BENCH_SCENES.md section 1: measured on AMD EPYC Zen 3, 2 cores, while the machine"
       " was partly busy (treat as ±20%). M/s = million particle-substeps per second; PB-MPM in"
       " M particle-iterations/s. Its memory follows capacity (176 MiB at 1M particles); its"
       " dense grid costs ~0.8 ms per substep whatever the particle count.\n\n"
       "| CRESSim-MPM solver | 8k | 125k | 1M |\n|---|---:|---:|---:|\n";
  m << "| MLS-MPM |";
  for (const PeerFigure& f : kCressim) m << " " << num(f.mlsMpm, 2) << " |";
  m << "\n| standard MPM |";
  for (const PeerFigure& f : kCressim) m << " " << num(f.standardMpm, 2) << " |";
  m << "\n| PB-MPM (M particle-iterations/s) |";
  for (const PeerFigure& f : kCressim) m << " " << num(f.pbMpm, 2) << " |";
  m << "\n";
  return m.str();
}

/// Writes <out>.md and <out>.csv; called after each size so a long run leaves its rows.
void writeResults(const RunInfo& info, const Options& opt, const std::vector<Row>& rows,
                  const std::vector<Bandwidth>& bw) {
  writeResultFiles(opt.out, {{".md", markdownReport(info, opt, rows, bw)}, {".csv", csvTable(rows)}});
}

/// Physics check for the peers (bench/peers): MLS-MPM on the plain scene at the first size
/// and thread count, the box's centre of mass and lowest particle after every frame, as CSV
/// in the format bench/peers/taichi_cressim.py --trajectory writes.
int writeTrajectory(const Options& opt) {
  mpm::Scene scene(SolverCase::parse("mls").settings(opt.threads[0], SceneVariant{"plain"}));
  const mpm::ParticleObjectId id = scene.addParticleObject(CressimBench::box(opt.sizes[0]));
  std::ostringstream t;
  t << "frame,t,com_x,com_y,com_z,min_y\n";
  std::vector<mpm::Vec3f> x;
  for (int f = 0; f <= opt.frames; ++f) {
    if (f) scene.step(CressimBench::kFrameDt);
    scene.readPositions(id, x);
    double c[3] = {0, 0, 0}, minY = 1e30;
    for (const mpm::Vec3f& p : x) {
      for (int a = 0; a < 3; ++a) c[a] += p[a];
      minY = std::min(minY, (double)p.y);
    }
    char line[160];
    std::snprintf(line, sizeof line, "%d,%.4f,%.7f,%.7f,%.7f,%.7f\n", f,
                  f * (double)CressimBench::kFrameDt, c[0] / x.size(), c[1] / x.size(), c[2] / x.size(), minY);
    t << line;
  }
  writeResultFiles(opt.trajectory, {{"", t.str()}});
  std::fprintf(stderr, "wrote %s\n", opt.trajectory.c_str());
  return 0;
}

/// Checkpoint cost: MLS-MPM at the first size and thread count after --frames
/// frames; --repeats saves to the file and loads from it (and the same in memory), medians
/// of wall and process CPU time, and the file's size.
int timeCheckpoint(const Options& opt) {
  mpm::Scene scene(SolverCase::parse("mls").settings(opt.threads[0], SceneVariant{"plain"}));
  scene.addParticleObject(CressimBench::box(opt.sizes[0]));
  for (int f = 0; f < opt.frames; ++f) scene.step(CressimBench::kFrameDt);
  std::vector<double> wall[4], cpu[4];
  size_t bytes = 0;
  const char* names[4] = {"save (file)", "load (file)", "saveToMemory", "loadFromMemory"};
  std::vector<uint8_t> memory;
  for (int rep = 0; rep < opt.repeats; ++rep)
    for (int k = 0; k < 4; ++k) {
      const double c0 = processCpuSeconds();
      const auto t0 = std::chrono::steady_clock::now();
      if (k == 0) scene.save(opt.checkpoint);
      if (k == 1) scene.load(opt.checkpoint);
      if (k == 2) memory = scene.saveToMemory();
      if (k == 3) scene.loadFromMemory(memory);
      wall[k].push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      cpu[k].push_back(processCpuSeconds() - c0);
      bytes = memory.size();
    }
  std::printf("checkpoint of %zu particles (MLS-MPM, after %d frames): %zu bytes (%.1f per particle)\n",
              scene.particleCount(), opt.frames, bytes, (double)bytes / (double)scene.particleCount());
  std::printf("| call | wall ms (median of %d) | CPU ms |\n|---|---:|---:|\n", opt.repeats);
  for (int k = 0; k < 4; ++k) std::printf("| %s | %.1f | %.1f |\n", names[k], 1e3 * median(wall[k]), 1e3 * median(cpu[k]));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  CLI::App app{"Throughput of the CPU backend on the CRESSim scene (BENCH_SCENES.md section 1), every solver"};
  app.add_option("--solvers", opt.solvers, "solvers: mls, standard, pb<iterations> (e.g. pb10)")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--sizes", opt.sizes, "box half-sizes [m]; 0.5,1,1.5,2.5,5 give 1k..1M particles")
      ->delimiter(',')
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--threads", opt.threads, "CPU thread counts to run each size with")
      ->delimiter(',')
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  addBackendOption(app, opt.backend);
  app.add_option("--frames", opt.frames, "timed frames per run")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--frames-large", opt.framesLarge,
                 "timed frames per run above " + std::to_string(kLargeRunParticles) + " particles")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--repeats", opt.repeats, "runs per row; the row reports the median")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--max-other-load", opt.maxOtherLoad,
                 "redo a run if other processes used more CPU than this during it [cores]")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--retries", opt.retries,
                 "redos of a run on a busy machine; the last try is kept whatever the load")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--retry-wait", opt.retryWait, "pause before a redo [s]")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--out", opt.out, "path stem of the results; writes <out>.md and <out>.csv")
      ->capture_default_str();
  app.add_option("--variants", opt.variants,
                 "scene variants: plain, far-shapes, big-domain, neo-hookean, slicer, slicer-tough, many-shapes,"
                 " many-shapes-400, thread (pay-for-use pairs)")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--bandwidth-mib", opt.bandwidthMiB,
                 "MiB per array of the memory bandwidth measurement at the start; 0 skips it")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_flag("--bandwidth-only", opt.bandwidthOnly,
               "measure the memory bandwidth for each --threads count, print CSV, and stop");
  app.add_option("--trajectory", opt.trajectory,
                 "physics check: MLS-MPM at the first --sizes and --threads for --frames frames;"
                 " the box's centre of mass per frame to this CSV file, no timing");
  app.add_option("--checkpoint", opt.checkpoint,
                 "time Scene::save / load (to this file) and their in-memory forms for MLS-MPM at the first"
                 " --sizes and --threads after --frames frames, --repeats times; no throughput run");
  CLI11_PARSE(app, argc, argv);
  // a GPU run's results go to the GPU's folder
  if (app.count("--out") == 0 && opt.backend == mpm::Backend::Cuda)
    opt.out = mpm::bench::resultsStem("throughput_cuda", true);
  try {
    for (const std::string& name : opt.solvers) SolverCase::parse(name);
    for (const std::string& name : opt.variants) SceneVariant::parse(name);
  } catch (const mpm::InvalidArgument& e) {
    std::fprintf(stderr, "bench_throughput: %s\n", e.what());
    return 2;
  }

  if (!opt.trajectory.empty()) return writeTrajectory(opt);
  if (!opt.checkpoint.empty()) return timeCheckpoint(opt);
  if (opt.bandwidthOnly) {
    if (opt.bandwidthMiB <= 0) opt.bandwidthMiB = 256;
    std::printf("threads,triad_gb_per_s,update_gb_per_s,array_mib\n");
    for (const Bandwidth& b : measureBandwidths(opt))
      std::printf("%d,%.3f,%.3f,%zu\n", b.threads, b.triadGBs, b.updateGBs, b.arrayBytes >> 20);
    return 0;
  }

  RunInfo info = RunInfo::now(argc, argv);
  const std::vector<Bandwidth> bandwidth = measureBandwidths(opt);
  for (const Bandwidth& b : bandwidth)
    std::fprintf(stderr, "memory bandwidth, %d thread(s): triad %.2f GB/s, in-place update %.2f GB/s\n",
                 b.threads, b.triadGBs, b.updateGBs);

  std::vector<Row> rows;
  try {
    for (const float half : opt.sizes) {
      const size_t particles = particlesAt(half);
      const int frames = particles > kLargeRunParticles ? opt.framesLarge : opt.frames;
      const size_t first = rows.size();
      for (const std::string& name : opt.solvers)
      for (const std::string& variant : opt.variants)
      for (const int threads : opt.threads) {
        Row r;
        r.solver = SolverCase::parse(name);
        r.variant = SceneVariant::parse(variant);
        r.halfSize = half;
        r.particles = particles;
        r.threads = threads;
        r.backend = opt.backend;
        r.frames = frames;
        rows.push_back(r);
      }
      char label[96];
      std::snprintf(label, sizeof label, "half-size %g (%zu particles)", half, particles);
      mpm::io::ProgressBar progress(
          label, (long long)opt.repeats * (long long)(rows.size() - first) * (kWarmupFrames + frames));
      long long framesDone = 0;
      // solvers and thread counts interleaved per repeat, so a change in load hits them alike
      for (int rep = 0; rep < opt.repeats; ++rep)
        for (size_t i = first; i < rows.size(); ++i) runOnce(rows[i], opt, progress, framesDone);
      progress.finish();
      for (size_t i = first; i < rows.size(); ++i) summarise(rows[i]);
      fillSpeedups(rows);
      for (size_t i = first; i < rows.size(); ++i)
        std::fprintf(stderr, "  %s, %s, %zu particles, %d thread(s): %.2f ms/frame, %.2f M/s\n",
                     rows[i].solver.label().c_str(), rows[i].variant.name.c_str(), rows[i].particles, rows[i].threads, rows[i].msPerFrame,
                     rows[i].mps);
      writeResults(info, opt, rows, bandwidth);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_throughput: %s\n", e.what());
    // keep the sizes that finished
    std::vector<Row> done;
    for (const Row& r : rows)
      if (r.summarised) done.push_back(r);
    try {
      writeResults(info, opt, done, bandwidth);
    } catch (const std::exception&) {
    }
    return 1;
  }

  info.complete = true;
  writeResults(info, opt, rows, bandwidth);
  std::printf("%s", markdownTable(rows, opt).c_str());
  std::fprintf(stderr, "wrote %s.md and %s.csv\n", opt.out.c_str(), opt.out.c_str());
  return 0;
}
