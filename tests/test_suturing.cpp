// Suturing curves (CRESSim-MPM, section IV-C): a needle slides along itself through tissue but
// drags it sideways; its tip presses the surface in, breaks in, opens a track against the
// tissue's fracture toughness, and its shaft feels friction growing with the inserted
// length; threads drag tissue sideways too. Momentum the curves take balances the tissue's.
// CPU backend (the kernels are the CUDA ones).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "mpm/scene.h"
#include "shapes/shape_builder.h"
#include "tools/tool_builder.h"
#include "contact/contact_law.h"
#include "contact/push_out.h"
#include "wound_gap.h"

namespace mpm {
namespace {

constexpr float kPi = 3.14159265f;
constexpr float kDx = 0.0025f;
// The block: 4 x 2 x 1.25 cm, its base on y = 0 held by a bonded plate, its top at y = 2 cm.
const Vec3f kBlockHalf{0.02f, 0.01f, 0.00625f};
constexpr float kToughness = 25.f;   // G_c [J/m^2]
constexpr float kWireRadius = 0.25e-3f;
constexpr float kNeedleRadius = 0.02f;

SceneSettings settingsFor(SolverType solver) {
  SceneSettings s;
  s.domain.lower = {-0.04f, -0.02f, -0.02f};
  s.domain.upper = {0.04f, 0.06f, 0.02f};
  s.dx = kDx;
  s.gravity = {0.f, 0.f, 0.f};
  s.solver = solver;
  s.backend = Backend::Cpu;
  return s;
}

ParticleObjectDesc block() {
  ParticleObjectDesc d;
  d.center = {0.f, kBlockHalf.y, 0.f};
  d.halfExtents = kBlockHalf;
  d.material.youngsModulus = 3e4f;
  d.material.poissonRatio = 0.3f;
  d.material.density = 1000.f;
  d.material.fractureToughness = kToughness;
  return d;
}

using test::basePlate;

/// A quarter-circle needle in the x-y plane, centred at `centre`: its tail at angle pi/2
/// (above the centre), its tip at angle pi (left of it) pointing down; turning about +z
/// at w > 0 drives the tip down into the block and on along the arc.
ArcDesc needle(Vec3f centre, float punctureForce) {
  ArcDesc a;
  a.radius = kNeedleRadius;
  a.startAngle = 0.5f * kPi;
  a.endAngle = kPi;
  a.wireRadius = kWireRadius;
  a.friction = 0.3f;
  a.punctureForce = punctureForce;
  a.pose.position = centre;
  return a;
}

/// Least-squares line y = a + b x through (x, y), and its R^2.
struct LineFit {
  double a = 0, b = 0, r2 = 0;
};
LineFit fitLine(const std::vector<double>& x, const std::vector<double>& y) {
  const double n = (double)x.size();
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    sx += x[i]; sy += y[i]; sxx += x[i] * x[i]; sxy += x[i] * y[i];
  }
  LineFit f;
  f.b = (n * sxy - sx * sy) / (n * sxx - sx * sx);
  f.a = (sy - f.b * sx) / n;
  double ssRes = 0, ssTot = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    const double e = y[i] - (f.a + f.b * x[i]), d = y[i] - sy / n;
    ssRes += e * e;
    ssTot += d * d;
  }
  f.r2 = 1.0 - ssRes / ssTot;
  return f;
}

/// One advance of a needle insertion: the tip's inserted length along the arc below the
/// block's top, the force along the tip's tangent resisting the motion, the tip's state.
struct InsertionSample {
  double inserted, force;
  bool inside;
};

