#pragma once
// bench_soak's random scenes: everything a scene is, drawn from its seed alone (the child
// builds it, the parent prints it). Only the public API (mpm/include).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "bench_options.h"
#include "mpm/scene.h"

namespace mpm::soak {

using mpm::bench::solverName;
constexpr float kPi = 3.14159265f;

struct Options {
  double minutes = 30;
  int threads = 2;          ///< cpuThreads of a scene is drawn from 1..threads
  uint64_t seed = 0;        ///< of the whole run; 0: from the clock
  std::string scene;        ///< one scene's seed: run only it
  bool inProcess = false;   ///< with --scene: no fork
  bool verbose = false;     ///< a line per advance
  int maxScenes = 0;        ///< 0: until the time is up
  int alarmSeconds = 60;    ///< a child still running then is a hang
  double budget = 3e6;      ///< particle-substeps per scene (PB-MPM: times its iterations)
  int maxParticles = 4000;  ///< per scene, about
  float detMin = 0.01f, detMax = 100.f;
  Backend backend = Backend::Cpu;
  std::string out;          ///< markdown summary; empty: stdout only
};

/// Reproducible draws: std::mt19937_64 is specified bit for bit, the distributions are not.
class Rng {
 public:
  explicit Rng(uint64_t seed) : g_(seed) {}
  uint64_t bits() { return g_(); }
  double uniform(double a, double b) { return a + (b - a) * (double)(g_() >> 11) * 0x1.0p-53; }
  float uni(double a, double b) { return (float)uniform(a, b); }
  float logUni(double a, double b) { return (float)std::exp(uniform(std::log(a), std::log(b))); }
  int integer(int a, int b) { return a + (int)(g_() % (uint64_t)(b - a + 1)); }
  bool chance(double p) { return uniform(0, 1) < p; }
  Vec3f direction() {
    const float z = uni(-1, 1), a = uni(0, 2 * kPi), r = std::sqrt(std::max(0.f, 1 - z * z));
    return {r * std::cos(a), r * std::sin(a), z};
  }
  Quat rotation() {  // uniform (Shoemake)
    const double u1 = uniform(0, 1), u2 = uniform(0, 2 * kPi), u3 = uniform(0, 2 * kPi);
    const double a = std::sqrt(1 - u1), b = std::sqrt(u1);
    return {(float)(b * std::cos(u3)), (float)(a * std::sin(u2)), (float)(a * std::cos(u2)), (float)(b * std::sin(u3))};
  }

