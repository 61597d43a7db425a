// Suturing demo (CRESSim-MPM, Fig. 12): two soft tissue blocks side by side with a gap, each
// bonded to the ground at its base. A curved needle (a dynamic Bullet body driven like a
// hand holding a needle holder, coupled as an ArcDesc) turns about its axis: in through
// the top of block 1, under the gap, out through the top of block 2, on until its tail
// (and the thread pinned to it) has come through; then it is pulled up and back over the
// wound at 1 cm/s until the wound's edges meet (the gap 2 mm) or the thread carries 1 N at
// the needle's eye, as a surgeon stops, and held there. The
// thread (a Featherstone chain coupled as LineSegmentsDesc, both ways, with the added mass
// of the tissue it holds) starts at a fixed knot over the wound, so pulling tightens it
// through both bites and draws the wound together. Writes PNGs (cutaway: the front half of
// the tissue is not drawn, so the needle and thread inside show), suturing.csv (per frame:
// time, needle force, gap across the wound, thread tension at the needle's eye, wall time)
// and summary.txt.
//
// Status (dx 2.5 mm, 12 s, 240 frames, 166 s on 2 idle cores; MLS-MPM): the tip breaks
// into block 1 at 1.05 s, the needle goes through both bites (peak force 0.137 N) and draws
// the thread after it; pulled up over the wound the thread, held by the tissue
// (ThreadCoupling::addedMass) and its eye pinned within 12 um (one frame 0.35 mm), draws the
// gap from 7.25 mm to 1.88 mm at 10.55 s (0.77 N), where the pull stops and holds (1.91 mm at
// the end; another build's rounding held at 10.20 s on 0.99 N and 2.61 mm; docs/benchmarks.md, Suturing). --solver pb advances PB-MPM every 6 ticks
// (--tissue-interval); --one-way and --no-added-mass show the couplings without the hold.
#include <CLI/CLI.hpp>
#include <btBulletDynamicsCommon.h>
#include <BulletDynamics/Featherstone/btMultiBody.h>
#include <BulletDynamics/Featherstone/btMultiBodyConstraintSolver.h>
#include <BulletDynamics/Featherstone/btMultiBodyDynamicsWorld.h>
#include <BulletDynamics/Featherstone/btMultiBodyPoint2Point.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "mpm/output.h"
#include "mpm/scene.h"
#include "mpm_bullet/coupler.h"
#include "mpm_bullet/suture.h"

namespace {

constexpr float kPi = 3.14159265f;
// The blocks: 3 x 2 x 3 cm each, a 6 mm gap between them across x = 0, tops at y = 2 cm.
constexpr float kBlockW = 0.03f, kHeight = 0.02f, kDepth = 0.03f, kGap = 0.006f;
// The needle: a half circle of 12 mm turning about its centre, 6 mm above the tops: its
// arc enters block 1 10.4 mm left of the gap's middle, passes 6 mm under the tops and
// leaves block 2 as far right.
constexpr float kNeedleR = 0.012f, kAbove = 0.006f;
// The thread: 7.5 cm (in 30 segments of one cell, --thread-segments), from a knot over
// the wound.
constexpr float kThreadLength = 0.075f;

/// The needle's script: it waits, then turns about its centre through both bites until the
/// tail is out (0.32 s to 5 s); then it is pulled up and back
/// over the wound at `pullSpeed`, as a hand draws a stitch tight, until the thread carries
/// `holdTension` at the needle's eye or the gap (seen once a frame) is down to `closeGap`;
/// from then on the needle is held where it is. Pulled on, the thread cuts out through the
/// top of a bite and the wound opens again.
struct Script {
  float turnStart = 0.32f, turnStop = 5.f;  // [s]
  float turnAngle = 365.f * kPi / 180.f;  // the thread's eye (24 degrees behind the tail) out
  mpm::Vec3f centre0{0.f, kHeight + kAbove, 0.f};
  // the pull's path: up, and back over the wound so the thread from bite 2 runs toward the
  // middle (drawn away to +x it drew block 2's edge away)
  mpm::Vec3f pull{-0.015f, 0.06f, 0.f};
  float pullSpeed = 0.01f;  // [m/s]
  float holdTension = 1.f;  // [N]
  float pulled = 0.f;       // [m] along the pull's path so far
  bool pulling = false;     // in this tick
  float closeGap = 0.002f;  // [m]
  bool closed = false;      // the gap has come down to closeGap (set once a frame)
  bool held = false;        // the tension has reached holdTension or the wound has closed