/// Drives the quarter needle of `needle` about its axis at `w` for `frames` advances of dt,
/// recording each.
void drive(Scene& scene, CurveId id, float w, int frames, float dt, float entryAngle, std::vector<InsertionSample>& out) {
  for (int frame = 0; frame < frames; ++frame) {
    ShapeState s = scene.curveState(id);
    s.angularVelocity = {0.f, 0.f, w};
    scene.setCurveState(id, s);
    scene.step(dt);
    const ShapeState after = scene.curveState(id);
    // the moment about the arc's axis over its radius: the force along the wire's tangent,
    // signed to resist the turn (w > 0: insertion)
    const double force = -scene.curveImpulse(id).angular.z / kNeedleRadius / dt * (w > 0.f ? 1.0 : -1.0);
    const Mat3f R = rotationMatrix(after.pose.rotation);
    const float turned = std::atan2(R.m[1][0], R.m[0][0]);  // about z since the start
    out.push_back({kNeedleRadius * (double)(turned - entryAngle), force, scene.tipInside(id)});
  }
}

// A quarter needle driven along its own arc at 5 mm/s into a block glued to its base
// (MLS-MPM, dx 2.5 mm, E 30 kPa, G_c 25 J/m^2, wire diameter d 0.5 mm, mu_k 0.3,
// punctureForce 0.03 N). Measured phases as on real needles (Okamura et al. 2004): the
// blunt tip presses the surface in (force rising), breaks in at the puncture force (drop),
// then the force is G_c d plus the shaft's friction mu_k p pi d per unit inserted length
// (p the shear modulus: 11.5 kPa, 5.4 N/m). Withdrawn, the tip opens nothing: the friction
// alone resists.
TEST(Suturing, InsertionProfile) {
  Scene scene(settingsFor(SolverType::MlsMpm));
  scene.addParticleObject(block());
  scene.addShape(basePlate());
  // the tip starts 1 mm above the top, pointing down: it crosses the top after 1 mm of arc
  const Vec3f centre{-0.01f + kNeedleRadius, 0.021f, 0.f};
  const float punctureForce = 0.03f;
  const CurveId id = scene.addCurve(needle(centre, punctureForce));
  const float speed = 5e-3f, w = speed / kNeedleRadius, dt = 1.f / 200.f;
  const float entryAngle = std::asin(0.001f / kNeedleRadius);
  std::vector<InsertionSample> in, out;
  drive(scene, id, w, 480, dt, entryAngle, in);  // 12 mm of arc
  drive(scene, id, -w, 40, dt, entryAngle, out);  // 1 mm back
  // the phases
  size_t puncture = 0;
  while (puncture < in.size() && !in[puncture].inside) ++puncture;
  ASSERT_LT(puncture, in.size()) << "the tip never broke in";
  const size_t contact = [&] {
    size_t i = 0;
    while (i < in.size() && in[i].force < 0.1 * punctureForce) ++i;
    return i;
  }();
  std::vector<double> rampX, rampF;
  for (size_t i = contact; i < puncture; ++i) {
    rampX.push_back(in[i].inserted);
    rampF.push_back(in[i].force);
  }
  ASSERT_GE(rampX.size(), 5u);
  const LineFit ramp = fitLine(rampX, rampF);
  double peak = 0;  // up to the advance the tip broke in at the end of (blunt all through it)
  for (size_t i = 0; i <= puncture; ++i) peak = std::max(peak, in[i].force);
  double after = 0;  // the mean over the 2 mm after breaking in
  for (size_t i = puncture + 1; i <= puncture + 80; ++i) after += in[i].force / 80.0;
  std::vector<double> x, f;  // from 1 mm past the puncture on
  for (size_t i = puncture + 40; i < in.size(); ++i) {
    x.push_back(in[i].inserted);
    f.push_back(in[i].force);
  }
  const LineFit grow = fitLine(x, f);
  const double gcd = kToughness * 2.0 * kWireRadius;
  const double frictionPerLength = 0.3 * 3e4 / 2.6 * kPi * 2.0 * kWireRadius;
  // withdrawal: the mean over its last half (the track's friction at that length)
  double back = 0, backLength = 0;
  for (size_t i = out.size() / 2; i < out.size(); ++i) {
    back += out[i].force / (out.size() - out.size() / 2);
    backLength += out[i].inserted / (out.size() - out.size() / 2);
  }
  std::printf("contact at %.2f mm, puncture at %.2f mm, ramp slope %.2f N/m; peak %.4f N, after %.4f N (drop %.0f %%)\n"
              "after: F = %.4f N + %.2f N/m L (R^2 %.3f); G_c d = %.4f N, mu p pi d = %.2f N/m\n"
              "withdrawal at L = %.2f mm: %.4f N (friction there %.4f N)\n",
              1e3 * in[contact].inserted, 1e3 * in[puncture].inserted, ramp.b, peak, after,
              100.0 * (1.0 - after / peak), grow.a, grow.b, grow.r2, gcd, frictionPerLength, 1e3 * backLength, back,
              grow.b * backLength);
  EXPECT_GT(ramp.b, 0.0) << "the force rises before the puncture";
  EXPECT_GE(peak, punctureForce);
  EXPECT_LE(after, 0.7 * peak) << "the force drops by 30 % or more when the tip breaks in";
  EXPECT_GT(grow.r2, 0.9) << "after the puncture the force grows linearly with the inserted length";
  EXPECT_GT(grow.b, 0.0);
  EXPECT_NEAR(grow.a, gcd, 0.3 * gcd) << "the intercept is the tip's resistance G_c d";
  EXPECT_NEAR(grow.b, frictionPerLength, 0.3 * frictionPerLength) << "the slope is the shaft's friction";
  // withdrawing, only the friction at that length resists (no G_c d)
  EXPECT_NEAR(back, grow.b * backLength, 0.3 * grow.b * backLength);
}

