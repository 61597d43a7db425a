#include "scenes/standard_scenes.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <fstream>
#include <sstream>

#include "mpm/error.h"

namespace mpm::scenes {

SceneSettings CressimBench::settings(Backend backend, int threads) {
  SceneSettings s;
  s.domain.lower = {-5.5f, -5.5f, -5.5f};
  s.domain.upper = {5.5f, 5.5f, 5.5f};
  s.domain.wallMode = WallMode::Separate;
  s.dx = 0.2f;
  s.gravity = {0.f, -1.f, 0.f};
  s.substeps.fixedSubsteps = kSubstepsPerFrame;
  s.backend = backend;
  s.cpuThreads = threads;
  return s;
}

ParticleObjectDesc CressimBench::box(float halfSize) {
  ParticleObjectDesc d;
  d.primitive = PrimitiveType::Box;
  d.center = {0.f, 0.f, 0.f};
  d.halfExtents = {halfSize, halfSize, halfSize};
  d.particleSpacing = 0.1f;
  d.material.model = MaterialModel::FixedCorotated;
  d.material.youngsModulus = 5e5f;
  d.material.poissonRatio = 0.4f;
  d.material.density = 10.f / (0.1f * 0.1f * 0.1f);  // mass 10 per particle
  return d;
}

float HertzIndentation::cellSize(const Setup& setup) { return kRadius / (float)setup.cellsPerRadius; }

SceneSettings HertzIndentation::settings(const Setup& setup) {
  const float dx = cellSize(setup);
  SceneSettings s;
  s.dx = dx;
  s.gravity = {0.f, 0.f, 0.f};
  s.domain.wallMode = WallMode::Slip;
  const int wall = s.domain.wallThickness;
  // whole cells from the origin to every face: node layers at y = 0 and y = H, a node
  // column on the axis x = z = 0; beside the slab, two free cells and the wall
  const int side = (int)std::lround(setup.slabHalfWidth / dx) + 2 + wall;
  const int top = (int)std::lround(setup.slabThickness / dx) + 2 + wall;
  s.domain.lower = {-side * dx, -wall * dx, -side * dx};
  s.domain.upper = {side * dx, top * dx, side * dx};
  if (setup.quarter) {
    s.domain.lower.x = s.domain.lower.z = -wall * dx;  // the mirror planes at x = z = 0
    s.domain.mirrorLower[0] = s.domain.mirrorLower[2] = true;
  }
  s.backend = setup.backend;
  s.cpuThreads = setup.threads;
  return s;
}

ParticleObjectDesc HertzIndentation::slab(const Setup& setup) {
  // whole cells, so that the faces lie on node layers
  const float dx = cellSize(setup);
  const float half = dx * std::round(setup.slabHalfWidth / dx);
  const float thick = surfaceHeight(setup);
  ParticleObjectDesc d;
  d.primitive = PrimitiveType::Box;
  const float side = setup.quarter ? 0.5f * half : half;  // x and z from 0 to half
  d.center = {setup.quarter ? side : 0.f, 0.5f * thick, setup.quarter ? side : 0.f};
  d.halfExtents = {side, 0.5f * thick, side};
  d.particlesPerCellAxis = 2;
  d.material.model = setup.material;
  d.material.youngsModulus = kYoungsModulus;
  d.material.poissonRatio = kPoissonRatio;
  d.material.density = kDensity;
  return d;
}

ShapeDesc HertzIndentation::indenter(const Setup& setup) {
  Geometry ball;
  ball.type = GeometryType::Sphere;
  ball.radius = kRadius;
  ShapeDesc s;
  s.parts = {ball};
  // the node layer one cell above the surface holds slab mass: start just clear of it
  s.pose.position = {0.f, surfaceHeight(setup) + 1.05f * cellSize(setup) + kRadius, 0.f};
  s.linearVelocity = {0.f, -5.f * loadingSpeed(setup), 0.f};
  s.contact.mode = ContactMode::Frictional;
  s.contact.friction = 0.f;
  s.mass = 0.f;
  return s;
}

float HertzIndentation::surfaceHeight(const Setup& setup) {
  const float dx = cellSize(setup);
  return dx * std::round(setup.slabThickness / dx);
}

float HertzIndentation::waveSpeed() {
  const double E = kYoungsModulus, nu = kPoissonRatio;
  return (float)std::sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) / kDensity);
}

