// Cutting demo: runs assets/scenes/cutting.json: a scalpel, a kinematic Bullet body coupled
// as a slicer, goes down into a block of tissue bonded to the ground at its base, moves
// right through it, goes down again to open the cut deeper, and is withdrawn. The tissue
// resists with its fracture toughness (liver, 160 J/m^2). Writes the file's frames (PNG,
// PLY), frames.csv, force.csv (the force on the scalpel over time), a view along the cut
// from its start (cut_end_view.png, the two sides in two shades) and summary.txt: the
// pieces the block is in, the cut's gap, its length and depth, the peak and the steady
// cutting force.
#include <BulletDynamics/Featherstone/btMultiBodyDynamicsWorld.h>
#include <CLI/CLI.hpp>
#include <btBulletDynamicsCommon.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <numeric>
#include <string>
#include <vector>

#include "../scene_runner.h"

namespace {

// The file's block (12 x 4 x 6 cm on the ground, the cut along x in the plane z = 0) and
// the scalpel's path: its leading end from x = -35 to 35 mm, 15 then 25 mm below the top.
constexpr float kHeight = 0.04f, kFirstDepth = 0.015f, kSecondDepth = 0.025f;
constexpr float kStartX = -0.035f, kEndX = 0.035f, kHalfLength = 0.015f;

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
  std::string scenePath = MPM_ASSETS_DIR "/scenes/cutting.json", solverName;
  demo::SceneOptions options;
  options.out = "out/cutting";
  float dx = 0.f, toughness = -1.f;
  app.add_option("--scene", scenePath, "the scene file");
  options.add(app);
  app.add_option("--solver", solverName, "MlsMpm, StandardMpm or PbMpm (default: the file's)")
      ->check(CLI::IsMember({"MlsMpm", "StandardMpm", "PbMpm"}));
  app.add_option("--dx", dx, "grid cell size [m] (default: the file's)")->check(CLI::PositiveNumber);
  app.add_option("--toughness", toughness, "the block's fracture toughness G_c [J/m^2] (default: the file's)")
      ->check(CLI::NonNegativeNumber);
  CLI11_PARSE(app, argc, argv);

  try {
    std::vector<std::string> overrides = options.overrides();
    if (!solverName.empty()) overrides.push_back("{\"settings\": {\"solver\": \"" + solverName + "\"}}");
    if (dx > 0.f) overrides.push_back("{\"settings\": {\"dx\": " + std::to_string(dx) + "}}");
    if (toughness >= 0.f)
      overrides.push_back(R"({"objects": [{"name": "block", "material": {"fractureToughness": )" + std::to_string(toughness) +
                          "}}]}");
    auto loaded = mpm::bullet::LoadedScene::fromFile(scenePath, overrides);
    mpm::Scene& scene = loaded->scene();
    const mpm::ParticleObjectId tissue = loaded->object("block");
    const btRigidBody* scalpel = loaded->body("scalpel");
    const float dxUsed = scene.settings().dx;
    const float toughness = loaded->material("block").fractureToughness;
    std::printf("cutting (dx %.1f mm): %zu tissue particles, G_c %.0f J/m^2\n", dxUsed * 1e3, scene.particleCount(),
                toughness);
    std::filesystem::create_directories(options.out);
    std::ofstream csv(options.out + "/force.csv");
    csv << "time_s,lead_x_m,edge_y_m,force_x_N,force_y_N,force_z_N\n";
    double peak = 0, steady = 0;
    int steadySamples = 0;
    demo::runFrames(*loaded, options.out, loaded->frameCount(), "cutting", [&] {
      const btVector3 force = loaded->frame() == 0 ? btVector3(0, 0, 0) : loaded->bodyForce("scalpel");
      const btVector3 at = scalpel->getCenterOfMassPosition();  // the blade's middle, its edge
      csv << scene.time() << "," << at.x() + kHalfLength << "," << at.y() << "," << force.x() << "," << force.y()
          << "," << force.z() << "\n";
      peak = std::max(peak, (double)std::fabs(force.x()));
      // steady: moving right at full speed through the middle of the cut (the force on the
      // blade points against its motion, -x)
      if (loaded->bulletTime() > 1.25 && loaded->bulletTime() < 1.55) {
        steady -= force.x();
        ++steadySamples;
      }
    });
    steady /= std::max(steadySamples, 1);

    // the cut: in the region the edge passed (leading end's path, above the first depth)
    std::vector<mpm::Vec3f> x, near, far;
    scene.readPositions(tissue, x);
    const float top = kHeight - kFirstDepth;
    float nearMax = -1.f, farMin = 1.f;
    for (const mpm::Vec3f& p : x) {
      (p.z < 0.f ? near : far).push_back(p);
      if (p.x < kStartX - 2 * kHalfLength + 0.005f || p.x > kEndX - 0.005f || p.y < top + 0.003f) continue;
      if (p.z < 0.f) nearMax = std::max(nearMax, p.z);
      else farMin = std::min(farMin, p.z);
    }
    // along the cut from the end where it starts, low: the slot's depth
    mpm::io::Camera endCamera;
    endCamera.eye = {-0.17f, 0.08f, 0.04f};
    endCamera.target = {0.f, 0.02f, 0.f};
    endCamera.width = 800;
    endCamera.height = 560;
    endCamera.fovYDegrees = 35.f;
    mpm::io::SplatRenderer endView(endCamera);
    endView.setGround(0.f, 0.1f);
    endView.addParticles(near, 0.3f * dxUsed, {215, 110, 105});
    endView.addParticles(far, 0.3f * dxUsed, {235, 150, 130});
    endView.writePng(options.out + "/cut_end_view.png");

    const int n = pieces(x, 0.75f * dxUsed);
    char line[512];
    std::snprintf(line, sizeof line,
                  "dx %.1f mm, %zu particles, G_c %.0f J/m^2\n"
                  "pieces after the cut: %d (the cut is partial: the block stays one piece below it)\n"
                  "cut length %.1f mm along x, depth %.1f then %.1f mm\n"
                  "gap across the cut after the blade left: %.2f mm\n"
                  "cutting force against the motion: peak %.3f N, steady %.3f N (G_c x depth = %.3f N)\n",
                  dxUsed * 1e3, scene.particleCount(), toughness, n, (kEndX - kStartX + 2 * kHalfLength) * 1e3,
                  kFirstDepth * 1e3, kSecondDepth * 1e3, (farMin - nearMax) * 1e3, peak, steady,
                  toughness * kFirstDepth);
    std::ofstream(options.out + "/summary.txt") << line;
    std::printf("%s", line);
    std::printf("frames, force.csv and summary.txt in %s/\n", options.out.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "cutting: %s\n", e.what());
    return 1;
  }
  return 0;
}