/// The mean magnitude of a curve's force over `frames` advances of dt with the needle
/// moved by `state` each time (its pose kept from the last advance).
double meanForce(Scene& scene, CurveId id, Vec3f v, Vec3f w, int frames, float dt) {
  double sum = 0;
  for (int frame = 0; frame < frames; ++frame) {
    ShapeState s = scene.curveState(id);
    s.linearVelocity = v;
    s.angularVelocity = w;
    scene.setCurveState(id, s);
    scene.step(dt);
    sum += norm(scene.curveImpulse(id).linear) / dt / frames;
  }
  return sum;
}

/// A scene with the needle driven 9 mm of arc (8 mm deep) into the block at 2 cm/s;
/// `contactOnly`: no toughness, no friction (the curve contact alone).
std::unique_ptr<Scene> insertedNeedle(CurveId& id, bool contactOnly) {
  auto scene = std::make_unique<Scene>(settingsFor(SolverType::MlsMpm));
  ParticleObjectDesc b = block();
  ArcDesc a = needle({-0.01f + kNeedleRadius, 0.021f, 0.f}, 0.03f);
  if (contactOnly) {
    b.material.fractureToughness = 0.f;
    a.friction = 0.f;
    a.punctureForce = 0.f;
  }
  scene->addParticleObject(b);
  scene->addShape(basePlate());
  id = scene->addCurve(a);
  std::vector<InsertionSample> in;
  drive(*scene, id, 0.02f / kNeedleRadius, 45, 0.01f, 0.f, in);
  return scene;
}

// The curve contact (CRESSim-MPM, IV-C): a needle 8 mm into the block, moved on at 5 mm/s for
// 1.5 mm along its own arc and, from the same start, sideways (across its plane). Along
// itself only the tangential slip survives, and it slides; sideways it drags the material
// with it. The contact rule alone (no toughness, no shaft friction). With them the needle
// also meets G_c d and the friction along itself (InsertionProfile): measured so, 0.0587 N
// along and 0.0550 N across over these 1.5 mm (the material's elastic push grows with the
// sideways travel, the tip's and the shaft's resistance do not).
TEST(Suturing, SlidesAlongItselfDragsSideways) {
  const float speed = 5e-3f, dt = 1.f / 100.f;
  CurveId a, b;
  std::unique_ptr<Scene> first = insertedNeedle(a, true), second = insertedNeedle(b, true);
  ASSERT_TRUE(first->tipInside(a));
  const double along = meanForce(*first, a, {0.f, 0.f, 0.f}, {0.f, 0.f, speed / kNeedleRadius}, 30, dt);
  const double across = meanForce(*second, b, {0.f, 0.f, speed}, {0.f, 0.f, 0.f}, 30, dt);
  std::printf("mean force over 1.5 mm at 5 mm/s: along the arc %.4f N, across its plane %.4f N (%.1f times)\n", along,
              across, across / along);
  EXPECT_GE(across, 10.0 * along);
}

