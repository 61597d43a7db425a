// Cutting demo (CRESSim-MPM, Fig. 11): a scalpel, a kinematic Bullet body coupled as a slicer,
// goes down into a block of tissue bonded to the ground at its base, moves right through
// it, goes down again to open the cut deeper, and is withdrawn. The tissue resists with
// its fracture toughness (liver, 160 J/m^2). Writes PNGs (the two sides of the cut in two
// shades), force.csv (the force on the scalpel over time) and summary.txt: the pieces the
// block is in, the cut's gap, its length and depth, the peak and the steady cutting force.
#include <CLI/CLI.hpp>
#include <btBulletDynamicsCommon.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <numeric>
#include <string>
#include <vector>

#include "mpm/output.h"
#include "mpm/scene.h"
#include "mpm_bullet/coupler.h"

namespace {

// The block: 12 x 4 x 6 cm on the ground; the cut runs along x in the plane z = 0.
constexpr float kHalfX = 0.06f, kHeight = 0.04f, kHalfZ = 0.03f;
constexpr float kFirstDepth = 0.015f, kSecondDepth = 0.025f;  // below the top [m]
constexpr float kStartX = -0.035f, kEndX = 0.035f;            // the blade's leading end

/// The scalpel's leading end (x) and edge height (y) at time t: down, right, down, up.
struct Script {
  double t0 = 0.3, t1 = 0.8, t2 = 2.0, t3 = 2.4, t4 = 2.9;  // phase ends [s]
  float above = kHeight + 0.01f;
  void at(double t, float& x, float& y) const {
    auto ramp = [](double a) { a = std::clamp(a, 0.0, 1.0); return (float)(a * a * (3 - 2 * a)); };
    const float y1 = kHeight - kFirstDepth, y2 = kHeight - kSecondDepth;
    x = kStartX + (kEndX - kStartX) * ramp((t - t1) / (t2 - t1));
    if (t < t1) y = above + (y1 - above) * ramp((t - t0) / (t1 - t0));
    else if (t < t3) y = y1 + (y2 - y1) * ramp((t - t2) / (t3 - t2));
    else y = y2 + (above + 0.02f - y2) * ramp((t - t3) / (t4 - t3));
  }
};

/// A kinematic body's pose from the script: Bullet asks at the start of each internal tick
/// for the pose at its end, and takes the velocity from the difference.
struct ScriptedMotion : btMotionState {
  const Script* script;
  float halfLength;
  double time = 0, tick = 1.0 / 240;
  void getWorldTransform(btTransform& t) const override {
    float x, y;
    script->at(time + tick, x, y);
    // the body's centre: the blade's middle, its edge at y
    t.setIdentity();
    t.setOrigin(btVector3(x - halfLength, y, 0.f));
  }
  void setWorldTransform(const btTransform&) override {}
};

/// Connected pieces among particles closer than `link` (cell hash).
int pieces(const std::vector<mpm::Vec3f>& x, float link) {
  std::vector<size_t> parent(x.size());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](size_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  auto key = [&](int i, int j, int k) { return ((long long)i * 100003 + j) * 100019 + k; };
  std::map<long long, std::vector<size_t>> cells;
  auto cell = [&](float v) { return (int)std::floor(v / link); };
  for (size_t i = 0; i < x.size(); ++i) cells[key(cell(x[i].x), cell(x[i].y), cell(x[i].z))].push_back(i);
  for (size_t i = 0; i < x.size(); ++i)
    for (int a = -1; a <= 1; ++a)
      for (int b = -1; b <= 1; ++b)
        for (int c = -1; c <= 1; ++c) {
          auto it = cells.find(key(cell(x[i].x) + a, cell(x[i].y) + b, cell(x[i].z) + c));
          if (it == cells.end()) continue;
          for (size_t j : it->second) {
            const mpm::Vec3f d = x[i] - x[j];
            if (j > i && mpm::dot(d, d) < link * link) parent[find(i)] = find(j);
          }
        }
  int n = 0;
  for (size_t i = 0; i < x.size(); ++i) n += find(i) == i;
  return n;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"A scalpel cuts a tissue block held at its base (Bullet + MPM slicer)"};
  std::string out = "out/cutting", solverName = "MlsMpm";
  int pngEvery = 10, threads = 0;
  float dx = 0.005f, toughness = 160.f;
  app.add_option("--out", out, "output folder");
  app.add_option("--solver", solverName, "MlsMpm, StandardMpm or PbMpm");
  app.add_option("--dx", dx, "grid cell size [m]")->check(CLI::PositiveNumber);
  app.add_option("--toughness", toughness, "fracture toughness G_c [J/m^2]")->check(CLI::NonNegativeNumber);
  app.add_option("--png-every", pngEvery, "write a PNG every N frames (60 per second)")->check(CLI::PositiveNumber);
  app.add_option("--threads", threads, "CPU threads (0 = all)")->check(CLI::NonNegativeNumber);
  CLI11_PARSE(app, argc, argv);
  const std::map<std::string, mpm::SolverType> solvers = {
      {"MlsMpm", mpm::SolverType::MlsMpm}, {"StandardMpm", mpm::SolverType::StandardMpm}, {"PbMpm", mpm::SolverType::PbMpm}};
  if (!solvers.count(solverName)) {
    std::fprintf(stderr, "cutting: --solver %s: use MlsMpm, StandardMpm or PbMpm\n", solverName.c_str());
    return 2;
  }