float HertzIndentation::transitTime(const Setup& setup) { return setup.slabThickness / waveSpeed(); }

float HertzIndentation::loadingSpeed(const Setup& setup) {
  return kMaxDepth / (setup.loadingTransits * transitTime(setup));
}

double HertzIndentation::hertzForce(double depth) {
  if (depth <= 0) return 0;
  const double nu = kPoissonRatio;
  const double eStar = kYoungsModulus / (1 - nu * nu);
  return 4.0 / 3.0 * eStar * std::sqrt((double)kRadius) * std::pow(depth, 1.5);
}

double HertzIndentation::windowHalfDepth(const Setup& setup) {
  return 0.5 * (double)loadingSpeed(setup) * kWindowTransits * transitTime(setup);
}

HertzIndentation::Run HertzIndentation::run(const Setup& setup,
                                            const std::function<void(int, int)>& progress) {
  const double dx = cellSize(setup);
  Scene scene(settings(setup));
  scene.addParticleObject(slab(setup));
  const ShapeId id = scene.addShape(indenter(setup));

  // the approach (1.05 dx down to dx / 4 above the surface) in whole frames of at most
  // 5 kFrameDepth; loading frames of kFrameDepth, half a window past kMaxDepth
  const double approachTravel = 0.8 * dx, approachSpeed = 5.0 * loadingSpeed(setup);
  const int approachFrames = (int)std::ceil(approachTravel / (5.0 * kFrameDepth) - 1e-6);
  const float approachFrame = (float)(approachTravel / approachSpeed / approachFrames);
  const float loadingFrame = kFrameDepth / loadingSpeed(setup);
  const int loadingFrames =
      (int)std::ceil((0.25 * dx + kMaxDepth + windowHalfDepth(setup)) / kFrameDepth) + 1;
  const int frames = approachFrames + loadingFrames;

  Run r;
  r.setup = setup;
  r.particles = scene.particleCount();
  const double surface = surfaceHeight(setup);
  auto depthNow = [&] {
    return surface - ((double)scene.shapeState(id).pose.position.y - kRadius);
  };
  for (int f = 0; f < frames; ++f) {
    const bool loading = f >= approachFrames;
    if (f == approachFrames) {
      ShapeState s = scene.shapeState(id);
      s.linearVelocity = {0.f, -loadingSpeed(setup), 0.f};
      scene.setShapeState(id, s);
    }
    const float frame = loading ? loadingFrame : approachFrame;
    const double before = depthNow();
    r.substeps += scene.step(frame).substeps;
    Sample s;
    s.depth = 0.5 * (before + depthNow());
    // the grid pushes the sphere up; a quarter model gives a quarter of it
    s.force = (setup.quarter ? 4.0 : 1.0) * scene.shapeImpulse(id).linear.y / frame;
    (loading ? r.loading : r.approach).push_back(s);
    if (progress) progress(f + 1, frames);
  }
  return r;
}

double HertzIndentation::averagedForce(const Run& run, double depth, bool hertz) {
  const double half = windowHalfDepth(run.setup);
  double sum = 0;
  int n = 0;
  for (const Sample& s : run.loading)
    if (std::fabs(s.depth - depth) <= half) {
      sum += hertz ? hertzForce(s.depth) : s.force;
      ++n;
    }
  return n ? sum / n : std::nan("");
}

HertzIndentation::Comparison HertzIndentation::compare(const Run& run) {
  Comparison c;
  double num = 0, den = 0;
  for (int i = 0; i <= 16; ++i) {
    const double d = (0.02 + 0.005 * i) * kRadius;
    const double f = averagedForce(run, d), fh = averagedForce(run, d, true);
    num += (f - fh) * (f - fh);
    den += fh * fh;
  }
  c.l2Error = std::sqrt(num / den);
  const double f = averagedForce(run, kMaxDepth), fh = averagedForce(run, kMaxDepth, true);
  c.errorAtMaxDepth = f / fh - 1;
  // F_H ~ d^1.5: the Hertz depth that gives the measured force is d (F / F_H)^(2/3)
  const double dHertz = kMaxDepth * std::pow(std::fmax(f / fh, 0.0), 2.0 / 3.0);
  c.depthLossCells = (kMaxDepth - dHertz) / cellSize(run.setup);
  return c;
}

