// Suturing demo: runs assets/scenes/suturing.json (the scene: two tissue blocks with a gap,
// a curved needle turned through both and then drawn up and back over the wound, its
// thread from a knot over the wound; see the file's description). The hand pulls as a
// surgeon does, to a tension, and holds it: the needle's driver never pushes harder than
// --pull-force (NeedleDriveLimits::maxForce, the file's 0.8 N), so once the thread carries
// that the needle stops where the tissue balances it, and the wound's gap at the end is
// what the tissue and the thread make of that tension, not where a rule stopped the pull.
// Writes in --out the file's frames (PNG, PLY), frames.csv, suturing.csv (per frame: time,
// needle force, gap, thread tension at the eye, eye pin gap, tip inside, needle turn, wall
// time) and summary.txt.
//
// Status (dx 2.5 mm, 12 s, 240 frames, about 5 min on 2 cores; MLS-MPM): see docs/
// benchmarks.md for the measured gap and tension. --solver pb advances PB-MPM once every
// 6 Bullet ticks (world.tissueInterval); --one-way and --no-added-mass show the couplings
// without the tissue's hold on the thread; --set patches anything else in the file.
#include <BulletDynamics/Featherstone/btMultiBody.h>
#include <BulletDynamics/Featherstone/btMultiBodyPoint2Point.h>
#include <CLI/CLI.hpp>
#include <btBulletDynamicsCommon.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "../scene_runner.h"
#include "mpm_bullet/suture.h"