/// Total momentum of the scene's one object [kg m/s].
Vec3f momentum(const Scene& scene, ParticleObjectId id) {
  const ObjectSummary s = scene.summary(id);
  return Vec3f{(float)s.momentum[0], (float)s.momentum[1], (float)s.momentum[2]};
}

// Momentum: the block (gravity off) takes exactly what the needle and the base plate give
// up through an insertion with its puncture: the grid contact of the wire and the blunt
// tip, the shaft's friction and the tip's resistance (G_c d) together. Relative to the
// largest momentum the needle gave, 1e-4.
TEST(Suturing, InsertionConservesMomentum) {
  Scene scene(settingsFor(SolverType::MlsMpm));
  const ParticleObjectId blockId = scene.addParticleObject(block());
  const ShapeId plate = scene.addShape(basePlate());
  const CurveId id = scene.addCurve(needle({-0.01f + kNeedleRadius, 0.021f, 0.f}, 0.03f));
  const Vec3f p0 = momentum(scene, blockId);
  Vec3f given{0.f, 0.f, 0.f};
  double largest = 0;
  bool broke = false;
  for (int frame = 0; frame < 40; ++frame) {  // 8 mm of arc at 2 cm/s
    ShapeState s = scene.curveState(id);
    s.angularVelocity = {0.f, 0.f, 0.02f / kNeedleRadius};
    scene.setCurveState(id, s);
    scene.step(0.01f);
    given -= scene.curveImpulse(id).linear + scene.shapeImpulse(plate).linear;  // what they gave the material
    largest = std::max(largest, (double)norm(scene.curveImpulse(id).linear));
    broke = broke || scene.tipInside(id);
  }
  EXPECT_TRUE(broke);
  const Vec3f gained = momentum(scene, blockId) - p0;
  std::printf("block gained (%.3e, %.3e, %.3e), needle and plate gave (%.3e, %.3e, %.3e) kg m/s; needle's largest %.3e\n", gained.x,
              gained.y, gained.z, given.x, given.y, given.z, largest);
  ASSERT_GT(largest, 1e-6);
  EXPECT_LT(norm(gained - given), 1e-4 * largest);
}

/// A thread of `segments` segments straight through the block along x at mid-height.
LineSegmentsDesc threadThroughBlock(int segments) {
  LineSegmentsDesc t;
  for (int i = 0; i <= segments; ++i) t.points.push_back({-0.03f + 0.06f * i / segments, 0.01f, 0.0011f});
  t.radius = 0.125e-3f;
  return t;
}

/// The mean force on a kinematic thread moved at v for `frames` advances of dt.
double meanThreadForce(Scene& scene, CurveId id, Vec3f v, int frames, float dt) {
  std::vector<Vec3f> points = threadThroughBlock(12).points;
  double sum = 0;
  for (int frame = 0; frame < frames; ++frame) {
    scene.setCurvePoints(id, points, std::vector<Vec3f>(points.size(), v));
    scene.step(dt);
    for (Vec3f& p : points) p += dt * v;
    sum += norm(scene.curveImpulse(id).linear) / dt / frames;
  }
  return sum;
}

