// Stability stress tests for every solver. Each run has
// SceneSettings::energyCheck on, so a failure is a SimulationDiverged (energy growth,
// non-finite state or particles leaving the grid) naming the object and the particle.
//
//   (a) the time step swept as a multiple k of the solver's stability estimate until the
//       run fails: the cylinder of Horton et al. 2010 compressed 20 % in 0.3 s (ten times faster than
//       section 4, as the paper's own step study) and held 0.1 s;
//   (b) near-incompressible material, nu = 0.49 and 0.499, on the same compression;
//   (c) 80 % compression and back;
//   (d) a rigid sphere hitting a tissue slab at 5 and 10 m/s;
//   (e) two bodies of stiffness ratio 1000 in contact, pressed by a plate.
//
//   bench_stability --out bench/results/<machine>/stability
//
// Writes <out>.md (header naming machine and command, the tables) and <out>.csv.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
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

// the MTLED paper's cylinder (scenes::CylinderBetweenPlates, tests/reference/README.md)
constexpr double kHeight = CylinderBetweenPlates::kHeight;
/// Bonded 20 % compression, CalculiX extrapolated to zero mesh size, at the end of the 3 s
/// ramp (tests/reference/cylinder_compression_extrapolated.csv) [N].
constexpr double kReferenceForce = CylinderBetweenPlates::kBondedFinalForce;
constexpr float kDx = 0.01f;  // grid cell (MPM) and node spacing (MTLED) [m]
constexpr float kPlate = CylinderBetweenPlates::kPlateHalfThickness;  // plate half-thickness [m]

struct Options {
  std::vector<std::string> solvers{"MlsMpm", "StandardMpm", "PbMpm", "Mtled"};
  int threads = 0;
  std::string out = mpm::bench::resultsStem("stability");
};

/// Outcome of one run.
struct Row {
  Row(SolverType s, std::string t, std::string v) : solver(s), test(std::move(t)), variant(std::move(v)) {}
  SolverType solver;
  std::string test, variant;  ///< e.g. "sweep", "k = 1.25"
  bool stable = true;
  bool ran = true;          ///< false: the case does not apply to the solver (`message` says why)
  std::string message;      ///< the SimulationDiverged text when it failed
  double seconds = 0;       ///< simulated time reached [s]
  long long substeps = 0;
  size_t particles = 0;
  float substepDt = 0;      ///< [s]
  double wall = 0;          ///< [s]
  double worstExcess = 0;   ///< largest EnergyBalance::excess() / supplied over the frames
  std::string measure;      ///< what `value` is
  double value = std::nan("");
};

SceneSettings baseSettings(SolverType solver, int threads, float halfWidth, float low, float high) {
  SceneSettings s;
  s.domain = {{-halfWidth, low, -halfWidth}, {halfWidth, high, halfWidth}};
  s.domain.walls = false;
  s.dx = kDx;
  s.gravity = {0.f, 0.f, 0.f};
  s.solver = solver;
  s.backend = Backend::Cpu;
  s.cpuThreads = threads;
  s.energyCheck.enabled = true;
  return s;
}

/// A kinematic plate (box) whose top or bottom face is at height y.
ShapeDesc plate(float halfWidth, float faceY, bool below, ContactMode mode, float band) {
  ContactParams contact;
  contact.mode = mode;
  contact.band = band;
  return scenes::plate(halfWidth, kPlate, faceY, below, contact);
}

Material cylinderMaterial(double nu) { return CylinderBetweenPlates::material(nu); }
const double kSeedNu = CylinderBetweenPlates::seedPoissonRatio();
double waveSpeed(const Material& m) { return CylinderBetweenPlates::waveSpeed(m); }
double smoothRamp(double s) { return CylinderBetweenPlates::smoothRamp(s); }