namespace {

/// The wound's gap: block 2's leftmost minus block 1's rightmost particle in the band
/// near the top (the top 4 mm) around the stitch's plane (|z| < 6 mm) [m].
float gapWidth(const std::vector<mpm::Vec3f>& left, const std::vector<mpm::Vec3f>& right, float top) {
  float l = -1.f, r = 1.f;
  for (const mpm::Vec3f& p : left)
    if (p.y > top - 0.004f && std::fabs(p.z) < 0.006f) l = std::max(l, p.x);
  for (const mpm::Vec3f& p : right)
    if (p.y > top - 0.004f && std::fabs(p.z) < 0.006f) r = std::min(r, p.x);
  return r - l;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"A needle and thread close a gap between two tissue blocks (Bullet + MPM curves)"};
  std::string scenePath = MPM_ASSETS_DIR "/scenes/suturing.json", solverName = "mls";
  demo::SceneOptions options;
  options.out = "out/suturing";
  float dx = 0.f, pullForce = 0.f;
  bool oneWay = false, noAddedMass = false;
  int frames = -1;
  app.add_option("--scene", scenePath, "the scene file");
  options.add(app);
  app.add_option("--frames", frames, "frames to run (default: the file's output.frames)")->check(CLI::PositiveNumber);
  app.add_option("--solver", solverName, "mls (MLS-MPM) or pb (position-based MPM, advanced every 6 ticks)")
      ->check(CLI::IsMember({"mls", "pb"}));
  app.add_option("--dx", dx, "grid cell size [m] (default: the file's)")->check(CLI::PositiveNumber);
  app.add_flag("--one-way", oneWay, "the thread drags the tissue, the tissue does not hold it (no impulses to its links)");
  app.add_flag("--no-added-mass", noAddedMass,
               "two-way without ThreadCoupling::addedMass: each link gets its segment's own momentum change only");
  app.add_option("--pull-force", pullForce, "the most the hand pulls the needle with [N] (default: the file's maxForce)")
      ->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);

  try {
    std::vector<std::string> overrides = options.overrides();
    // PB-MPM's stiffness is its iterations per unit time: advanced at every 1/9600 s tick the
    // blocks are nearly rigid; every 6 ticks it carries MLS-MPM's tension at the same pull
    // (tests/test_suturing_bullet.cpp, PullingTheStitch)
    if (solverName == "pb") overrides.push_back(R"({"settings": {"solver": "PbMpm"}, "world": {"tissueInterval": 6}})");
    if (dx > 0.f) overrides.push_back("{\"settings\": {\"dx\": " + std::to_string(dx) + "}}");
    if (oneWay || noAddedMass)
      overrides.push_back(std::string(R"({"threads": [{"name": "thread", "coupling": {"dynamic": )") +
                          (oneWay ? "false" : "true") + R"(, "addedMass": false}}]})");
    if (pullForce > 0.f)
      overrides.push_back(R"({"bodies": [{"name": "needle", "motion": {"limits": {"maxForce": )" +
                          std::to_string(pullForce) + "}}}]}");
    auto loaded = mpm::bullet::LoadedScene::fromFile(scenePath, overrides);
    mpm::Scene& scene = loaded->scene();
    const mpm::ParticleObjectId left = loaded->object("left"), right = loaded->object("right");
    btRigidBody* needle = loaded->body("needle");
    btMultiBody* thread = loaded->thread("thread");
    const int eyePoint = (int)mpm::bullet::threadPoints(thread).size() - 1;  // its last point, pinned at the eye
    btMultiBodyPoint2Point* eyePin = loaded->threadPin("thread", eyePoint);
    const btVector3 eyeInNeedle = eyePin->getPivotInB();
    const mpm::CurveId needleCurve = loaded->coupler().needleOf(needle);
    const float top = 0.02f;  // the blocks' tops [m]

    // the thread's pull at the eye, summed over each frame
    btVector3 eyeImpulse(0, 0, 0);
    loaded->setTickCallback([&](float dt) { eyeImpulse += mpm::bullet::pinForce(eyePin, dt) * dt; });

    if (frames < 0) frames = loaded->frameCount();
    const float dxUsed = scene.settings().dx, frameTime = loaded->frameTime();
    std::printf("suturing (%s, dx %.1f mm): %zu tissue particles, %.1f s in %d frames, Bullet tick %.3f ms, MPM substep %.3f ms\n",
                solverName.c_str(), dxUsed * 1e3, scene.particleCount(), frames * frameTime, frames,
                loaded->tick() * 1e3, scene.maxSubstep() * 1e3);
    std::filesystem::create_directories(options.out);
    std::ofstream csv(options.out + "/suturing.csv");
    csv << "time_s,needle_force_N,gap_mm,thread_tension_N,eye_pin_gap_mm,tip_inside,needle_turn_deg,wall_s\n";
    std::vector<mpm::Vec3f> a, b;
    scene.readPositions(left, a);
    scene.readPositions(right, b);
    const float gap0 = gapWidth(a, b, top);
    float gap = gap0, gapMin = gap0, peakForce = 0.f, peakTension = 0.f, tension = 0.f;
    float lastSecondTension = 0.f, lastSecondGap = 0.f;  // means over the last second
    int lastSecondFrames = 0;
    double wallTotal = 0;
    auto start = std::chrono::steady_clock::now();
    demo::runFrames(*loaded, options.out, frames, "suturing", [&] {
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      const bool first = loaded->frame() == 0;
      wallTotal += first ? 0 : wall;
      const float force = first ? 0.f : (float)loaded->bodyForce("needle").length();
      tension = first ? 0.f : (float)(eyeImpulse / frameTime).length();
      eyeImpulse = btVector3(0, 0, 0);
      scene.readPositions(left, a);
      scene.readPositions(right, b);
      gap = gapWidth(a, b, top);
      const btTransform pose = needle->getCenterOfMassTransform();
      const float turn = 2.f * std::atan2(pose.getRotation().z(), pose.getRotation().w()) * 180.f / 3.14159265f;
      const float eyeGap = (mpm::bullet::threadPoints(thread)[(size_t)eyePoint] - pose * eyeInNeedle).length();
      csv << scene.time() << "," << force << "," << gap * 1e3 << "," << tension << "," << eyeGap * 1e3 << ","
          << (scene.tipInside(needleCurve) ? 1 : 0) << "," << turn << "," << (first ? 0 : wall) << std::endl;
      gapMin = std::min(gapMin, gap);
      if (scene.time() > frames * frameTime - 1.0 + 1e-6) {
        lastSecondTension += tension;
        lastSecondGap += gap;
        ++lastSecondFrames;
      }
      peakForce = std::max(peakForce, force);
      peakTension = std::max(peakTension, tension);
      start = std::chrono::steady_clock::now();
    });

    const float n = (float)std::max(lastSecondFrames, 1);
    char line[768];
    std::snprintf(line, sizeof line,
                  "solver %s, dx %.1f mm, %zu particles, %.1f s simulated in %.0f s (%.2f s per frame)\n"
                  "gap across the wound (top 4 mm, |z| < 6 mm): %.2f mm at the start, %.2f mm at the end, %.2f mm at "
                  "the least, %.2f mm over the last second\n"
                  "needle force: peak %.3f N; thread tension at the needle's eye: peak %.3f N, at the end %.3f N, "
                  "%.3f N over the last second\n",
                  solverName.c_str(), dxUsed * 1e3, scene.particleCount(), frames * frameTime, wallTotal,
                  wallTotal / frames, gap0 * 1e3, gap * 1e3, gapMin * 1e3, lastSecondGap / n * 1e3, peakForce,
                  peakTension, tension, lastSecondTension / n);
    std::ofstream(options.out + "/summary.txt") << line;
    std::printf("%s", line);
    std::printf("frames, frames.csv, suturing.csv and summary.txt in %s/\n", options.out.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "suturing: %s\n", e.what());
    return 1;
  }
  return 0;
}