ShapeDesc plate(float halfWidth, float halfThickness, float faceY, bool below, const ContactParams& contact) {
  ShapeDesc d;
  Geometry box;
  box.type = GeometryType::Box;
  box.halfExtents = {halfWidth, halfThickness, halfWidth};
  d.parts = {box};
  d.contact = contact;
  d.pose.position = {0.f, below ? faceY - halfThickness : faceY + halfThickness, 0.f};
  return d;
}

double CylinderBetweenPlates::seedPoissonRatio() { return (3 * kBulk - 2 * kMu) / (2 * (3 * kBulk + kMu)); }

Material CylinderBetweenPlates::material(double nu) {
  // at the paper's nu, E = 2 mu (1 + nu) rounds to the same float as 9 K mu / (3 K + mu)
  const double E = 2 * kMu * (1 + nu);
  return {MaterialModel::NeoHookeanDecoupled, (float)E, (float)nu, (float)kDensity};
}

double CylinderBetweenPlates::waveSpeed(const Material& m) {
  const double E = m.youngsModulus, nu = m.poissonRatio;
  return std::sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) / m.density);
}

double CylinderBetweenPlates::smoothRamp(double s) {
  s = std::min(std::max(s, 0.0), 1.0);
  return (10 - 15 * s + 6 * s * s) * s * s * s;
}

const char* CylinderBetweenPlates::loadingName(Loading loading) {
  switch (loading) {
    case Loading::Compression: return "compression";
    case Loading::Extension: return "extension";
    case Loading::Shear: return "shear";
  }
  return "?";
}

SceneSettings CylinderBetweenPlates::settings(const Setup& setup) {
  const bool meshless = setup.solver == SolverType::Mtled;
  const double dx = meshless ? 0.01 : setup.resolution;
  // whole cells from the origin to the lower y face and to the x, z faces (computed in
  // double: at dx = 0.01 these are exactly -0.05 and +-halfWidth)
  const double below = dx * std::round(0.05 / dx), side = dx * std::round(setup.halfWidth / dx);
  SceneSettings s;
  s.domain = {{(float)-side, (float)-below, (float)-side}, {(float)side, 0.15f, (float)side}};
  s.domain.walls = false;
  s.dx = (float)dx;
  s.gravity = {0.f, 0.f, 0.f};
  s.solver = setup.solver;
  s.backend = setup.backend;
  s.cpuThreads = setup.threads;
  s.energyCheck.enabled = setup.energyCheck;
  s.substeps.fixedSubsteps = setup.fixedSubsteps;
  s.mtled.timeStepSafety = setup.mtledSafety;
  s.mtled.smoothedStrain = setup.smoothedStrain;
  return s;
}

ParticleObjectDesc CylinderBetweenPlates::cylinder(const Setup& setup) {
  ParticleObjectDesc cyl;
  cyl.primitive = PrimitiveType::Cylinder;
  cyl.center = {0.f, (float)kHeight / 2, 0.f};
  cyl.radius = (float)kRadius;
  cyl.halfExtents = {0.f, (float)kHeight / 2, 0.f};
  // MTLED: nodes `resolution` apart; MPM: 2 particles per cell axis
  cyl.particleSpacing = setup.solver == SolverType::Mtled ? (float)setup.resolution : 0.f;
  cyl.material = material(setup.nu);
  return cyl;
}

ShapeDesc CylinderBetweenPlates::plate(const Setup& setup, bool top) {
  ContactParams contact;
  contact.mode = setup.ends;
  contact.friction = 0.f;
  const bool meshless = setup.solver == SolverType::Mtled;
  contact.band = setup.plateBand >= 0.f ? setup.plateBand : (float)setup.resolution * (meshless ? 0.1f : 0.5f);
  return scenes::plate(setup.halfWidth, kPlateHalfThickness, top ? (float)kHeight : 0.f, !top, contact);
}