// Scene::segmentContactMasses: a kinematic thread of 8 segments lying at rest in a block
// (off the node lines: 0.4 and 0.44 dx), its last two segments beyond the block's end. Each
// node within the contact band (kThreadReach: 1.5 dx of the centre line) is held by its nearest segment
// only, and inside a uniform block a node carries rho dx^3 (2 x 2 x 2 particles a cell,
// the quadratic B-spline's partition of unity): the segments' contact masses sum to the
// band's node count times rho dx^3 (1e-4), those outside the material hold nothing, and all
// are zero before the first advance.
TEST(Suturing, SegmentContactMassesAreTheNodesTheyHold) {
  Scene scene(settingsFor(SolverType::MlsMpm));
  ParticleObjectDesc slab = block();
  slab.halfExtents = {0.015f, 0.01f, 0.01f};
  slab.center = {0.f, 0.01f, 0.f};  // x in [-15, 15] mm
  scene.addParticleObject(slab);
  LineSegmentsDesc t;
  // from x = -7.5 mm: every node of the band has its whole stencil (1.5 dx) inside the block
  for (int i = 0; i <= 8; ++i) t.points.push_back({-0.0075f + kDx * i, 0.011f, 0.0011f});
  // points 7 and 8 jump: segment 6 runs out of the block, 7 lies outside it (x 27.5-30 mm)
  t.points[7].x = 0.0275f;
  t.points[8].x = 0.03f;
  const CurveId id = scene.addCurve(t);
  for (float m : scene.segmentContactMasses(id)) EXPECT_EQ(m, 0.f);
  scene.step(1e-3f);
  const std::vector<float> Mc = scene.segmentContactMasses(id);
  ASSERT_EQ(Mc.size(), 8u);
  // the nodes within the band whose nearest segment is one of 0-5 (all in the block's interior)
  auto distanceToSegment = [](Vec3f x, Vec3f a, Vec3f b) {
    const Vec3f ab = b - a;
    const float u = std::clamp(dot(x - a, ab) / dot(ab, ab), 0.f, 1.f);
    return norm(x - (a + u * ab));
  };
  int held = 0;
  for (int i = -8; i <= 14; ++i)
    for (int j = 0; j <= 8; ++j)
      for (int k = -4; k <= 4; ++k) {
        const Vec3f x{i * kDx, j * kDx, k * kDx};
        float d = 1.f;
        size_t nearest = 0;
        for (size_t s = 0; s + 1 < t.points.size(); ++s) {
          const float ds = distanceToSegment(x, t.points[s], t.points[s + 1]);
          if (ds < d) d = ds, nearest = s;  // a tie goes to the earlier segment
        }
        if (d < kThreadReach * kDx && nearest <= 5) ++held;  // segments 0-5: nodes inside, x <= 7.5 mm
      }
  const double node = 1000.0 * kDx * kDx * kDx, inside = Mc[0] + Mc[1] + Mc[2] + Mc[3] + Mc[4] + Mc[5];
  std::printf("contact masses (1e-5 kg): ");
  for (float m : Mc) std::printf("%.3f ", m * 1e5);
  std::printf("; segments 0-5 hold %.4e kg, %d band nodes x rho dx^3 = %.4e kg\n", inside, held, held * node);
  EXPECT_NEAR(inside, held * node, 1e-4 * held * node);
  EXPECT_EQ(Mc[7], 0.f) << "outside the material";
  EXPECT_GT(Mc[0], 2.f * node) << "a segment inside holds its nodes";
}

// A thread through the block slides along itself and drags the material sideways, at the
// same speed (5 mm/s over 1.5 mm); it does not cut it.
TEST(Suturing, ThreadSlidesAlongItselfDragsSideways) {
  double force[2];
  for (int sideways = 0; sideways < 2; ++sideways) {
    Scene scene(settingsFor(SolverType::MlsMpm));
    scene.addParticleObject(block());
    scene.addShape(basePlate());
    const CurveId id = scene.addCurve(threadThroughBlock(12));
    const Vec3f v = sideways ? Vec3f{0.f, 0.f, 5e-3f} : Vec3f{5e-3f, 0.f, 0.f};
    force[sideways] = meanThreadForce(scene, id, v, 30, 0.01f);
  }
  std::printf("thread: along %.4f N, across %.4f N (%.1f times)\n", force[0], force[1], force[1] / force[0]);
  EXPECT_GE(force[1], 10.0 * force[0]);
}