  try {
    std::filesystem::create_directories(out);
    btDefaultCollisionConfiguration config;
    btCollisionDispatcher dispatcher(&config);
    btDbvtBroadphase broadphase;
    btSequentialImpulseConstraintSolver solver;
    btDiscreteDynamicsWorld world(&dispatcher, &broadphase, &solver, &config);
    world.setGravity(btVector3(0, -9.81f, 0));
    btBoxShape groundShape(btVector3(0.1f, 0.01f, 0.06f));
    btRigidBody ground(0.f, nullptr, &groundShape);
    ground.setWorldTransform(btTransform(btQuaternion::getIdentity(), btVector3(0, -0.01f, 0)));
    world.addRigidBody(&ground);

    mpm::SceneSettings settings;
    settings.domain = {{-0.1f, -0.03f, -0.06f}, {0.1f, 0.1f, 0.06f}};
    settings.dx = dx;
    settings.solver = solvers.at(solverName);
    settings.cpuThreads = threads;
    mpm::Scene scene(settings);
    mpm::ParticleObjectDesc block;
    block.center = {0.f, 0.5f * kHeight, 0.f};
    block.halfExtents = {kHalfX, 0.5f * kHeight, kHalfZ};
    block.material = {mpm::MaterialModel::NeoHookeanDecoupled, 6e4f, 0.4f, 1060.f, toughness};
    const mpm::ParticleObjectId tissue = scene.addParticleObject(block);

    mpm::bullet::Coupler coupler(&world, scene);
    mpm::bullet::CouplingOptions held;
    held.contact.mode = mpm::ContactMode::Bonded;  // the block's base is glued down
    coupler.addRigidBody(&ground, held);

    // the scalpel: a 3 cm blade, 4 cm from edge to spine, kinematic
    Script script;
    ScriptedMotion motion;
    motion.script = &script;
    motion.halfLength = 0.015f;
    btBoxShape handleShape(btVector3(0.015f, 0.02f, 0.0005f));
    btRigidBody::btRigidBodyConstructionInfo info(0.f, &motion, &handleShape);
    btRigidBody scalpel(info);
    scalpel.setCollisionFlags(scalpel.getCollisionFlags() | btCollisionObject::CF_KINEMATIC_OBJECT);
    scalpel.setActivationState(DISABLE_DEACTIVATION);
    world.addRigidBody(&scalpel);
    scalpel.setCollisionFlags(scalpel.getCollisionFlags() | btCollisionObject::CF_NO_CONTACT_RESPONSE);
    mpm::QuadSlicerDesc blade;
    blade.halfLength = 0.015f;
    blade.width = 0.04f;
    blade.halfThickness = 0.0002f;
    blade.pose.position = {0.f, 0.f, 0.f};  // the edge at the body's centre height
    const mpm::SlicerId slicer = coupler.addSlicer(&scalpel, blade);
    mpm::Vec3f frameImpulse{0.f, 0.f, 0.f};  // the tissue's impulse on the blade over a frame
    coupler.setUserTickCallback([&](float dt) {
      motion.time += dt;
      frameImpulse += scene.slicerImpulse(slicer).linear;
    });

    std::printf("cutting (%s, dx %.1f mm): %zu tissue particles, G_c %.0f J/m^2\n", solverName.c_str(), dx * 1e3,
                scene.particleCount(), toughness);
    mpm::io::Camera camera;
    camera.eye = {0.07f, 0.17f, 0.13f};
    camera.target = {0.f, 0.02f, 0.f};
    camera.width = 800;
    camera.height = 560;
    camera.fovYDegrees = 35.f;
    mpm::io::SplatRenderer renderer(camera);
    renderer.setGround(0.f, 0.1f);
    // and along the cut from the end where it starts, low: the slot's depth
    mpm::io::Camera endCamera = camera;
    endCamera.eye = {-0.17f, 0.08f, 0.04f};
    endCamera.target = {0.f, 0.02f, 0.f};
    mpm::io::SplatRenderer endRenderer(endCamera);
    endRenderer.setGround(0.f, 0.1f);
    std::ofstream csv(out + "/force.csv");
    csv << "time_s,lead_x_m,edge_y_m,force_x_N,force_y_N,force_z_N\n";
    const int frames = (int)std::ceil(script.t4 * 60) + 30;
    std::vector<mpm::Vec3f> x, near, far, steel;
    double peak = 0, steady = 0;
    int steadySamples = 0;
    mpm::io::ProgressBar progress("cutting", frames);
    char name[64];
    for (int f = 0; f <= frames; ++f) {
      mpm::Vec3f force{0.f, 0.f, 0.f};
      if (f > 0) {
        frameImpulse = {0.f, 0.f, 0.f};
        world.stepSimulation(1.f / 60, 10, 1.f / 240);
        coupler.rethrowError();
        force = 60.f * frameImpulse;  // averaged over the frame
      }
      float lead, edge;
      script.at(motion.time, lead, edge);
      csv << scene.time() << "," << lead << "," << edge << "," << force.x << "," << force.y << "," << force.z << "\n";
      peak = std::max(peak, (double)std::fabs(force.x));
      // steady: moving right at full speed through the middle of the cut (the force on the
      // blade points against its motion, -x)
      if (motion.time > 1.25 && motion.time < 1.55) {
        steady -= force.x;
        ++steadySamples;
      }
      if (f % pngEvery == 0 || f == frames) {
        scene.readPositions(tissue, x);
        near.clear();
        far.clear();
        for (const mpm::Vec3f& p : x) (p.z < 0.f ? near : far).push_back(p);
        steel.clear();
        for (int i = 0; i <= 30; ++i)
          for (int j = 0; j <= 40; ++j)
            steel.push_back({lead - 0.03f * i / 30.f, edge + 0.04f * j / 40.f, 0.f});
        renderer.clear();
        renderer.addParticles(near, 0.3f * dx, {215, 110, 105});
        renderer.addParticles(far, 0.3f * dx, {235, 150, 130});
        if (edge < kHeight + 0.02f) renderer.addParticles(steel, 0.0006f, {170, 175, 190});
        std::snprintf(name, sizeof name, "/frame_%04d.png", f);
        renderer.writePng(out + name);
        if (f == frames) {
          endRenderer.addParticles(near, 0.3f * dx, {215, 110, 105});
          endRenderer.addParticles(far, 0.3f * dx, {235, 150, 130});
          endRenderer.writePng(out + "/cut_end_view.png");
        }
      }
      progress.update(f);
    }
    progress.finish();
    steady /= std::max(steadySamples, 1);

    // the cut: in the region the edge passed (leading end's path, above the first depth)
    scene.readPositions(tissue, x);
    const float top = kHeight - kFirstDepth;
    float nearMax = -1.f, farMin = 1.f;
    for (const mpm::Vec3f& p : x) {
      if (p.x < kStartX - 0.03f + 0.005f || p.x > kEndX - 0.005f || p.y < top + 0.003f) continue;
      if (p.z < 0.f) nearMax = std::max(nearMax, p.z);
      else farMin = std::min(farMin, p.z);
    }
    const int n = pieces(x, 0.75f * dx);
    std::ofstream summary(out + "/summary.txt");
    char line[512];
    std::snprintf(line, sizeof line,
                  "solver %s, dx %.1f mm, %zu particles, G_c %.0f J/m^2\n"
                  "pieces after the cut: %d (the cut is partial: the block stays one piece below it)\n"
                  "cut length %.1f mm along x, depth %.1f then %.1f mm\n"
                  "gap across the cut after the blade left: %.2f mm\n"
                  "cutting force against the motion: peak %.3f N, steady %.3f N (G_c x depth = %.3f N)\n",
                  solverName.c_str(), dx * 1e3, scene.particleCount(), toughness, n, (kEndX - kStartX + 0.03f) * 1e3,
                  kFirstDepth * 1e3, kSecondDepth * 1e3, (farMin - nearMax) * 1e3, peak, steady,
                  toughness * kFirstDepth);
    summary << line;
    std::printf("%s", line);
    world.removeRigidBody(&scalpel);
    world.removeRigidBody(&ground);
    std::printf("frames, force.csv and summary.txt in %s/\n", out.c_str());
  } catch (const mpm::Error& e) {
    std::fprintf(stderr, "cutting: %s\n", e.what());
    return 1;
  }
  return 0;
}