 private:
  std::mt19937_64 g_;
};

inline Vec3f rotate(const Quat& q, Vec3f v) {
  const Vec3f u{q.x, q.y, q.z};
  const Vec3f t = 2.f * cross(u, v);
  return v + q.w * t + cross(u, t);
}
inline Quat multiply(const Quat& a, const Quat& b) {
  return {a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z, a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
          a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x, a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w};
}
inline Quat aboutY(float angle) { return {std::cos(angle / 2), 0.f, std::sin(angle / 2), 0.f}; }
inline Vec3f unit(Vec3f v) {
  const float n = norm(v);
  return n > 1e-9f ? (1.f / n) * v : Vec3f{0.f, -1.f, 0.f};
}

/// A tool's speed: slow to a few m/s, sometimes tens of m/s.
inline float toolSpeed(Rng& r) { return r.chance(0.05) ? r.uni(10, 30) : r.logUni(0.01, 3); }

/// One advance of the plan.
struct AdvancePlan {
  float dt = 1.f / 60;
  bool async = false;     ///< advance() + fetchResults() instead of step()
  bool roundTrip = false; ///< saveToMemory / loadFromMemory after it
  bool freshScene = false;  ///< load into a new Scene instead of the same one
};

/// Everything a scene is, drawn from its seed alone (the child builds it, the parent prints it).
struct SceneSpec {
  uint64_t seed = 0;
  SceneSettings settings;
  std::vector<ParticleObjectDesc> objects;
  std::vector<ShapeDesc> tools;  ///< kinematic, moved every advance
  std::vector<float> toolSpeeds;
  bool floor = false;            ///< a static plane under the objects
  float floorY = 0;
  std::vector<QuadSlicerDesc> slicers;
  std::vector<ArcDesc> needles;
  std::vector<float> needleSpeeds;  ///< of the tip along the arc [m/s]
  std::vector<AdvancePlan> plan;
  double costFactor = 1;            ///< work per particle-substep, relative
};

inline Vec3f halfSize(const ParticleObjectDesc& d) {
  switch (d.primitive) {
    case PrimitiveType::Box: return d.halfExtents;
    case PrimitiveType::Sphere: return {d.radius, d.radius, d.radius};
    default: return {d.radius, d.halfExtents.y, d.radius};
  }
}

inline ParticleObjectDesc drawObject(Rng& r, const SceneSettings& s, int budget) {
  ParticleObjectDesc d;
  d.primitive = (PrimitiveType)r.integer(0, 2);
  // MTLED needs a support domain of nodes in every body: at least 3 spacings across
  const bool mtled = s.solver == SolverType::Mtled;
  const float minHalf = std::max(0.01f, (mtled ? 1.5f : 1.f) * s.dx);
  d.halfExtents = {r.uni(minHalf, 0.04), r.uni(minHalf, 0.04), r.uni(minHalf, 0.04)};
  d.radius = r.uni(minHalf, 0.035);
  d.particlesPerCellAxis = mtled ? 2 : r.integer(1, 2);
  const float spacing = s.dx / (float)d.particlesPerCellAxis;
  // keep the count near the budget: shrink the body, never thin its particles
  const Vec3f h = halfSize(d);
  const double volume = 8.0 * h.x * h.y * h.z;
  const double count = volume / ((double)spacing * spacing * spacing);
  if (count > budget) {
    const float k = std::max((float)std::cbrt(budget / count), 0.f);
    d.halfExtents = {std::max(minHalf, k * d.halfExtents.x), std::max(minHalf, k * d.halfExtents.y),
                     std::max(minHalf, k * d.halfExtents.z)};
    d.radius = std::max(minHalf, k * d.radius);
  }
  Material& m = d.material;
  m.model = r.chance(0.5) ? MaterialModel::FixedCorotated : MaterialModel::NeoHookeanDecoupled;
  m.youngsModulus = r.logUni(1e3, 1e6);
  m.poissonRatio = r.uni(0, 0.49);
  m.density = r.uni(900, 1200);
  m.fractureToughness = r.chance(0.5) ? 0.f : r.uni(10, 300);
  if (r.chance(0.2)) d.velocity = r.uni(0, 0.5) * r.direction();
  if (r.chance(0.1)) d.angularVelocity = r.uni(0, 5) * r.direction();
  return d;
}

inline Geometry drawGeometry(Rng& r) {
  Geometry g;
  g.type = (GeometryType)r.integer(1, 4);  // Box, Sphere, Capsule, Cylinder
  g.halfExtents = {r.uni(0.004, 0.03), r.uni(0.004, 0.03), r.uni(0.004, 0.03)};
  g.radius = g.type == GeometryType::Sphere ? r.uni(0.005, 0.02) : r.uni(0.003, 0.01);
  g.halfHeight = r.uni(0.005, 0.04);
  g.axis = r.integer(0, 2);
  return g;
}

inline SceneSpec drawScene(uint64_t seed, const Options& opt) {
  Rng r(seed);
  SceneSpec spec;
  spec.seed = seed;
  SceneSettings& s = spec.settings;
  const double pick = r.uniform(0, 1);
  s.solver = pick < 0.3 ? SolverType::MlsMpm : pick < 0.55 ? SolverType::StandardMpm : pick < 0.8 ? SolverType::PbMpm : SolverType::Mtled;
  const bool mtled = s.solver == SolverType::Mtled;
  s.dx = r.uni(0.005, 0.02);
  s.backend = opt.backend;
  s.cpuThreads = r.integer(1, std::max(1, opt.threads));
  s.domain.walls = !mtled && r.chance(0.8);
  s.domain.wallMode = (WallMode)r.integer(0, 2);
  s.domain.wallThickness = r.integer(1, 3);
  if (r.chance(0.1)) s.gravity = {0.f, 0.f, 0.f};
  s.standardMpm.flipBlend = r.chance(0.5) ? 0.95f : r.uni(0, 1);
  if (r.chance(0.5)) {
    s.pbMpm.iterations = r.integer(1, 20);
    s.pbMpm.relaxation = r.uni(0.3, 1.7);
    s.pbMpm.rigidity = r.chance(0.5) ? 1.f : r.uni(0, 1);
  }
  if (r.chance(0.5)) {
    s.mtled.supportNodes = r.integer(6, 16);
    s.mtled.supportScale = r.uni(2, 20);
    s.mtled.integrationCellsPerSpacing = r.uni(1, 2);
    s.mtled.smoothedStrain = r.chance(0.5);
    s.mtled.timeStepSafety = r.uni(0.2, 0.8);
  }
  if (r.chance(0.3)) s.substeps.cflNumber = r.uni(0.1, 0.8);
  s.energyCheck.enabled = r.chance(0.4);
  s.energyCheck.tolerance = r.uni(0.1, 1);
  s.recovery.enabled = r.chance(0.4);
  s.recovery.maxHalvings = r.integer(1, 4);

  // domain: a 20 cm box of room above the floor, plus the walls' and stencil's margin
  const float margin = (float)(s.domain.wallThickness + 3) * s.dx;
  s.domain.lower = {-0.1f - margin, 0.f, -0.1f - margin};
  s.domain.upper = {0.1f + margin, 0.2f + 2 * margin, 0.1f + margin};
  spec.floor = !s.domain.walls || r.chance(0.2);
  spec.floorY = margin;
  if (!s.domain.walls && !spec.floor) s.gravity = {0.f, 0.f, 0.f};

  // 1-3 objects side by side, their boxes apart by a cell
  const int wanted = r.integer(1, 3);
  for (int i = 0; i < wanted; ++i) {
    ParticleObjectDesc d = drawObject(r, s, opt.maxParticles / wanted);
    const Vec3f h = halfSize(d);
    for (int tries = 0; tries < 30; ++tries) {
      d.center = {r.uni(-0.1 + h.x + 0.005, 0.1 - h.x - 0.005), spec.floorY + h.y + r.uni(0.002, 0.03),
                  r.uni(-0.1 + h.z + 0.005, 0.1 - h.z - 0.005)};
      if (i == 0 || r.chance(0.3)) d.center.y += i * 0.05f;  // sometimes stacked
      bool apart = true;
      for (const ParticleObjectDesc& o : spec.objects) {
        const Vec3f g = halfSize(o);
        bool sep = false;
        for (int a = 0; a < 3; ++a) sep |= std::fabs(d.center[a] - o.center[a]) > h[a] + g[a] + s.dx;
        apart &= sep;
      }
      if (apart) {
        spec.objects.push_back(d);
        break;
      }
    }
  }

  // kinematic tools, each started a few cm off an object and aimed at it
  const int tools = r.integer(0, 3);
  for (int i = 0; i < tools; ++i) {
    ShapeDesc t;
    t.parts.push_back(drawGeometry(r));
    if (r.chance(0.15)) {
      t.parts.push_back(drawGeometry(r));
      t.parts.back().localPose.position = r.uni(0.01, 0.03) * r.direction();
    }
    t.contact.mode = (ContactMode)r.integer(0, 2);
    t.contact.friction = r.chance(0.5) ? 0.f : r.uni(0, 1);
    t.contact.drag = r.chance(0.7) ? 1.f : r.uni(0, 1);
    t.contact.band = r.chance(0.7) ? 0.f : 0.5f * s.dx;
    const ParticleObjectDesc& o = spec.objects[(size_t)r.integer(0, (int)spec.objects.size() - 1)];
    Vec3f dir = r.direction();
    dir.y = std::fabs(dir.y) + 0.2f;
    float reach = 0;  // the tool's bounding radius: it starts clear of the object
    for (const Geometry& g : t.parts)
      reach = std::max(reach, norm(g.localPose.position) + std::max(norm(g.halfExtents), g.radius + g.halfHeight));
    t.pose.position = o.center + (norm(halfSize(o)) + reach + s.dx + r.uni(0, 0.03)) * unit(dir);
    t.pose.rotation = r.rotation();
    const float speed = toolSpeed(r);
    t.linearVelocity = speed * unit(o.center - t.pose.position);
    if (r.chance(0.2)) t.angularVelocity = r.uni(0, 10) * r.direction();
    spec.tools.push_back(t);
    spec.toolSpeeds.push_back(speed);
  }
  // a blade from above or a needle, grid solvers only
  if (!mtled && r.chance(0.25)) {
    const ParticleObjectDesc& o = spec.objects[0];
    QuadSlicerDesc b;
    b.halfLength = r.uni(0.01, 0.05);
    b.width = r.uni(0.01, 0.04);
    b.spineRadius = r.chance(0.5) ? 0.f : r.uni(0.001, 0.003);
    b.halfThickness = r.chance(0.5) ? 0.f : r.uni(0.0002, 0.001);
    b.friction = r.chance(0.5) ? 0.f : r.uni(0, 0.5);
    b.pose.rotation = aboutY(r.uni(0, kPi));
    b.pose.position = o.center + Vec3f{r.uni(-0.01, 0.01), halfSize(o).y + r.uni(0.003, 0.02), r.uni(-0.01, 0.01)};
    const float speed = toolSpeed(r);
    b.linearVelocity = speed * unit({r.uni(-0.3, 0.3), -1.f, r.uni(-0.3, 0.3)});
    spec.slicers.push_back(b);
  }
  if (!mtled && r.chance(0.2)) {
    const ParticleObjectDesc& o = spec.objects.back();
    ArcDesc n;
    n.radius = r.uni(0.006, 0.015);
    // the arc's upper half (turned over below): it starts clear of the tissue and its tip
    // swings down into it as the needle turns
    n.startAngle = kPi;
    n.endAngle = n.startAngle + r.uni(0.5 * kPi, kPi);
    n.wireRadius = r.uni(0.00015, 0.0005);
    n.friction = r.uni(0, 0.5);
    n.punctureForce = r.chance(0.5) ? 0.f : r.uni(0.1, 1);
    // arc plane vertical, its circle reaching below the top face
    const Quat flip{0.f, 1.f, 0.f, 0.f};  // half a turn about x: the arc opens downward
    const Quat spin = aboutY(r.uni(0, 2 * kPi));
    n.pose.rotation = multiply(spin, flip);
    n.pose.position = o.center + Vec3f{r.uni(-0.01, 0.01), halfSize(o).y + n.radius * r.uni(0.5, 0.95), r.uni(-0.01, 0.01)};
    const float speed = r.logUni(0.01, 1);
    n.angularVelocity = (speed / n.radius) * rotate(n.pose.rotation, {0.f, 0.f, 1.f});
    if (r.chance(0.3)) n.linearVelocity = r.uni(0, 0.2) * r.direction();
    spec.needles.push_back(n);
    spec.needleSpeeds.push_back(speed);
  }

  const int advances = r.integer(5, 60);
  const int roundTripAt = r.chance(0.25) ? r.integer(0, advances - 1) : -1;
  for (int i = 0; i < advances; ++i) {
    AdvancePlan a;
    a.dt = r.logUni(1.0 / 1000, 1.0 / 30);
    a.async = r.chance(0.2);
    a.roundTrip = i == roundTripAt;
    a.freshScene = r.chance(0.5);
    spec.plan.push_back(a);
  }
  // measured here: PB-MPM's substep costs about its iterations in MLS-MPM substeps, MTLED's about 5
  spec.costFactor = s.solver == SolverType::PbMpm ? s.pbMpm.iterations : mtled ? 5 : 1;
  return spec;
}

inline const char* primitiveName(PrimitiveType p) { return p == PrimitiveType::Box ? "box" : p == PrimitiveType::Sphere ? "sphere" : "cylinder"; }

inline std::string describe(const SceneSpec& spec) {
  const SceneSettings& s = spec.settings;
  std::ostringstream o;
  o << solverName(s.solver) << " dx " << s.dx * 1000 << " mm, " << s.cpuThreads << " thr,";
  for (const ParticleObjectDesc& d : spec.objects)
    o << " " << primitiveName(d.primitive) << "(E " << d.material.youngsModulus << ", nu " << d.material.poissonRatio << ")";
  o << ", " << spec.tools.size() << " tools";
  if (!spec.slicers.empty()) o << ", slicer";
  if (!spec.needles.empty()) o << ", needle";
  if (s.recovery.enabled) o << ", recovery";
  if (s.energyCheck.enabled) o << ", energy check";
  for (const AdvancePlan& a : spec.plan)
    if (a.roundTrip) o << ", round trip";
  return o.str();
}

}  // namespace mpm::soak