// A dynamic thread (3-0 suture: 0.25 mm, 0.05 g/m) thrown sideways through a free block,
// gravity off: the block gains what the thread's segments lose (their impulses), 1e-4.
TEST(Suturing, DynamicThreadConservesMomentum) {
  Scene scene(settingsFor(SolverType::MlsMpm));
  const ParticleObjectId blockId = scene.addParticleObject(block());
  LineSegmentsDesc t = threadThroughBlock(12);
  t.linearDensity = 5e-5f;
  t.velocities.assign(t.points.size(), Vec3f{0.f, 0.f, 0.05f});
  const CurveId id = scene.addCurve(t);
  const Vec3f p0 = momentum(scene, blockId);
  scene.step(0.01f);
  Vec3f given{0.f, 0.f, 0.f};
  for (const ShapeImpulse& J : scene.segmentImpulses(id)) given -= J.linear;
  const Vec3f gained = momentum(scene, blockId) - p0;
  const double thrown = 5e-5 * 0.06 * 0.05;  // the thread's momentum
  std::printf("thread gave %.3e, block gained %.3e kg m/s (thread had %.3e)\n", given.z, gained.z, thrown);
  EXPECT_GT(given.z, 0.5 * thrown) << "the material stops the light thread";
  EXPECT_LT(norm(gained - given), 1e-4 * thrown);
}