  static float ramp(float a) {
    a = std::clamp(a, 0.f, 1.f);
    return a * a * (3 - 2 * a);
  }
  float turnAt(float t) const { return turnAngle * ramp((t - turnStart) / (turnStop - turnStart)); }
  /// Moves the pull on over a tick ending at t, given the thread's tension at the eye.
  void advance(float t, float dt, float tension) {
    const float length = mpm::norm(pull);
    held = held || (t > turnStop && (tension >= holdTension || closed));
    pulling = t > turnStop && !held && pulled < length;
    if (pulling) pulled = std::min(pulled + pullSpeed * dt, length);
  }
  btTransform pose(float t) const {
    const mpm::Vec3f c = centre0 + (pulled / mpm::norm(pull)) * pull;
    return btTransform(btQuaternion(btVector3(0, 0, 1), turnAt(t)), btVector3(c.x, c.y, c.z));
  }
  /// Velocities: the turn's by central difference, the pull's while it moves.
  void velocity(float t, btVector3& v, btVector3& w) const {
    const float h = 1e-3f;
    const mpm::Vec3f d = (pulling ? pullSpeed / mpm::norm(pull) : 0.f) * pull;
    v = btVector3(d.x, d.y, d.z);
    w = btVector3(0, 0, (turnAt(t + h) - turnAt(t - h)) / (2 * h));
  }
};

/// Points along the needle's arc and the thread (for drawing), world frame.
std::vector<mpm::Vec3f> arcPoints(const btTransform& t, float r, float a0, float a1, int n) {
  std::vector<mpm::Vec3f> out;
  for (int i = 0; i <= n; ++i) {
    const float a = a0 + (a1 - a0) * i / n;
    const btVector3 p = t * btVector3(r * std::cos(a), r * std::sin(a), 0);
    out.push_back({p.x(), p.y(), p.z()});
  }
  return out;
}
std::vector<mpm::Vec3f> polylinePoints(const std::vector<btVector3>& p, float spacing) {
  std::vector<mpm::Vec3f> out;
  for (size_t k = 0; k + 1 < p.size(); ++k) {
    const int n = std::max(1, (int)std::ceil((p[k + 1] - p[k]).length() / spacing));
    for (int i = 0; i < n; ++i) {
      const btVector3 q = p[k] + (p[k + 1] - p[k]) * ((float)i / n);
      out.push_back({q.x(), q.y(), q.z()});
    }
  }
  out.push_back({p.back().x(), p.back().y(), p.back().z()});
  return out;
}

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
  std::string out = "out/suturing", solverName = "mls";
  int frames = 240, pngEvery = 8, threads = 0;
  float seconds = 12.f, dx = 0.0025f, punctureForce = 0.03f, threadDensity = 5e-5f, eyeBehind = 0.005f;
  bool oneWay = false, noAddedMass = false;
  int threadSegments = 30;
  float maxForce = 5.f;
  // Bullet's ticks per second: the added-mass coupling pushes links of about 5e-5 kg with
  // the tissue's elastic force explicitly, which wants ticks this short (at 1/960 s the
  // pulled stitch of tests/test_suturing_bullet.cpp blew up within 0.03 s); the MPM takes
  // about one substep per tick here anyway
  float tickRate = 9600.f;
  app.add_option("--out", out, "output folder");
  app.add_option("--frames", frames, "frames over the run (a CSV row each)")->check(CLI::PositiveNumber);
  app.add_option("--seconds", seconds, "simulated length of the run [s]")->check(CLI::PositiveNumber);
  app.add_option("--solver", solverName, "mls (MLS-MPM) or pb (position-based MPM)");
  app.add_option("--png-every", pngEvery, "write a PNG every N frames")->check(CLI::PositiveNumber);
  app.add_option("--dx", dx, "grid cell size [m]")->check(CLI::PositiveNumber);
  app.add_option("--threads", threads, "CPU threads (0 = all)")->check(CLI::NonNegativeNumber);
  // 0 by default: with 0.3 N the tip never broke in here (Scene::tipInside stayed false
  // while the force on the needle reached 4 N), so the needle went through as a blunt tool
  app.add_option("--puncture-force", punctureForce, "the needle's ArcDesc::punctureForce [N]")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--thread-density", threadDensity, "the thread's linear density [kg/m] (3-0 suture: 5e-5)")
      ->check(CLI::PositiveNumber);
  app.add_flag("--one-way", oneWay, "the thread drags the tissue, the tissue does not hold it (no impulses to its links)");
  app.add_flag("--no-added-mass", noAddedMass,
               "two-way without ThreadCoupling::addedMass: each link gets its segment's own momentum change only");
  app.add_option("--eye-behind", eyeBehind, "the thread's eye behind the needle's tail, along the arc [m]")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--thread-segments", threadSegments, "links of the thread")->check(CLI::PositiveNumber);
  app.add_option("--tick-rate", tickRate, "Bullet's ticks per second")->check(CLI::PositiveNumber);
  app.add_option("--max-force", maxForce, "the needle driver's force limit [N]")->check(CLI::PositiveNumber);
  // PB-MPM's stiffness is its iterations per unit time: advanced at every 1/9600 s tick the
  // blocks are nearly rigid; every 6 ticks it carries MLS-MPM's tension at the same pull
  // (tests/test_suturing_bullet.cpp, PullingTheStitch)
  int tissueInterval = 0;
  app.add_option("--tissue-interval", tissueInterval,
                 "Bullet ticks per tissue advance (Coupler::setTissueInterval; 0: 1 for mls, 6 for pb)")
      ->check(CLI::NonNegativeNumber);
  float pullSpeed = 0.01f, holdTension = 1.f;
  app.add_option("--pull-speed", pullSpeed, "the needle's speed when pulled after the bites [m/s]")
      ->check(CLI::PositiveNumber);
  float closeGap = 0.002f;
  app.add_option("--close-gap", closeGap, "the pull stops once the gap is down to this [m]")->check(CLI::NonNegativeNumber);
  app.add_option("--hold-tension", holdTension, "the pull stops once the thread carries this at the eye [N]")
      ->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);
  const float kTick = 1.f / tickRate;
  const std::map<std::string, mpm::SolverType> solvers = {{"mls", mpm::SolverType::MlsMpm},
                                                          {"pb", mpm::SolverType::PbMpm}};
  if (!solvers.count(solverName)) {
    std::fprintf(stderr, "suturing: --solver %s: use mls or pb\n", solverName.c_str());
    return 2;
  }

  try {
    std::filesystem::create_directories(out);
    // Bullet: a multibody world (the thread is a Featherstone chain), 50 solver iterations
    btDefaultCollisionConfiguration config;
    btCollisionDispatcher dispatcher(&config);
    btDbvtBroadphase broadphase;
    btMultiBodyConstraintSolver solver;
    btMultiBodyDynamicsWorld world(&dispatcher, &broadphase, &solver, &config);
    // no gravity in Bullet: the driver cancels the needle's anyway, and the thread (made
    // heavy for the coupling's sake, below) would sag onto the tissue where the needle goes
    // in; the tissue feels gravity in the scene (SceneSettings::gravity)
    world.setGravity(btVector3(0, 0, 0));
    world.getSolverInfo().m_numIterations = 50;
    btBoxShape groundShape(btVector3(0.06f, 0.005f, 0.03f));
    btRigidBody ground(0.f, nullptr, &groundShape);
    ground.setWorldTransform(btTransform(btQuaternion::getIdentity(), btVector3(0, -0.005f, 0)));
    world.addRigidBody(&ground, 1, 4);  // holds the tissue (coupled) and the thread (Bullet)

    mpm::SceneSettings settings;
    settings.domain = {{-0.075f, -0.012f, -0.045f}, {0.06f, 0.1f, 0.03f}};
    settings.dx = dx;
    settings.solver = solvers.at(solverName);
    settings.backend = mpm::Backend::Cpu;
    settings.cpuThreads = threads;
    mpm::Scene scene(settings);
    mpm::ParticleObjectDesc block;
    block.halfExtents = {0.5f * kBlockW, 0.5f * kHeight, 0.5f * kDepth};
    block.material = {mpm::MaterialModel::NeoHookeanDecoupled, 4e4f, 0.4f, 1060.f, 200.f};  // E, nu, rho, G_c
    block.center = {-0.5f * kGap - 0.5f * kBlockW, 0.5f * kHeight, 0.f};
    const mpm::ParticleObjectId left = scene.addParticleObject(block);
    block.center = {0.5f * kGap + 0.5f * kBlockW, 0.5f * kHeight, 0.f};
    const mpm::ParticleObjectId right = scene.addParticleObject(block);

    mpm::bullet::Coupler coupler(&world, scene);
    mpm::bullet::CouplingOptions held;
    held.contact.mode = mpm::ContactMode::Bonded;  // each block's base glued down
    coupler.addRigidBody(&ground, held);

    // the needle: the body's centre of mass at the arc's centre; its mass and inertia are
    // the needle's with the holder's (100 g, 1e-4 kg m^2): the driver's steady error under
    // a force F is F dt tau / m (3 N: 0.16 mm), and the needle is kinematic in the scene,
    // so its coupling is explicit and wants a body heavier than the tissue it drags
    Script script;
    script.pullSpeed = pullSpeed;
    script.holdTension = holdTension;
    script.closeGap = closeGap;
    const float mass = 0.1f;
    btSphereShape needleShape(0.001f);
    btRigidBody::btRigidBodyConstructionInfo info(mass, nullptr, &needleShape, btVector3(1e-4f, 1e-4f, 1e-4f));
    info.m_startWorldTransform = script.pose(0.f);
    btRigidBody needle(info);
    needle.setCollisionFlags(needle.getCollisionFlags() | btCollisionObject::CF_NO_CONTACT_RESPONSE);
    world.addRigidBody(&needle, 2, 0);
    mpm::ArcDesc arc;
    arc.radius = kNeedleR;
    arc.startAngle = 0.f;  // the tail, where the thread is fixed
    arc.endAngle = kPi;    // the tip
    arc.wireRadius = 0.25e-3f;
    arc.friction = 0.2f;
    arc.punctureForce = punctureForce;
    const mpm::CurveId needleCurve = coupler.addNeedle(&needle, arc);
    mpm::bullet::NeedleDriveLimits limits;
    limits.maxForce = maxForce;
    limits.maxTorque = maxForce * kNeedleR;  // the force limit at the needle's radius
    limits.timeConstant = 0.005f;
    mpm::bullet::NeedleDriver driver(&needle, limits);

    // the thread: its knot end Bullet's fixed base, 4 mm above the wound and 6 mm behind
    // the stitch's plane (a knot tied over the wound: the thread from it into bite 1 and
    // out of bite 2 to the needle draws both edges toward the middle when pulled; a knot
    // beyond block 1 drew block 1 away), its other end pinned at the needle's eye. It
    // starts up and out of the needle's way: from the eye up, back (-z), across and down
    // to the knot, in the air (a thread lying in the tissue's contact band while the
    // needle pulled it blew up)
    mpm::bullet::SutureThreadDesc td;
    td.length = kThreadLength;
    td.segments = threadSegments;
    td.radius = 0.15e-3f;
    td.linearDensity = threadDensity;
    td.damping = 1.f;  // air drag, 1/s
    td.fixedBase = true;
    td.maxTension = 10.f;  // half a 3-0 suture's breaking load, at this tick (suture.h)
    td.tick = kTick;
    td.collisionGroup = 4;  // it touches the tissue through the coupler, the ground in Bullet
    td.collisionMask = 1;
    // fixed to the needle 5 mm (two cells) behind its tail on the arc's circle, as a
    // swaged eye: a thread segment sharing grid nodes with the needle takes the needle's
    // drag in one tick and blew up (coupler.h, addThread)
    const float eye = -eyeBehind / kNeedleR;
    const btVector3 eyeInNeedle(kNeedleR * std::cos(eye), kNeedleR * std::sin(eye), 0);
    const btVector3 eyeAt = script.pose(0.f) * eyeInNeedle;
    const float up = kHeight + 0.014f, back = -0.024f;
    std::vector<btVector3> path = mpm::bullet::threadPointsAlong({eyeAt, btVector3(eyeAt.x(), up, 0), btVector3(eyeAt.x(), up, back),
                                            btVector3(-0.003f, up, back), btVector3(-0.003f, up, -0.006f),
                                            btVector3(-0.003f, kHeight + 0.004f, -0.006f)},
                                           kThreadLength / threadSegments, threadSegments);
    std::reverse(path.begin(), path.end());  // knot first: the chain's fixed base
    td.start = path[0];
    td.direction = path[1] - path[0];
    btMultiBody* thread = mpm::bullet::makeSutureThread(&world, td);
    mpm::bullet::layThreadAlong(thread, path);
    const btVector3 knotAt = path[0];
    std::printf("thread: knot at (%.1f, %.1f, %.1f) mm, eye at (%.1f, %.1f, %.1f) mm\n", 1e3f * knotAt.x(),
                1e3f * knotAt.y(), 1e3f * knotAt.z(), 1e3f * eyeAt.x(), 1e3f * eyeAt.y(), 1e3f * eyeAt.z());
    const int eyePoint = threadSegments;
    // the thread's tension at its free end, the eye
    btMultiBodyPoint2Point* eyePin = mpm::bullet::pinThreadPoint(&world, thread, eyePoint, &needle, eyeInNeedle);
    mpm::bullet::ThreadCoupling tc;
    tc.friction = 0.1f;
    tc.dynamic = !oneWay;
    tc.addedMass = !oneWay && !noAddedMass;
    coupler.addThread(thread, tc);
    coupler.setTissueInterval(tissueInterval > 0 ? tissueInterval : settings.solver == mpm::SolverType::PbMpm ? 6 : 1);

    // per tick: the driver before the coupling; after it, the frame's sums
    btVector3 needleImpulse(0, 0, 0), eyeImpulse(0, 0, 0);
    float eyeTension = 0.f;  // [N] low-passed over 20 ms, as a hand feels it
    double bulletTime = 0;  // Bullet's clock: the scene's runs ahead within a tissue interval
    coupler.setPreTickCallback([&](float dt) {
      const float t = (float)bulletTime + dt;  // where the needle should be after this tick
      script.advance(t, dt, eyeTension);
      btVector3 v, w;
      script.velocity(t, v, w);
      driver.setTarget(script.pose(t), v, w);
      driver.tick(dt);
    });
    coupler.setUserTickCallback([&](float dt) {
      bulletTime += dt;
      if (coupler.tissueAdvanced()) {  // the advance's impulse, over the interval's ticks
        const mpm::ShapeImpulse J = scene.curveImpulse(needleCurve);
        needleImpulse += btVector3(J.linear.x, J.linear.y, J.linear.z);
      }
      const btVector3 f = mpm::bullet::pinForce(eyePin, dt);
      eyeTension += (f.length() - eyeTension) * std::min(dt / 0.02f, 1.f);
      eyeImpulse += f * dt;
    });

    std::printf("suturing (%s, dx %.1f mm): %zu tissue particles, %.1f s in %d frames, Bullet tick %.3f ms, MPM substep %.3f ms\n",
                solverName.c_str(), dx * 1e3, scene.particleCount(), seconds, frames, kTick * 1e3, scene.maxSubstep() * 1e3);
    mpm::io::Camera camera;
    camera.eye = {0.025f, 0.07f, 0.11f};
    camera.target = {0.f, 0.015f, 0.f};
    camera.width = 800;
    camera.height = 560;
    camera.fovYDegrees = 35.f;
    mpm::io::SplatRenderer renderer(camera);
    renderer.setGround(0.f, 0.07f);
    std::ofstream csv(out + "/suturing.csv");
    csv << "time_s,needle_force_N,gap_mm,thread_tension_N,eye_pin_gap_mm,tip_inside,needle_turn_deg,driver_force_N,wall_s\n";
    const float frameTime = seconds / frames;
    const int ticksPerFrame = std::max(1, (int)std::lround(frameTime / kTick));
    std::vector<mpm::Vec3f> a, b, nearA, nearB;
    scene.readPositions(left, a);
    scene.readPositions(right, b);
    const float gap0 = gapWidth(a, b, kHeight);
    float gapMin = gap0, peakForce = 0.f, peakTension = 0.f, finalTension = 0.f;
    float heldAt = -1.f, heldGap = 0.f, heldTension = 0.f;  // where the pull stopped
    double wallTotal = 0;
    mpm::io::ProgressBar progress("suturing", frames);
    char name[64];
    for (int f = 0; f <= frames; ++f) {
      const auto start = std::chrono::steady_clock::now();
      btVector3 force(0, 0, 0), tension(0, 0, 0);
      if (f > 0) {
        needleImpulse = eyeImpulse = btVector3(0, 0, 0);
        world.stepSimulation(ticksPerFrame * kTick, ticksPerFrame + 1, kTick);
        coupler.rethrowError();
        force = needleImpulse / (ticksPerFrame * kTick);  // averaged over the frame
        tension = eyeImpulse / (ticksPerFrame * kTick);
      }
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      wallTotal += wall;
      scene.readPositions(left, a);
      scene.readPositions(right, b);
      const float gap = gapWidth(a, b, kHeight);
      const btTransform pose = needle.getCenterOfMassTransform();
      const float turn = 2.f * std::atan2(pose.getRotation().z(), pose.getRotation().w()) * 180.f / kPi;
      // how far the eye's pin is open
      const std::vector<btVector3> tp = mpm::bullet::threadPoints(thread);
      const float eyeGap = (tp[(size_t)eyePoint] - pose * eyeInNeedle).length();
      csv << scene.time() << "," << force.length() << "," << gap * 1e3 << "," << tension.length() << ","
          << eyeGap * 1e3 << "," << (scene.tipInside(needleCurve) ? 1 : 0) << "," << turn << ","
          << driver.lastForce().length() << "," << wall << std::endl;
      gapMin = std::min(gapMin, gap);
      script.closed = script.closed || (scene.time() > script.turnStop && gap <= script.closeGap);
      if (script.held && heldAt < 0.f) {
        heldAt = (float)scene.time();
        heldGap = gap;
        heldTension = (float)tension.length();
      }
      peakForce = std::max(peakForce, (float)force.length());
      peakTension = std::max(peakTension, (float)tension.length());
      finalTension = (float)tension.length();
      if (f % pngEvery == 0 || f == frames) {
        nearA.clear();
        nearB.clear();
        for (const mpm::Vec3f& p : a)
          if (p.z < 0.f) nearA.push_back(p);  // cutaway: the half toward the camera is left out
        for (const mpm::Vec3f& p : b)
          if (p.z < 0.f) nearB.push_back(p);
        renderer.clear();
        renderer.addParticles(nearA, 0.3f * dx, {215, 110, 105});
        renderer.addParticles(nearB, 0.3f * dx, {235, 150, 130});
        renderer.addParticles(arcPoints(pose, kNeedleR, arc.startAngle, arc.endAngle, 120), 0.0005f, {90, 95, 120});
        renderer.addParticles(polylinePoints(mpm::bullet::threadPoints(thread), 0.0004f), 0.0004f, {40, 90, 200});
        renderer.addParticles({{knotAt.x(), knotAt.y(), knotAt.z()}}, 0.0015f, {30, 30, 30});
        std::snprintf(name, sizeof name, "/frame_%04d.png", f);
        renderer.writePng(out + name);
      }
      progress.update(f);
    }
    progress.finish();

    std::ofstream summary(out + "/summary.txt");
    char line[768];
    std::snprintf(line, sizeof line,
                  "solver %s, dx %.1f mm, %zu particles, %.1f s simulated in %.0f s (%.2f s per frame)\n"
                  "gap across the wound (top 4 mm, |z| < 6 mm): %.2f mm at the start, %.2f mm at the end, %.2f mm at "
                  "the least\n"
                  "needle force: peak %.3f N (puncture force %.2f N); thread tension at the needle's eye: peak %.3f N, "
                  "at the end %.3f N\n"
                  "the pull held at %.2f s (gap %.2f mm, tension %.3f N over the frame; -1: never)\n",
                  solverName.c_str(), dx * 1e3, scene.particleCount(), seconds, wallTotal, wallTotal / frames,
                  gap0 * 1e3, gapWidth(a, b, kHeight) * 1e3, gapMin * 1e3, peakForce, arc.punctureForce, peakTension,
                  finalTension, heldAt, heldGap * 1e3, heldTension);
    summary << line;
    std::printf("%s", line);
    coupler.removeThread(thread);
    coupler.remove(&needle);
    mpm::bullet::destroySutureThread(&world, thread);
    world.removeRigidBody(&needle);
    world.removeRigidBody(&ground);
    std::printf("frames, suturing.csv and summary.txt in %s/\n", out.c_str());
  } catch (const mpm::Error& e) {
    std::fprintf(stderr, "suturing: %s\n", e.what());
    return 1;
  }
  return 0;
}
