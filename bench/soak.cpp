// Soak: random valid scenes with random tool motions, for a given wall time. Each scene runs
// in a forked child under an alarm, so a crash or a hang is counted instead of ending the
// run. After every advance that returned, the child reads each object's F, positions and
// velocities back: a broken tissue there (det F <= 0, outside [--det-min, --det-max], or
// anything non-finite) is a silent collapse. Thrown mpm errors are allowed outcomes,
// counted by kind. Exit code 1 if any crash, hang, collapse, non-mpm exception or checkpoint
// round trip that changed the state happened.
//
//   bench_soak --minutes 30 --threads 2 --seed 7 --out soak.md
//   bench_soak --scene 0x1f2e3d4c5b6a7980 --threads 2    one scene again, as printed
//   bench_soak --scene 0x1f2e3d4c5b6a7980 --in-process   the same without the fork (debugger)
//
// A scene depends only on its seed and --threads (cpuThreads is drawn from 1..threads) and
// --budget, so the printed seed reruns it alone.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cerrno>
#include <cinttypes>
#include <csignal>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "mpm/error.h"
#include "mpm/scene.h"
#include "soak_scenes.h"

namespace {

using namespace mpm;
using namespace mpm::soak;

/// What the child reports through the pipe (plain bytes).
enum class Outcome : int { Clean, Diverged, InvalidArgument, Checkpoint, OtherError, ForeignException, Collapse, RoundTrip, Crash, Hang, Count };
const char* const kOutcomeNames[] = {"clean", "SimulationDiverged", "InvalidArgument", "CheckpointError",
                                     "other mpm::Error", "non-mpm exception", "silent collapse",
                                     "checkpoint round trip changed the state", "crash", "hang"};
bool isFailure(Outcome o) { return o >= Outcome::ForeignException; }

struct Report {
  Outcome outcome = Outcome::Clean;
  int advances = 0;        ///< that returned
  long long substeps = 0;
  int halvings = 0;
  double simTime = 0;
  long long particles = 0;
  bool budgetSpent = false;  ///< stopped early: the plan would cost more than --budget
  bool final = false;        ///< false: progress after an advance (what a crash or hang keeps)
  char where[32] = "setup";
  char message[400] = "";
};

void setText(char* dst, size_t size, const std::string& text) {
  std::snprintf(dst, size, "%s", text.c_str());
}

/// Positions, velocities and F of every object: the collapse check's input, and a round
/// trip's before and after.
struct Snapshot {
  std::vector<std::vector<Vec3f>> x, v;
  std::vector<std::vector<Mat3f>> F;
};
Snapshot snapshot(const Scene& scene, const std::vector<ParticleObjectId>& ids) {
  Snapshot s;
  s.x.resize(ids.size()), s.v.resize(ids.size()), s.F.resize(ids.size());
  for (size_t i = 0; i < ids.size(); ++i) {
    scene.readPositions(ids[i], s.x[i]);
    scene.readVelocities(ids[i], s.v[i]);
    scene.readDeformationGradients(ids[i], s.F[i]);
  }
  return s;
}
bool sameBits(const Snapshot& a, const Snapshot& b) {
  auto same = [](const auto& p, const auto& q) {
    if (p.size() != q.size()) return false;
    for (size_t i = 0; i < p.size(); ++i)
      if (p[i].size() != q[i].size() || std::memcmp(p[i].data(), q[i].data(), p[i].size() * sizeof(p[i][0])) != 0) return false;
    return true;
  };
  return same(a.x, b.x) && same(a.v, b.v) && same(a.F, b.F);
}

/// The first broken particle, or "" when the tissue is whole.
std::string brokenParticle(const Snapshot& s, const Options& opt) {
  auto finite = [](Vec3f a) { return isFinite(a.x) && isFinite(a.y) && isFinite(a.z); };
  std::ostringstream o;
  for (size_t i = 0; i < s.F.size(); ++i)
    for (size_t p = 0; p < s.F[i].size(); ++p) {
      const Mat3f& F = s.F[i][p];
      bool ok = finite(F.column(0)) && finite(F.column(1)) && finite(F.column(2));
      const float J = determinant(F);
      if (!ok || !(J > opt.detMin && J < opt.detMax)) {
        const Vec3f x = s.x[i][p], v = s.v[i][p];
        o << "object " << i << " particle " << p << ": det F = " << J << (ok ? "" : " (F not finite)") << " at ("
          << x.x << ", " << x.y << ", " << x.z << ") m, velocity (" << v.x << ", " << v.y << ", " << v.z << ") m/s";
        return o.str();
      }
      if (!finite(s.x[i][p]) || !finite(s.v[i][p])) {
        o << "object " << i << " particle " << p << ": position or velocity not finite";
        return o.str();
      }
    }
  return "";
}

void printAdvance(size_t i, float dt, const StepReport& step, const Snapshot& s, const AdvancePlan& a) {
  float lo = INFINITY, hi = -INFINITY, fastest = 0;
  for (size_t k = 0; k < s.F.size(); ++k)
    for (size_t p = 0; p < s.F[k].size(); ++p) {
      lo = std::min(lo, determinant(s.F[k][p])), hi = std::max(hi, determinant(s.F[k][p]));
      fastest = std::max(fastest, norm(s.v[k][p]));
    }
  std::printf("         advance %zu%s: dt %.5f s, %d substeps of %.2e s, %d halvings, det F in [%g, %g], fastest %.3g m/s%s\n", i,
              a.async ? " (advance+fetch)" : "", dt, step.substeps, step.substepDt, step.halvings, lo, hi, fastest,
              a.roundTrip ? (a.freshScene ? ", round trip (fresh scene)" : ", round trip") : "");
  std::fflush(stdout);
}

/// Builds and runs one scene; every outcome but a crash or a hang comes back here.
Report runScene(const SceneSpec& spec, const Options& opt, const std::function<void(const Report&)>& progress) {
  Report rep;
  Rng motion(spec.seed ^ 0x9e3779b97f4a7c15ULL);
  try {
    Scene scene(spec.settings);
    std::vector<ParticleObjectId> objects;
    for (const ParticleObjectDesc& d : spec.objects) objects.push_back(scene.addParticleObject(d));
    std::vector<ShapeId> tools;
    for (const ShapeDesc& t : spec.tools) tools.push_back(scene.addShape(t));
    if (spec.floor) {
      ShapeDesc f;
      Geometry g;
      g.type = GeometryType::Plane;
      f.parts.push_back(g);
      f.pose.position = {0.f, spec.floorY, 0.f};
      f.contact.friction = 0.3f;
      scene.addShape(f);
    }
    std::vector<SlicerId> slicers;
    for (const QuadSlicerDesc& b : spec.slicers) slicers.push_back(scene.addSlicer(b));
    std::vector<CurveId> needles;
    for (const ArcDesc& n : spec.needles) needles.push_back(scene.addCurve(n));
    rep.particles = (long long)scene.particleCount();
    double spent = 0;

    for (size_t i = 0; i < spec.plan.size(); ++i) {
      const AdvancePlan& a = spec.plan[i];
      setText(rep.where, sizeof rep.where, "advance " + std::to_string(i));
      // tools: now and then aimed again at an object (always once they are far off)
      for (size_t k = 0; k < tools.size(); ++k) {
        ShapeState st = scene.shapeState(tools[k]);
        const bool far = norm(st.pose.position - Vec3f{0.f, 0.1f, 0.f}) > 0.25f;
        if (!far && !motion.chance(0.3)) continue;
        const ObjectSummary o = scene.summary(objects[(size_t)motion.integer(0, (int)objects.size() - 1)]);
        const Vec3f target = Vec3f{(float)o.centerOfMass[0], (float)o.centerOfMass[1], (float)o.centerOfMass[2]} + 0.02f * motion.direction();
        const float speed = motion.chance(0.5) ? spec.toolSpeeds[k] : toolSpeed(motion);
        st.linearVelocity = speed * unit(target - st.pose.position);
        st.angularVelocity = motion.chance(0.2) ? motion.uni(0, 10) * motion.direction() : Vec3f{0.f, 0.f, 0.f};
        scene.setShapeState(tools[k], st);
      }
      for (SlicerId b : slicers) {
        ShapeState st = scene.slicerState(b);
        if (motion.chance(0.2)) {
          st.linearVelocity = -1.f * st.linearVelocity;  // back out, or in again
          scene.setSlicerState(b, st);
        }
      }
      for (size_t k = 0; k < needles.size(); ++k) {
        ShapeState st = scene.curveState(needles[k]);
        if (motion.chance(0.2)) {
          st.angularVelocity = (motion.logUni(0.01, 1) / spec.needles[k].radius) * rotate(st.pose.rotation, {0.f, 0.f, 1.f});
          scene.setCurveState(needles[k], st);
        }
      }

      // the cost this advance will take; stop (or shorten it) once the budget is spent
      float dt = a.dt;
      const float sub = scene.maxSubstep();
      const double perSubstep = (double)scene.particleCount() * spec.costFactor;
      if (std::isfinite(sub) && sub > 0) {
        const double allowed = std::floor((opt.budget - spent) / std::max(1.0, perSubstep));
        if (std::ceil(dt / sub) > allowed) {
          rep.budgetSpent = true;
          if (allowed < 1) break;
          dt = (float)(allowed * sub * 0.999);
        }
      }
      StepReport step;
      if (a.async) {
        scene.advance(dt);
        step = scene.fetchResults();
      } else {
        step = scene.step(dt);
      }
      spent += perSubstep * step.substeps;
      rep.substeps += step.substeps;
      rep.halvings += step.halvings;
      rep.simTime = scene.time();
      ++rep.advances;

      const Snapshot now = snapshot(scene, objects);
      if (opt.verbose) printAdvance(i, dt, step, now, a);
      const std::string broken = brokenParticle(now, opt);
      if (!broken.empty()) {
        rep.outcome = Outcome::Collapse;
        setText(rep.message, sizeof rep.message, broken);
        rep.final = true;
        return rep;
      }
      if (a.roundTrip) {
        setText(rep.where, sizeof rep.where, "round trip " + std::to_string(i));
        const std::vector<uint8_t> bytes = scene.saveToMemory();
        if (a.freshScene) {
          Scene fresh(spec.settings);
          fresh.loadFromMemory(bytes);
          scene = std::move(fresh);
        } else {
          scene.loadFromMemory(bytes);
        }
        bool handles = true;
        for (ParticleObjectId id : objects) handles &= scene.isValid(id);
        for (ShapeId id : tools) handles &= scene.isValid(id);
        for (SlicerId id : slicers) handles &= scene.isValid(id);
        for (CurveId id : needles) handles &= scene.isValid(id);
        if (!handles || !sameBits(now, snapshot(scene, objects))) {
          rep.outcome = Outcome::RoundTrip;
          setText(rep.message, sizeof rep.message,
                  handles ? "the particles differ after loading" : "a handle is stale after loading");
          rep.final = true;
          return rep;
        }
      }
      progress(rep);
      if (rep.budgetSpent) break;
    }
    setText(rep.where, sizeof rep.where, "end");
  } catch (const SimulationDiverged& e) {
    rep.outcome = Outcome::Diverged, setText(rep.message, sizeof rep.message, e.what());
  } catch (const InvalidArgument& e) {
    rep.outcome = Outcome::InvalidArgument, setText(rep.message, sizeof rep.message, e.what());
  } catch (const CheckpointError& e) {
    rep.outcome = Outcome::Checkpoint, setText(rep.message, sizeof rep.message, e.what());
  } catch (const Error& e) {
    rep.outcome = Outcome::OtherError, setText(rep.message, sizeof rep.message, e.what());
  } catch (const std::exception& e) {
    rep.outcome = Outcome::ForeignException, setText(rep.message, sizeof rep.message, e.what());
  }
  rep.final = true;
  return rep;
}

/// Runs the scene in a forked child under the alarm; crashes and hangs become outcomes,
/// placed by the child's last progress record.
Report runForked(const SceneSpec& spec, const Options& opt) {
  int fds[2];
  if (pipe(fds) != 0) throw std::runtime_error("pipe failed");
  std::fflush(stdout), std::fflush(stderr);  // else the child's exit could print them again
  const pid_t child = fork();
  if (child < 0) throw std::runtime_error("fork failed");
  if (child == 0) {
    close(fds[0]);
    std::signal(SIGINT, SIG_DFL);
    alarm((unsigned)opt.alarmSeconds);
    bool sent = true;
    // each record is under PIPE_BUF: written whole or not at all
    auto send = [&](const Report& r) { sent &= write(fds[1], &r, sizeof r) == (ssize_t)sizeof r; };
    send(runScene(spec, opt, send));
    std::fflush(stdout);
    _exit(sent ? 0 : 3);
  }
  close(fds[1]);
  Report rep, record;
  size_t got = 0;
  char* dst = reinterpret_cast<char*>(&record);
  for (ssize_t n; (n = read(fds[0], dst + got, sizeof record - got)) != 0;) {
    if (n < 0) {
      if (errno == EINTR) continue;
      break;
    }
    got += (size_t)n;
    if (got == sizeof record) rep = record, got = 0;
  }
  close(fds[0]);
  int status = 0;
  while (waitpid(child, &status, 0) < 0 && errno == EINTR) {}
  if (rep.final && WIFEXITED(status) && WEXITSTATUS(status) == 0) return rep;
  std::string why;
  if (WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    rep.outcome = sig == SIGALRM ? Outcome::Hang : Outcome::Crash;
    why = sig == SIGALRM ? "still running after " + std::to_string(opt.alarmSeconds) + " s (alarm)"
                         : std::string("killed by signal ") + std::to_string(sig) + " (" + strsignal(sig) + ")";
  } else {
    rep.outcome = Outcome::Crash;
    why = "exited with code " + std::to_string(WEXITSTATUS(status)) + " without its report";
  }
  // the advance under way, or the checks and round trip after it
  setText(rep.where, sizeof rep.where, rep.advances ? "advance " + std::to_string(rep.advances) : "setup or advance 0");
  setText(rep.message, sizeof rep.message, why);
  return rep;
}

volatile std::sig_atomic_t gStop = 0;
void onInterrupt(int) { gStop = 1; }

std::string hex(uint64_t v) {
  char b[24];
  std::snprintf(b, sizeof b, "0x%016" PRIx64, v);
  return b;
}

struct Tally {
  int count[(int)Outcome::Count][4] = {};  ///< outcome x solver
  int scenes[4] = {};
  long long particleSubsteps = 0;
  int budgetSpent = 0, halvings = 0;
  std::vector<std::string> failures, errors;  ///< one markdown line per scene that did not run clean
};

std::string summary(const Tally& t, const Options& opt, uint64_t seed, double wall, int scenes) {
  std::ostringstream o;
  o << "# Soak run\n\nseed " << hex(seed) << ", threads " << opt.threads << ", backend "
    << (opt.backend == Backend::Cuda ? "cuda" : "cpu") << ", budget " << opt.budget << " particle-substeps per scene, alarm "
    << opt.alarmSeconds << " s, det F bounds (" << opt.detMin << ", " << opt.detMax << ")\n\n";
  o << "| outcome | all | MlsMpm | StandardMpm | PbMpm | Mtled |\n|---|---:|---:|---:|---:|---:|\n";
  auto row = [&](const char* name, const int* v) {
    o << "| " << name << " | " << v[0] + v[1] + v[2] + v[3];
    for (int s = 0; s < 4; ++s) o << " | " << v[s];
    o << " |\n";
  };
  row("scenes run", t.scenes);
  for (int k = 0; k < (int)Outcome::Count; ++k) row(kOutcomeNames[k], t.count[k]);
  o << "\nwall time " << wall << " s for " << scenes << " scenes; " << t.particleSubsteps << " particle-substeps; "
    << t.halvings << " recovery halvings; " << t.budgetSpent << " scenes stopped by the budget\n";
  o << "\nRerun a scene alone: `bench_soak --scene SEED --threads " << opt.threads << " --verbose`\n";
  if (!t.failures.empty()) {
    o << "\n## Crashes, hangs, collapses\n\n";
    for (const std::string& line : t.failures) o << line << "\n";
  }
  if (!t.errors.empty()) {
    o << "\n## Errors thrown (allowed)\n\n";
    const size_t shown = std::min<size_t>(t.errors.size(), 30);  // the table counts them all
    for (size_t i = 0; i < shown; ++i) o << t.errors[i] << "\n";
    if (shown < t.errors.size()) o << "- and " << t.errors.size() - shown << " more\n";
  }
  return o.str();
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  CLI::App app{"Soak: random valid MPM scenes in forked children; counts crashes, hangs, silent collapses and errors"};
  app.add_option("--minutes", opt.minutes, "wall time to run for")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--threads", opt.threads, "a scene's cpuThreads is drawn from 1..threads")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--seed", opt.seed, "seed of the run (0: from the clock)");
  app.add_option("--scene", opt.scene, "run only the scene of this seed (as printed)");
  app.add_flag("--in-process", opt.inProcess, "with --scene: run it in this process, without fork or alarm");
  app.add_flag("--verbose", opt.verbose, "print a line per advance: dt, substeps, det F range, fastest particle");
  app.add_option("--scenes", opt.maxScenes, "stop after this many scenes (0: when the time is up)")->capture_default_str();
  app.add_option("--alarm", opt.alarmSeconds, "seconds after which a scene counts as hung")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--budget", opt.budget, "particle-substeps per scene (PB-MPM: times its iterations)")->capture_default_str();
  app.add_option("--max-particles", opt.maxParticles, "particles per scene, about")->capture_default_str();
  app.add_option("--det-min", opt.detMin, "det F at or below this is a collapse")->capture_default_str();
  app.add_option("--det-max", opt.detMax, "det F at or above this is a collapse")->capture_default_str();
  mpm::bench::addBackendOption(app, opt.backend);
  app.add_option("--out", opt.out, "also write the summary as markdown here");
  CLI11_PARSE(app, argc, argv);

  uint64_t seed = opt.seed ? opt.seed : (uint64_t)std::chrono::system_clock::now().time_since_epoch().count();
  Rng seeds(seed);
  std::signal(SIGINT, onInterrupt);
  Tally tally;
  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  const bool single = !opt.scene.empty();
  std::printf("soak: seed %s, %g min, threads 1..%d\n", hex(seed).c_str(), opt.minutes, opt.threads);
  int n = 0;
  for (; !gStop; ++n) {
    if (single ? n == 1 : (elapsed() >= opt.minutes * 60 || (opt.maxScenes > 0 && n >= opt.maxScenes))) break;
    const uint64_t sceneSeed = single ? std::stoull(opt.scene, nullptr, 0) : seeds.bits();
    const SceneSpec spec = drawScene(sceneSeed, opt);
    std::printf("[%4d] %s %s\n", n, hex(sceneSeed).c_str(), describe(spec).c_str());
    const auto t0 = std::chrono::steady_clock::now();
    const Report rep = single && opt.inProcess ? runScene(spec, opt, [](const Report&) {}) : runForked(spec, opt);
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (gStop && rep.outcome == Outcome::Crash) break;  // the child took the Ctrl-C
    const int solver = (int)spec.settings.solver;
    ++tally.scenes[solver];
    ++tally.count[(int)rep.outcome][solver];
    tally.particleSubsteps += rep.particles * rep.substeps;
    tally.budgetSpent += rep.budgetSpent;
    tally.halvings += rep.halvings;
    std::printf("       %s: %d of %zu advances%s, %lld particles, %lld substeps, %.3f s simulated, %.2f s wall%s%s%s\n",
                kOutcomeNames[(int)rep.outcome], rep.advances, spec.plan.size(), rep.budgetSpent ? " (budget)" : "",
                rep.particles, rep.substeps, rep.simTime, secs, rep.message[0] ? " at " : "",
                rep.message[0] ? rep.where : "", rep.message[0] ? ":" : "");
    if (rep.message[0]) std::printf("         %s\n", rep.message);
    if (rep.outcome != Outcome::Clean) {
      std::ostringstream line;
      line << "- `" << hex(sceneSeed) << "` " << solverName(spec.settings.solver) << ": **" << kOutcomeNames[(int)rep.outcome]
           << "** at " << rep.where << ": " << rep.message;
      (isFailure(rep.outcome) ? tally.failures : tally.errors).push_back(line.str());
    }
    if (isFailure(rep.outcome))
      std::printf("         rerun: bench_soak --scene %s --threads %d\n", hex(sceneSeed).c_str(), opt.threads);
    std::fflush(stdout);
  }
  const std::string table = summary(tally, opt, seed, elapsed(), n);
  std::printf("\n%s", table.c_str());
  if (!opt.out.empty()) {
    std::ofstream f(opt.out);
    f << table;
    if (!f) std::fprintf(stderr, "soak: could not write %s\n", opt.out.c_str());
  }
  int failures = 0;
  for (int k = (int)Outcome::ForeignException; k < (int)Outcome::Count; ++k)
    for (int s = 0; s < 4; ++s) failures += tally.count[k][s];
  return failures ? 1 : 0;
}