/// Runs `frames` of length `frame`, calling `drive(t, frame)` before and `sample(t)` after
/// each; fills the row's outcome, energy excess and counts.
void runFrames(Scene& scene, Row& row, double frame, double duration,
               const std::function<void(double, double)>& drive, const std::function<void(double)>& sample) {
  const auto t0 = std::chrono::steady_clock::now();
  row.particles = scene.particleCount();
  row.worstExcess = -1e30;
  double t = 0;
  try {
    for (int f = 0; t < duration - 1e-9; ++f) {
      drive(t, frame);
      const StepReport r = scene.step((float)frame);
      row.substeps += r.substeps;
      row.substepDt = r.substepDt;
      row.worstExcess = std::max(row.worstExcess, r.energy.excess() / r.energy.supplied);
      t = (f + 1) * frame;
      row.seconds = t;
      sample(t);
    }
  } catch (const SimulationDiverged& e) {
    row.stable = false;
    row.message = e.what();
  }
  row.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// Forces on the material from a pressing plate [N] (negative: compression).
struct Forces {
  double last = std::nan("");  ///< mean over the run's last `average` seconds
  double peak = 0;             ///< largest magnitude of a frame's mean
};

/// Moves the kinematic plate `top`, whose lower face starts at height `face0`, down by
/// `travel(t)` [m] in frames of `frame` seconds, and measures its force.
Forces pressWithPlate(Scene& scene, ShapeId top, float face0, Row& row, double frame, double duration,
                      double average, const std::function<double(double)>& travel) {
  Forces forces;
  double forceSum = 0, forceTime = 0;
  runFrames(
      scene, row, frame, duration,
      [&](double t, double dt) {
        ShapeState st;
        st.pose.position = {0.f, (float)(face0 + kPlate - travel(t)), 0.f};
        st.linearVelocity = {0.f, (float)(-(travel(t + dt) - travel(t)) / dt), 0.f};
        scene.setShapeState(top, st);
      },
      [&](double t) {
        const double impulse = -scene.shapeImpulse(top).linear.y;
        forces.peak = std::max(forces.peak, std::abs(impulse / frame));
        if (t <= duration - average + 1e-9) return;
        forceSum += impulse;
        forceTime += frame;
      });
  if (forceTime > 0) forces.last = forceSum / forceTime;
  return forces;
}

/// The MTLED paper's cylinder between two bonded plates (scenes::CylinderBetweenPlates at dx and node
/// spacing 1 cm, with the energy check), the top plate following `travel(t)` downward [m].
struct Cylinder : CylinderBetweenPlates::Setup {
  Cylinder(SolverType s, int t) {
    solver = s;
    threads = t;
    resolution = 0.01;  // kDx
    energyCheck = true;
  }
  SceneSettings settings() const { return CylinderBetweenPlates::settings(*this); }
  CylinderBetweenPlates::Parts build(Scene& scene) const { return CylinderBetweenPlates::build(scene, *this); }

  /// Runs the plate motion in frames of `frame` seconds.
  Forces run(Row& row, double frame, double duration, double average,
             const std::function<double(double)>& travel) const {
    Scene scene(settings());
    return pressWithPlate(scene, build(scene).top, (float)kHeight, row, frame, duration, average, travel);
  }
};

// ---- (a) the step sweep ----------------------------------------------------------------

constexpr double kSweepRamp = 0.3, kSweepHold = 0.1, kSweepCompression = 0.2;

double sweepTravel(double t) { return kSweepCompression * kHeight * smoothRamp(t / kSweepRamp); }

/// The solver's stability estimate [s]: dx / c_p (the CFL step at cflNumber 1, at rest)
/// for the grid solvers (PB-MPM included, though its step is not bound by it), MTLED's
/// critical step of eq. 37.
double referenceStep(SolverType solver, int threads) {
  if (solver != SolverType::Mtled) return kDx / waveSpeed(cylinderMaterial(kSeedNu));
  Cylinder c(solver, threads);
  c.mtledSafety = 1.f;
  Scene scene(c.settings());
  c.build(scene);
  return scene.maxSubstep();
}

Row sweepRun(SolverType solver, int threads, double k, double dtRef) {
  Row row(solver, "sweep", "k = " + num(k, 3) + " (dt = " + num(1e3 * k * dtRef, 4) + " ms)");
  Cylinder c(solver, threads);
  c.fixedSubsteps = 4;  // substeps of exactly k times the estimate; the energy checked every 4
  row.measure = "force after hold / reference";
  row.value = c.run(row, c.fixedSubsteps * k * dtRef, kSweepRamp + kSweepHold, 0.05, sweepTravel).last /
              kReferenceForce;
  return row;
}

/// Starts at k = 1; doubles while stable (halves while failing) to bracket the limit,
/// then bisects four times between the largest stable and the smallest failed multiple.
/// Capped where a run would have fewer than 20 substeps.
std::vector<Row> sweep(SolverType solver, int threads, double& largestStable, double& cap) {
  const double dtRef = referenceStep(solver, threads);
  std::fprintf(stderr, "%s: reference step %.4g s\n", solverName(solver).c_str(), dtRef);
  cap = (kSweepRamp + kSweepHold) / (20 * dtRef);
  std::vector<Row> rows;
  double stable = 0, failed = 0;
  const auto tryMultiple = [&](double k) {
    rows.push_back(sweepRun(solver, threads, k, dtRef));
    std::fprintf(stderr, "  k = %.4g: %s (%.1f s)\n", k, rows.back().stable ? "stable" : "failed", rows.back().wall);
    (rows.back().stable ? stable : failed) = k;
  };
  for (double k = 1; k <= cap && failed == 0; k *= 2) tryMultiple(k);
  for (double k = 0.5; stable == 0 && k > 0.05; k /= 2) tryMultiple(k);
  for (int i = 0; i < 4 && failed > 0 && stable > 0; ++i) tryMultiple(0.5 * (stable + failed));
  largestStable = failed == 0 ? -stable : stable;  // negative: never failed, at least |value|
  return rows;
}

// ---- (b) near-incompressible, (c) 80 % and back --------------------------------------

Row incompressible(SolverType solver, int threads, double nu) {
  Row row(solver, "near-incompressible", "nu = " + num(nu, 3));
  Cylinder c(solver, threads);
  c.nu = nu;
  row.measure = "force after 0.1 s hold / reference (nu 0.49)";
  row.value = c.run(row, 0.005, kSweepRamp + kSweepHold, 0.05, sweepTravel).last / kReferenceForce;
  return row;
}

Row compressAndBack(SolverType solver, int threads) {
  constexpr double kRamp = 0.5, kDepth = 0.8 * kHeight;
  Row row(solver, "80 % compression and back", "bonded, 0.5 s each way");
  Cylinder c(solver, threads);
  c.halfWidth = 0.2f;  // the cylinder bulges to more than twice its radius
  const auto travel = [&](double t) {
    return kDepth * (t < kRamp ? smoothRamp(t / kRamp) : smoothRamp((2 * kRamp - t) / kRamp));
  };
  Scene scene(c.settings());
  const CylinderBetweenPlates::Parts parts = c.build(scene);
  const Forces f = pressWithPlate(scene, parts.top, (float)kHeight, row, 0.005, 2 * kRamp + 0.05, 0.05, travel);
  // back at the start, a body still held by both plates spans H again and pushes back little
  std::vector<Vec3f> x;
  scene.readPositions(parts.body, x);
  double low = 1e9, high = -1e9;
  for (const Vec3f& p : x) low = std::min(low, (double)p.y), high = std::max(high, (double)p.y);
  row.measure = "particle span in y after return / H; force then / peak force " + num(f.peak, 1) + " N = " +
                num(f.last / f.peak, 4);
  row.value = (high - low) / kHeight;
  return row;
}

// ---- (d) a sphere hitting a slab -------------------------------------------------------

Row impact(SolverType solver, int threads, float speed) {
  constexpr float kSlabHalf = 0.06f, kSlabHalfHeight = 0.02f, kSphereRadius = 0.015f, kSphereDensity = 1000.f;
  Row row(solver, "sphere impact", num(speed, 0) + " m/s");
  Scene scene(baseSettings(solver, threads, 0.1f, -0.05f, 0.15f));
  const bool meshless = solver == SolverType::Mtled;
  ParticleObjectDesc slab;
  slab.center = {0.f, kSlabHalfHeight, 0.f};
  slab.halfExtents = {kSlabHalf, kSlabHalfHeight, kSlabHalf};
  slab.particleSpacing = meshless ? kDx : 0.f;
  slab.material = {MaterialModel::NeoHookeanDecoupled, 2e5f, 0.3f, 1000.f};
  scene.addParticleObject(slab);
  scene.addShape(plate(0.08f, 0.f, true, ContactMode::Bonded, meshless ? 0.1f * kDx : 0.f));
  ShapeDesc ball;
  Geometry sphere;
  sphere.type = GeometryType::Sphere;
  sphere.radius = kSphereRadius;
  ball.parts = {sphere};
  const float mass = kSphereDensity * 4.f / 3.f * 3.14159265f * kSphereRadius * kSphereRadius * kSphereRadius;
  ball.mass = mass;
  const float I = 0.4f * mass * kSphereRadius * kSphereRadius;
  ball.inertia = {I, I, I};
  ball.pose.position = {0.f, 2 * kSlabHalfHeight + kSphereRadius + kDx, 0.f};
  ball.linearVelocity = {0.f, -speed, 0.f};
  const ShapeId id = scene.addShape(ball);
  double lowest = 1e9, rebound = 0;
  runFrames(
      scene, row, 0.0005, 0.03, [](double, double) {},
      [&](double) {
        const ShapeState st = scene.shapeState(id);
        lowest = std::min(lowest, (double)st.pose.position.y - kSphereRadius);
        rebound = st.linearVelocity.y;
      });
  // deepest point of the sphere below the slab's top, as a share of the slab thickness
  row.measure = "rebound / impact speed; deepest indentation / thickness = " +
                num((2 * kSlabHalfHeight - lowest) / (2 * kSlabHalfHeight), 2);
  row.value = rebound / speed;
  return row;
}

// ---- (e) stiffness ratio 1000 ----------------------------------------------------------

Row stiffnessRatio(SolverType solver, int threads) {
  constexpr float kHalf = 0.03f, kSoft = 0.015f, kStiff = 0.01f, kESoft = 1e4f;
  constexpr double kRamp = 0.1, kHold = 0.05, kStrain = 0.2;
  Row row(solver, "stiffness ratio 1000", "E 10 kPa under 10 MPa, pressed 20 %");
  if (solver == SolverType::Mtled) {
    row.ran = false;
    row.message = "not run: MTLED objects do not contact each other (no particle-object contact)";
    return row;
  }
  Scene scene(baseSettings(solver, threads, 0.08f, -0.05f, 0.1f));
  ParticleObjectDesc layer;
  layer.halfExtents = {kHalf, kSoft, kHalf};
  layer.center = {0.f, kSoft, 0.f};
  layer.material = {MaterialModel::FixedCorotated, kESoft, 0.3f, 1000.f};
  scene.addParticleObject(layer);
  layer.halfExtents = {kHalf, kStiff, kHalf};
  layer.center = {0.f, 2 * kSoft + kStiff, 0.f};
  layer.material.youngsModulus = 1000 * kESoft;
  scene.addParticleObject(layer);
  const float top0 = 2 * (kSoft + kStiff);
  scene.addShape(plate(0.05f, 0.f, true, ContactMode::Frictional, 0.f));
  const ShapeId top = scene.addShape(plate(0.05f, top0, false, ContactMode::Frictional, 0.f));
  const auto travel = [&](double t) { return kStrain * 2 * kSoft * smoothRamp(t / kRamp); };
  const Forces f = pressWithPlate(scene, top, top0, row, 0.002, kRamp + kHold, 0.025, travel);
  // the stiff layer barely strains, so the soft one takes the plate's travel: uniaxial
  // stress E A strain on frictionless plates (the layers' interface is bonded, which
  // stiffens it somewhat)
  const double uniaxial = kESoft * (2 * kHalf) * (2 * kHalf) * kStrain;
  row.measure = "plate force / (E_soft A strain)";
  row.value = -f.last / uniaxial;
  return row;
}

// ---- report ----------------------------------------------------------------------------

std::string outcome(const Row& r) { return !r.ran ? "not run" : r.stable ? "stable" : "**failed**"; }

std::string shortMessage(const std::string& m) {
  return m.size() > 400 ? m.substr(0, 400) + " ..." : m;
}

struct SweepResult {
  SolverType solver;
  double largestStable, cap;
};

std::string markdownReport(const RunInfo& info, const std::vector<SweepResult>& sweeps, const std::vector<Row>& rows) {
  std::ostringstream m;
  m << info.header("Stability stress tests, every solver, CPU backend", MPM_BENCH_BUILD_TYPE);
  m << "Every run has `SceneSettings::energyCheck` on (tolerance 0.5): a run *fails* when a step throws"
       " `SimulationDiverged` (its energy exceeded its start plus the shapes' work by more than half the"
       " energy supplied, or a particle became non-finite or left the grid); the message names the"
       " object and the particle. `worst excess` is the largest (energy − start − work − gravity release)"
       " / supplied over the run's frames: ≤ 0 means the energy never rose above its start plus the work"
       " done (negative: dissipated). Energy measured: kinetic + strain W(F) for MLS-MPM and standard"
       " MPM, kinetic + the strain energy of its integration points for MTLED; kinetic only for PB-MPM (its"
       " forces do not derive from a W(F) it reports).\n\n"
       "Cylinder (a, b, c): Horton et al. 2010's, R = 5 cm, H = 10 cm, decoupled Neo-Hookean mu = 1007 Pa, K = 50001 Pa"
       " (nu = 0.49), rho = 1000 kg/m^3, no gravity, between two kinematic bonded plates; MPM: dx = 1 cm,"
       " 8 particles per cell (6.2k particles); MTLED: node spacing 1 cm (891 nodes). Compression 20 %"
       " with the smooth ramp of eq. 43 in 0.3 s (ten times faster than section 4, as the paper's own step"
       " study), then held 0.1 s. Force ratios are against the bonded quasi-static reference at 20 %"
       " (CalculiX extrapolated, −6.805 N), so dynamic and resolution effects show in them.\n\n";
  m << "## (a) Largest stable step\n\n"
       "k is the substep over the solver's stability estimate: for MLS-MPM, standard MPM and PB-MPM"
       " dx / c_p = "
    << num(1e3 * kDx / waveSpeed(cylinderMaterial(kSeedNu)), 3)
    << " ms (the CFL step at cflNumber = 1 at rest; the default policy takes defaultCflNumber of it:"
       " MLS-MPM "
    << num(defaultCflNumber(SolverType::MlsMpm), 2) << ", standard MPM " << num(defaultCflNumber(SolverType::StandardMpm), 2)
    << "; PB-MPM's step is not bound by it), for MTLED its critical step of eq. 37 (the default takes timeStepSafety = 0.5 of"
       " it). Frames of 4 k times the estimate with `fixedSubsteps = 4` (the energy checked every 4"
       " substeps); k starts at 1 and doubles while the run is stable (halves while it fails), then four"
       " bisections between the largest stable and the smallest failed k. The sweep stops at the k where"
       " the run would have fewer than 20 substeps.\n\n"
       "| solver | largest stable k | first failing k |\n|---|---:|---:|\n";
  for (const SweepResult& s : sweeps) {
    double failed = std::nan("");
    for (const Row& r : rows)
      if (r.solver == s.solver && r.test == "sweep" && !r.stable) {
        const double k = std::stod(r.variant.substr(4));
        if (std::isnan(failed) || k < failed) failed = k;
      }
    m << "| " << solverName(s.solver) << " | "
      << (s.largestStable < 0 ? ">= " + num(-s.largestStable, 3) + " (cap " + num(s.cap, 1) + ")"
                              : num(s.largestStable, 3))
      << " | " << (std::isnan(failed) ? "none up to the cap" : num(failed, 3)) << " |\n";
  }
  m << "\n## All runs\n\n| solver | test | variant | outcome | t reached [s] | substeps | substep [ms] | particles |"
       " wall [s] | worst excess | sanity number | value |\n|---|---|---|---|---:|---:|---:|---:|---:|---:|---|---:|\n";
  for (const Row& r : rows)
    m << "| " << solverName(r.solver) << " | " << r.test << " | " << r.variant << " | " << outcome(r) << " | "
      << num(r.seconds, 3) << " | " << r.substeps << " | " << num(1e3 * r.substepDt, 4) << " | " << r.particles
      << " | " << num(r.wall, 1) << " | " << (r.substeps ? num(r.worstExcess, 3) : "–") << " | " << r.measure
      << " | " << (r.stable ? num(r.value, 3) : "–") << " |\n";
  m << "\n## Failure messages\n\n";
  for (const Row& r : rows)
    if (!r.stable || !r.ran)
      m << "- " << solverName(r.solver) << ", " << r.test << ", " << r.variant << ": " << shortMessage(r.message)
        << "\n";
  return m.str();
}

std::string csvEscape(std::string s) {
  for (char& c : s)
    if (c == '"') c = '\'';
  return '"' + s + '"';
}

std::string csvTable(const std::vector<Row>& rows) {
  std::ostringstream t;
  t << "solver,test,variant,stable,t_reached_s,substeps,substep_s,particles,wall_s,worst_excess,measure,value,"
       "message\n";
  for (const Row& r : rows)
    t << solverName(r.solver) << ',' << csvEscape(r.test) << ',' << csvEscape(r.variant) << ','
      << (!r.ran ? "" : r.stable ? "1" : "0") << ',' << num(r.seconds, 4) << ',' << r.substeps << ',' << r.substepDt << ','
      << r.particles << ',' << num(r.wall, 2) << ',' << (r.substeps ? num(r.worstExcess, 4) : "") << ','
      << csvEscape(r.measure) << ',' << (r.stable ? num(r.value, 4) : "") << ',' << csvEscape(r.message) << '\n';
  return t.str();
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  CLI::App app{"Stability stress tests: step sweep, near-incompressible, 80 % compression, impact, stiffness ratio"};
  addSolversOption(app, opt.solvers);
  app.add_option("--threads", opt.threads, "CPU threads; 0 = all")->check(CLI::NonNegativeNumber)->capture_default_str();
  app.add_option("--out", opt.out, "path stem: writes <out>.md and <out>.csv")->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  RunInfo info = RunInfo::now(argc, argv);
  std::vector<Row> rows;
  std::vector<SweepResult> sweeps;
  const auto write = [&] {
    writeResultFiles(opt.out, {{".md", markdownReport(info, sweeps, rows)}, {".csv", csvTable(rows)}});
  };
  const auto add = [&](Row r) {
    std::fprintf(stderr, "%s, %s, %s: %s in %.1f s, worst excess %.3f, %s %.3f\n", solverName(r.solver).c_str(),
                 r.test.c_str(), r.variant.c_str(), outcome(r).c_str(), r.wall, r.worstExcess,
                 r.measure.c_str(), r.value);
    if (!r.stable || !r.ran) std::fprintf(stderr, "    %s\n", shortMessage(r.message).c_str());
    rows.push_back(std::move(r));
    write();
  };
  for (const std::string& name : opt.solvers) {
    const SolverType solver = solverTypes().at(name);
    SweepResult s{solver, 0, 0};
    for (Row& r : sweep(solver, opt.threads, s.largestStable, s.cap)) rows.push_back(std::move(r));
    sweeps.push_back(s);
    write();
    for (const double nu : {0.49, 0.499}) add(incompressible(solver, opt.threads, nu));
    add(compressAndBack(solver, opt.threads));
    for (const float v : {5.f, 10.f}) add(impact(solver, opt.threads, v));
    add(stiffnessRatio(solver, opt.threads));
  }
  info.complete = true;
  write();
  std::fprintf(stderr, "wrote %s.md and %s.csv\n", opt.out.c_str(), opt.out.c_str());
  return 0;
}