TEST(Suturing, Validation) {
  Scene scene(settingsFor(SolverType::MlsMpm));
  auto refuses = [&](auto desc, const std::string& field) {
    try {
      scene.addCurve(desc);
      ADD_FAILURE() << "accepted a bad " << field;
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  ArcDesc a = needle({0.f, 0.f, 0.f}, 0.f);
  a.radius = -1.f;
  refuses(a, "ArcDesc.radius");
  a = needle({0.f, 0.f, 0.f}, 0.f);
  a.endAngle = a.startAngle - 0.1f;
  refuses(a, "ArcDesc.endAngle");
  a = needle({0.f, 0.f, 0.f}, 0.f);
  a.wireRadius = 0.05f;
  refuses(a, "ArcDesc.wireRadius");
  a = needle({0.f, 0.f, 0.f}, -1.f);
  refuses(a, "ArcDesc.punctureForce");
  a = needle({0.f, 0.f, 0.f}, 0.f);
  a.pose.rotation = {0.f, 0.f, 0.f, 0.f};
  refuses(a, "pose.rotation");
  LineSegmentsDesc t = threadThroughBlock(3);
  t.points.resize(1);
  refuses(t, "LineSegmentsDesc.points");
  t = threadThroughBlock(3);
  t.points[2] = t.points[1];
  refuses(t, "LineSegmentsDesc.points[2]");
  t = threadThroughBlock(3);
  t.velocities.resize(2);
  refuses(t, "LineSegmentsDesc.velocities");
  t = threadThroughBlock(3);
  t.linearDensity = -1.f;
  refuses(t, "LineSegmentsDesc.linearDensity");
  t = threadThroughBlock(3);
  t.points[1].y = NAN;
  refuses(t, "LineSegmentsDesc.points[1]");
  // the calls of the other kind, a point count that is not the thread's
  const CurveId thread = scene.addCurve(threadThroughBlock(3));
  const CurveId needleId = scene.addCurve(needle({0.f, 0.03f, 0.f}, 0.f));
  EXPECT_THROW(scene.setCurveState(thread, ShapeState{}), InvalidArgument);
  EXPECT_THROW(scene.setCurvePoints(needleId, threadThroughBlock(3).points), InvalidArgument);
  EXPECT_THROW(scene.setCurvePoints(thread, threadThroughBlock(4).points), InvalidArgument);
  scene.removeCurve(thread);
  EXPECT_FALSE(scene.isValid(thread));
  EXPECT_THROW(scene.curveImpulse(thread), InvalidArgument);
  scene.step(0.01f);  // the scene still steps
  EXPECT_TRUE(scene.isValid(needleId));
  SceneSettings m = settingsFor(SolverType::Mtled);
  Scene meshless(m);
  EXPECT_THROW(meshless.addCurve(needle({0.f, 0.03f, 0.f}, 0.f)), InvalidArgument);
}

// Checkpoints hold curves: a scene saved mid-insertion (the tip inside, a thread beside
// the needle) and loaded into a fresh scene steps on bit for bit: positions, the needle's
// pose, impulse and tip, the thread's segment impulses.
TEST(Suturing, Checkpoint) {
  struct Run {
    std::vector<Vec3f> x;
    ShapeState needle;
    ShapeImpulse impulse;
    std::vector<ShapeImpulse> thread;
    bool inside;
  };
  auto stepOn = [](Scene& scene, ParticleObjectId obj, CurveId needleId, CurveId threadId, int frames) {
    for (int frame = 0; frame < frames; ++frame) {
      ShapeState s = scene.curveState(needleId);
      s.angularVelocity = {0.f, 0.f, 0.02f / kNeedleRadius};
      scene.setCurveState(needleId, s);
      scene.step(0.01f);
    }
    Run r;
    scene.readPositions(obj, r.x);
    r.needle = scene.curveState(needleId);
    r.impulse = scene.curveImpulse(needleId);
    r.thread = scene.segmentImpulses(threadId);
    r.inside = scene.tipInside(needleId);
    return r;
  };
  auto build = [](Scene& scene, ParticleObjectId& obj, CurveId& needleId, CurveId& threadId) {
    obj = scene.addParticleObject(block());
    scene.addShape(basePlate());
    needleId = scene.addCurve(needle({-0.01f + kNeedleRadius, 0.021f, 0.f}, 0.03f));
    LineSegmentsDesc t = threadThroughBlock(6);
    t.linearDensity = 5e-5f;
    threadId = scene.addCurve(t);
  };
  SceneSettings settings = settingsFor(SolverType::MlsMpm);
  Scene scene(settings);
  ParticleObjectId obj;
  CurveId needleId, threadId;
  build(scene, obj, needleId, threadId);
  stepOn(scene, obj, needleId, threadId, 14);  // 2.8 mm of arc: the tip broke in
  ASSERT_TRUE(scene.tipInside(needleId));
  const std::vector<uint8_t> saved = scene.saveToMemory();
  const Run straight = stepOn(scene, obj, needleId, threadId, 6);
  Scene fresh(settings);
  ParticleObjectId obj2;
  CurveId needle2, thread2;
  build(fresh, obj2, needle2, thread2);
  fresh.removeCurve(needle2);  // a different scene, replaced whole by the checkpoint
  fresh.loadFromMemory(saved);
  const Run resumed = stepOn(fresh, obj, needleId, threadId, 6);
  ASSERT_EQ(resumed.x.size(), straight.x.size());
  for (size_t i = 0; i < straight.x.size(); ++i)
    ASSERT_TRUE(resumed.x[i].x == straight.x[i].x && resumed.x[i].y == straight.x[i].y &&
                resumed.x[i].z == straight.x[i].z) << "particle " << i;
  EXPECT_EQ(resumed.needle.pose.rotation.z, straight.needle.pose.rotation.z);
  EXPECT_EQ(resumed.impulse.angular.z, straight.impulse.angular.z);
  EXPECT_EQ(resumed.inside, straight.inside);
  ASSERT_EQ(resumed.thread.size(), straight.thread.size());
  for (size_t k = 0; k < straight.thread.size(); ++k) EXPECT_EQ(resumed.thread[k].linear.z, straight.thread[k].linear.z);
}

/// The loop of a stitch through two blocks: down through the left block at -x, under the
/// gap, up through the right block at +x (its legs 3.3 cm long, 6 segments each, its bottom
/// 4 segments).
std::vector<Vec3f> stitch(float x) {
  std::vector<Vec3f> p;
  const float top = 0.03f, bottom = 0.008f, z = 0.0011f;
  for (int i = 0; i <= 6; ++i) p.push_back({-x, top + (bottom - top) * i / 6.f, z});
  for (int i = 1; i <= 4; ++i) p.push_back({-x + 2.f * x * i / 4.f, bottom, z});
  for (int i = 1; i <= 6; ++i) p.push_back({x, bottom + (top - bottom) * i / 6.f, z});
  return p;
}

// A stitch tightened (CRESSim-MPM, Fig. 12): two blocks 6 mm apart, glued at their bases, a
// thread loop through both 5 mm from their facing sides, its legs drawn toward each other
// at 1 cm/s by 7 mm (the loop's bottom slides along itself, the legs drag the tissue): the
// gap closes to under a third of its width, with MLS-MPM and PB-MPM. The thread is
// kinematic here; pulled by a Bullet chain in test_suturing_bullet and the demo.
TEST(Suturing, TighteningAStitchClosesTheGap) {
  for (SolverType solver : {SolverType::MlsMpm, SolverType::PbMpm}) {
    Scene scene(settingsFor(solver));
    ParticleObjectDesc half = block();
    half.halfExtents = {0.01f, 0.01f, 0.00625f};
    half.center = {-0.013f, 0.01f, 0.f};
    const ParticleObjectId left = scene.addParticleObject(half);
    half.center.x = 0.013f;
    const ParticleObjectId right = scene.addParticleObject(half);
    scene.addShape(basePlate());
    LineSegmentsDesc t;
    t.points = stitch(0.008f);
    t.radius = 0.125e-3f;
    const CurveId id = scene.addCurve(t);
    const float gap0 = test::woundGap(scene, left, right);
    const float dt = 0.01f, speed = 0.01f;
    for (int frame = 0; frame < 70; ++frame) {
      const std::vector<Vec3f> from = stitch(0.008f - speed * dt * frame), to = stitch(0.008f - speed * dt * (frame + 1));
      std::vector<Vec3f> v(from.size());
      for (size_t i = 0; i < v.size(); ++i) v[i] = (1.f / dt) * (to[i] - from[i]);
      scene.setCurvePoints(id, from, v);
      scene.step(dt);
    }
    const float gap = test::woundGap(scene, left, right);
    std::printf("%s: gap %.2f mm -> %.2f mm\n", solver == SolverType::MlsMpm ? "MLS-MPM" : "PB-MPM", 1e3f * gap0,
                1e3f * gap);
    EXPECT_LE(gap, gap0 / 3.f);
  }
}

// A light thread's segments share grid nodes with their neighbours: each node is in
// contact with the nearest segment only (the thread is one curve), so each segment's
// implicit exchange owns its nodes. 30 segments of 2 mm at 1 g/m lying in a block, their
// points moving +-2 cm/s alternately (a kinked thread), one advance of 1/960 s: no segment's
// velocity changes by more than the largest relative velocity there is (4 cm/s). With the
// nodes shared the changes reached 0.29 m/s and Bullet's chain blew up.
TEST(Suturing, ThreadSegmentsDoNotAmplifyEachOther) {
  Scene scene(settingsFor(SolverType::MlsMpm));
  scene.addParticleObject(block());
  LineSegmentsDesc t;
  for (int i = 0; i <= 30; ++i) {
    t.points.push_back({-0.015f + 0.001f * i, 0.01f, 0.0011f});
    t.velocities.push_back({0.f, 0.f, i % 2 ? 0.02f : -0.02f});
  }
  t.linearDensity = 1e-3f;
  const CurveId id = scene.addCurve(t);
  scene.step(1.f / 960.f);
  const std::vector<ShapeImpulse> J = scene.segmentImpulses(id);
  double largest = 0;
  for (const ShapeImpulse& j : J) largest = std::max(largest, (double)norm(j.linear) / (1e-3 * 0.001));
  std::printf("largest segment velocity change %.4f m/s\n", largest);
  EXPECT_LE(largest, 0.04);
}

}  // namespace
}  // namespace mpm