CylinderBetweenPlates::Parts CylinderBetweenPlates::build(Scene& scene, const Setup& setup) {
  Parts p;
  p.body = scene.addParticleObject(cylinder(setup));
  p.bottom = scene.addShape(plate(setup, false));
  p.top = scene.addShape(plate(setup, true));
  return p;
}

std::array<double, 3> CylinderBetweenPlates::topDisplacement(Loading loading, double t, double rampTime) {
  // D (10 - 15 s + 6 s^2) s^3, multiplied in this order (tests/test_mtled.cpp's numbers)
  const double s = std::min(std::max(t / rampTime, 0.0), 1.0);
  const double u = kTravel * (10 - 15 * s + 6 * s * s) * s * s * s;
  switch (loading) {
    case Loading::Compression: return {0.0, -u, 0.0};
    case Loading::Extension: return {0.0, u, 0.0};
    case Loading::Shear: return {u, 0.0, 0.0};
  }
  return {0.0, 0.0, 0.0};
}

CylinderBetweenPlates::Run CylinderBetweenPlates::run(const Setup& setup, Loading loading, double frame, double sample,
                                    const std::function<void(double)>& progress) {
  Scene scene(settings(setup));
  const Parts parts = build(scene, setup);
  Run run;
  run.particles = scene.particleCount(parts.body);
  const auto wall0 = std::chrono::steady_clock::now();
  const std::clock_t cpu0 = std::clock();
  double t = 0;
  for (int k = 0; t < setup.rampTime - 1e-9; ++k) {
    const double t1 = k == 0 ? frame / 2 : t + frame;
    // the plate's pose at the frame's start and its mean velocity over the frame, in double
    // before rounding
    const std::array<double, 3> u0 = topDisplacement(loading, t, setup.rampTime),
                                u1 = topDisplacement(loading, t1, setup.rampTime);
    ShapeState st;
    st.pose.position = {(float)u0[0], (float)(kHeight + kPlateHalfThickness + u0[1]), 0.f};
    st.linearVelocity = {(float)((u1[0] - u0[0]) / (t1 - t)), (float)((u1[1] - u0[1]) / (t1 - t)), 0.f};
    scene.setShapeState(parts.top, st);
    const StepReport r = scene.step((float)(t1 - t));
    run.substeps += r.substeps;
    run.substepDt = r.substepDt;
    run.energy = r.energy;
    const double mid = 0.5 * (t + t1);
    if (std::abs(mid / sample - std::round(mid / sample)) < 1e-6 && mid > 1e-6) {
      // the plate receives +impulse; the force on the cylinder is its opposite
      const ShapeImpulse impulse = scene.shapeImpulse(parts.top);
      run.time.push_back(mid);
      run.axialForce.push_back(-impulse.linear.y / (t1 - t));
      run.shearForce.push_back(-impulse.linear.x / (t1 - t));
    }
    t = t1;
    if (progress) progress(t);
  }
  run.simulated = t;
  run.wallSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  run.cpuSeconds = (double)(std::clock() - cpu0) / CLOCKS_PER_SEC;
  return run;
}

std::vector<std::vector<double>> CylinderBetweenPlates::readCsv(const std::string& path) {
  std::ifstream in(path);
  if (!in.good()) throw Error("cannot open " + path);
  std::vector<std::vector<double>> columns;
  std::string line;
  bool header = true;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (header) {
      header = false;
      continue;
    }
    std::stringstream s(line);
    std::string cell;
    for (size_t c = 0; std::getline(s, cell, ','); ++c) {
      if (columns.size() <= c) columns.emplace_back();
      columns[c].push_back(std::stod(cell));
    }
  }
  return columns;
}

double CylinderBetweenPlates::at(const std::vector<double>& times, const std::vector<double>& values, double t) {
  for (size_t i = 0; i < times.size() && i < values.size(); ++i)
    if (std::abs(times[i] - t) < 1e-6) return values[i];
  return std::nan("");
}

}  // namespace mpm::scenes
