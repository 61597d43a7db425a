#include "scenes/standard_scenes.h"

#include <cmath>

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

SceneSettings BlockDrop::settings() {
  SceneSettings s;
  s.domain.lower = {-1.f, 0.f, -1.f};
  s.domain.upper = {1.f, 2.f, 1.f};
  s.domain.wallMode = WallMode::Separate;
  s.dx = 1.f / 32.f;
  s.gravity = {0.f, -9.81f, 0.f};
  return s;
}

ParticleObjectDesc BlockDrop::block() {
  ParticleObjectDesc d;
  d.center = {0.f, 1.2f, 0.f};
  d.halfExtents = {0.25f, 0.15f, 0.2f};
  d.velocity = {0.3f, 0.f, 0.f};
  d.angularVelocity = {0.f, 0.f, 1.5f};
  d.material.model = MaterialModel::NeoHookeanDecoupled;
  d.material.youngsModulus = 4e4f;
  d.material.poissonRatio = 0.35f;
  d.material.density = 1000.f;
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
  d.material.model = MaterialModel::FixedCorotated;
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

}  // namespace mpm::scenes
