// Rigid shapes: primitive signed distances against closed forms, and the grid contact
// of the grid contact (CRESSim-MPM, eqs. 17-18) against momentum balance.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "mpm/scene.h"
#include "contact/contact_law.h"
#include "contact/push_out.h"
#include "shapes/sdf_primitives.h"
#include "shapes/shape_builder.h"
#include "tools/tool_builder.h"

namespace mpm {
namespace {

// Normals must be the gradient of the distance: compare with central differences.
template <class F>
void expectNormalIsGradient(F sdf, Vec3f p, float tol) {
  Vec3f n, dummy;
  sdf(p, n);
  const float h = 1e-3f;
  for (int a = 0; a < 3; ++a) {
    Vec3f q1 = p, q0 = p;
    q1[a] += h;
    q0[a] -= h;
    const float g = (sdf(q1, dummy) - sdf(q0, dummy)) / (2 * h);
    EXPECT_NEAR(n[a], g, tol) << "axis " << a << " at (" << p.x << ", " << p.y << ", " << p.z << ")";
  }
}

TEST(ShapeSdf, PrimitivesMatchClosedForms) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-0.3f, 0.3f);
  const Vec3f h{0.1f, 0.05f, 0.08f};
  for (int t = 0; t < 2000; ++t) {
    const Vec3f p{u(rng), u(rng), u(rng)};
    Vec3f n;
    // sphere
    EXPECT_NEAR(sdfSphere(p, 0.1f, n), norm(p) - 0.1f, 1e-6f);
    // box: exterior distance to the clamped point, interior minus distance to nearest face
    const Vec3f c{std::fmax(-h.x, std::fmin(h.x, p.x)), std::fmax(-h.y, std::fmin(h.y, p.y)),
                  std::fmax(-h.z, std::fmin(h.z, p.z))};
    const bool inside = std::fabs(p.x) < h.x && std::fabs(p.y) < h.y && std::fabs(p.z) < h.z;
    const float face = std::fmin(std::fmin(h.x - std::fabs(p.x), h.y - std::fabs(p.y)), h.z - std::fabs(p.z));
    EXPECT_NEAR(sdfBox(p, h, n), inside ? -face : norm(p - c), 1e-6f);
    // capsule on z: distance to the segment minus radius
    const Vec3f s{0.f, 0.f, std::fmax(-0.1f, std::fmin(0.1f, p.z))};
    EXPECT_NEAR(sdfCapsule(p, 0.04f, 0.1f, 2, n), norm(p - s) - 0.04f, 1e-6f);
    // cylinder on x: exterior rim distance or nearest of side / cap
    const float rho = std::sqrt(p.y * p.y + p.z * p.z), dr = rho - 0.06f, da = std::fabs(p.x) - 0.12f;
    const float cyl = (dr > 0 && da > 0) ? std::sqrt(dr * dr + da * da) : std::fmax(dr, da);
    EXPECT_NEAR(sdfCylinder(p, 0.06f, 0.12f, 0, n), cyl, 1e-6f);
    EXPECT_NEAR(sdfPlane(p, n), p.y, 0.f);
    if (t % 20 == 0) {
      expectNormalIsGradient([&](Vec3f q, Vec3f& m) { return sdfBox(q, h, m); }, p, 2e-2f);
      expectNormalIsGradient([&](Vec3f q, Vec3f& m) { return sdfCapsule(q, 0.04f, 0.1f, 2, m); }, p, 2e-2f);
      expectNormalIsGradient([&](Vec3f q, Vec3f& m) { return sdfCylinder(q, 0.06f, 0.12f, 0, m); }, p, 2e-2f);
    }
  }
}

// Large shapes near the domain: Bullet's usual ground is a box of half-extents
// 50 m centred 50 m below the origin, whose local coordinates near its top face are about
// 50 m and round to ~4e-6 m in float. The part's distance at grid nodes near y = 0 (dx =
// 2 cm, and 1e-6 m above and below a node layer) must match the exact distance of the same
// shape (its float pose and sizes taken exactly, evaluated in double) within 1e-7 m.
struct Pose64 {
  double R[3][3], t[3];
  /// Part frame -> world of part 0 of `d`, from the float quaternions normalised in double.
  explicit Pose64(const ShapeDesc& d) {
    double Rb[3][3], Rl[3][3];
    rotation(d.pose.rotation, Rb);
    rotation(d.parts[0].localPose.rotation, Rl);
    const Vec3f& o = d.pose.position;
    const Vec3f& l = d.parts[0].localPose.position;
    for (int i = 0; i < 3; ++i) {
      t[i] = (double)o[i] + Rb[i][0] * l.x + Rb[i][1] * l.y + Rb[i][2] * l.z;
      for (int j = 0; j < 3; ++j) R[i][j] = Rb[i][0] * Rl[0][j] + Rb[i][1] * Rl[1][j] + Rb[i][2] * Rl[2][j];
    }
  }
  static void rotation(const Quat& q, double R[3][3]) {
    const double n = std::sqrt((double)q.w * q.w + (double)q.x * q.x + (double)q.y * q.y + (double)q.z * q.z);
    const double w = q.w / n, x = q.x / n, y = q.y / n, z = q.z / n;
    R[0][0] = 1 - 2 * (y * y + z * z); R[0][1] = 2 * (x * y - w * z);     R[0][2] = 2 * (x * z + w * y);
    R[1][0] = 2 * (x * y + w * z);     R[1][1] = 1 - 2 * (x * x + z * z); R[1][2] = 2 * (y * z - w * x);
    R[2][0] = 2 * (x * z - w * y);     R[2][1] = 2 * (y * z + w * x);     R[2][2] = 1 - 2 * (x * x + y * y);
  }
  /// The pose of a body whose centre of mass is its origin (and the part's frame, with the
  /// identity local pose) after moving at v and w for `time`.
  Pose64 moved(Vec3f v, Vec3f w, double time) const {
    Pose64 r = *this;
    const double wn = std::sqrt((double)w.x * w.x + (double)w.y * w.y + (double)w.z * w.z), a = wn * time;
    const double k[3] = {w.x / wn, w.y / wn, w.z / wn}, c = std::cos(a), s = std::sin(a);
    double Q[3][3];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) Q[i][j] = (i == j ? c : 0) + (1 - c) * k[i] * k[j];
    Q[0][1] -= s * k[2]; Q[0][2] += s * k[1]; Q[1][0] += s * k[2]; Q[1][2] -= s * k[0]; Q[2][0] -= s * k[1]; Q[2][1] += s * k[0];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r.R[i][j] = Q[i][0] * R[0][j] + Q[i][1] * R[1][j] + Q[i][2] * R[2][j];
    for (int i = 0; i < 3; ++i) r.t[i] = t[i] + v[i] * time;
    return r;
  }
  /// World point -> part frame.
  void local(Vec3f x, double p[3]) const {
    const double d[3] = {(double)x.x - t[0], (double)x.y - t[1], (double)x.z - t[2]};
    for (int j = 0; j < 3; ++j) p[j] = R[0][j] * d[0] + R[1][j] * d[1] + R[2][j] * d[2];
  }
};

/// Distance of part 0 of `d` placed at `pose` (part frame -> world).
double exactDistance(const ShapeDesc& d, const Pose64& pose, Vec3f x) {
  double p[3];
  pose.local(x, p);
  const Geometry& g = d.parts[0];
  if (g.type == GeometryType::Plane) return p[1];
  double out = 0, inside = -1e300;
  for (int a = 0; a < 3; ++a) {
    const double q = std::fabs(p[a]) - (double)g.halfExtents[a];
    out += q > 0 ? q * q : 0;
    inside = std::fmax(inside, q);
  }
  return out > 0 ? std::sqrt(out) : inside;
}
double exactDistance(const ShapeDesc& d, Vec3f x) { return exactDistance(d, Pose64(d), x); }

/// Part 0 of `d` as the kernels see it, placed at the shape's pose, anchored for a domain
/// centred at `near`.
PartView placedPart(const ShapeDesc& d, Vec3f near, float margin = 0.f, float touchReach = INFINITY,
                    float minHalfThickness = 0.f, float glueReach = 0.f) {
  const ShapeState state{d.pose, d.linearVelocity, d.angularVelocity};
  std::vector<PartView> parts;
  appendParts(d, state, 0, minHalfThickness, near, [](const std::shared_ptr<const SignedDistanceGrid>&) { return (const float*)nullptr; },
              parts);
  BodyView b = makeBody(d, state, 0.f);
  b.glueReach = glueReach;
  placePart(parts[0], b, margin, touchReach);
  return parts[0];
}

/// Largest |distance - exact| over nodes (dx = 2 cm) in [-0.2, 0.2] m x [-0.1, 0.1] m x
/// [-0.2, 0.2] m and 1e-6 m above and below each node layer, near `surfaceY(x, z)`.
double largestDistanceError(const ShapeDesc& d) {
  const Vec3f near{0.f, 0.2f, 0.f};  // the domain [-0.3, 0, -0.3] - [0.3, 0.4, 0.3]
  const PartView part = placedPart(d, near);
  const float dx = 0.02f;
  double worst = 0;
  for (int i = -10; i <= 10; ++i)
    for (int k = -10; k <= 10; ++k)
      for (int j = -5; j <= 5; ++j)
        for (const float off : {0.f, 1e-6f, -1e-6f}) {
          const Vec3f x{dx * (float)i, dx * (float)j + off, dx * (float)k};
          Vec3f n;
          const double err = std::fabs((double)part.distance(x, n) - exactDistance(d, x));
          worst = std::fmax(worst, err);
        }
  return worst;
}

ShapeDesc boxGround(float half, Quat q = {}) {
  ShapeDesc d;
  d.parts = {Geometry::box({half, half, half})};
  d.pose.rotation = q;
  // the top face through the origin: centre at -R (0, half, 0)
  double R[3][3];
  Pose64::rotation(q, R);
  d.pose.position = {(float)(-R[0][1] * half), (float)(-R[1][1] * half), (float)(-R[2][1] * half)};
  return d;
}

// A moving 50 m ground, its centre of mass 50 m below: 200 substeps of 1 ms at v = (3, -2,
// 1) mm/s and w = 0.01 rad/s about z. Its centre's float position cannot take steps of 2e-6
// m (float spacing at 50: 3.8e-6 m); the parts follow the body's travel and turn instead.
TEST(ShapePrecision, MovingLargeBoxKeepsItsDistanceNearTheDomain) {
  ShapeDesc d = boxGround(50.f);
  d.linearVelocity = {0.003f, -0.002f, 0.001f};
  d.angularVelocity = {0.f, 0.f, 0.01f};
  const ShapeState state{d.pose, d.linearVelocity, d.angularVelocity};
  std::vector<PartView> parts;
  appendParts(d, state, 0, 0.f, Vec3f{0.f, 0.2f, 0.f},
              [](const std::shared_ptr<const SignedDistanceGrid>&) { return (const float*)nullptr; }, parts);
  BodyView b = makeBody(d, state, 0.f);
  const int steps = 200;
  const float dt = 1e-3f;
  for (int s = 0; s < steps; ++s) moveBody(b, dt);
  placePart(parts[0], b, 0.f, INFINITY);
  const Pose64 pose = Pose64(d).moved(d.linearVelocity, d.angularVelocity, (double)steps * dt);
  double worst = 0;
  for (int i = -10; i <= 10; ++i)
    for (int k = -10; k <= 10; ++k)
      for (int j = -5; j <= 5; ++j)
        for (const float off : {0.f, 1e-6f, -1e-6f}) {
          const Vec3f x{0.02f * (float)i, 0.02f * (float)j + off, 0.02f * (float)k};
          Vec3f n;
          worst = std::fmax(worst, std::fabs((double)parts[0].distance(x, n) - exactDistance(d, pose, x)));
        }
  std::printf("moving 50 m box ground after %d substeps: largest distance error %.3g m\n", steps, worst);
  EXPECT_LT(worst, 1e-7);
}

TEST(ShapePrecision, LargeShapesKeepTheirDistanceNearTheDomain) {
  const float s = std::sin(0.5f * 0.35f), c = std::cos(0.5f * 0.35f);  // 20 degrees
  const Quat tilt{c, 0.6f * s, 0.f, 0.8f * s};                       // about (0.6, 0, 0.8)
  ShapeDesc plane;
  plane.parts = {Geometry{}};
  plane.parts[0].type = GeometryType::Plane;
  plane.pose.rotation = tilt;
  {  // a plane whose origin lies 5 km away along it, its surface 1 cm above the origin
    double R[3][3];
    Pose64::rotation(tilt, R);
    const double along[3] = {3000, 0, -4000};
    Vec3f o;
    for (int i = 0; i < 3; ++i) o[i] = (float)(R[i][0] * along[0] + R[i][2] * along[2] + R[i][1] * 0.01);
    plane.pose.position = o;
  }
  ShapeDesc offsetLocal = boxGround(50.f);  // the far centre in the part's local pose
  offsetLocal.parts[0].localPose.position = offsetLocal.pose.position;
  offsetLocal.pose.position = {0.013f, 0.f, -0.021f};
  const struct {
    const char* name;
    ShapeDesc d;
  } cases[] = {{"50 m box ground", boxGround(50.f)},
               {"rotated 50 m box", boxGround(50.f, tilt)},
               {"5 km box ground", boxGround(5000.f)},
               {"5 km rotated box", boxGround(5000.f, tilt)},
               {"50 m box placed by its local pose", offsetLocal},
               {"plane with a far origin", plane}};
  for (const auto& c : cases) {
    const double err = largestDistanceError(c.d);
    std::printf("%s: largest distance error %.3g m\n", c.name, err);
    EXPECT_LT(err, 1e-7) << c.name;
  }
}

SceneSettings contactScene() {
  SceneSettings s;
  s.domain.lower = {-0.3f, 0.f, -0.3f};
  s.domain.upper = {0.3f, 0.6f, 0.3f};
  s.domain.wallMode = WallMode::Slip;
  s.dx = 0.02f;
  s.gravity = {0.f, -9.81f, 0.f};
  return s;
}

ParticleObjectDesc softBlock() {
  ParticleObjectDesc d;
  d.center = {0.f, 0.04f + 0.05f, 0.f};  // resting on the floor wall (2 cells)
  d.halfExtents = {0.15f, 0.05f, 0.15f};
  d.material.model = MaterialModel::NeoHookeanDecoupled;
  d.material.youngsModulus = 2e5f;
  d.material.poissonRatio = 0.3f;
  d.material.density = 1000.f;
  return d;
}

// A dynamic box resting on a soft block: averaged over time, the grid holds it up with
// m g (momentum balance), and it does not sink into the tissue. The window starts after
// 1 s of settling: the box rings on the undamped elastic block, and only the transfers'
// numerical damping stills it, which falls with the substep count. At 0.5 s (the settling
// this test had with cflNumber 0.3) the box still moved at 0.058 m/s with cfl 0.3 and at
// 0.147 m/s with cfl 0.6 (MLS-MPM's default is 0.55), whose 0.5-1 s average read 20.17 N
// (+2.8 %: the box's own momentum change, 0.138 m/s); at 1 s it moves at 0.010 and
// 0.009 m/s.
// contactNodePart skips looking from a node's material when the node's own distance is
// far beyond the contact threshold, on the premise that for the parts it does this for
// (PartView::lipschitzDistance) the phi it would decide by, phiNode or phiSide = phiBar +
// nBar . (x - xbar) where the node and its material see opposite sides, is at least
// phiNode - 2 |x - xbar| (less the kernel's rounding slack). Checked on each such part,
// turned and placed off the origin, for random nodes and materials up to 2 cells apart.
TEST(ShapeContact, EarlyOutBoundHoldsForEveryLipschitzPart) {
  const float s = std::sin(0.5f * 0.6f), c = std::cos(0.5f * 0.6f);
  const Quat turn{c, 0.48f * s, 0.6f * s, 0.64f * s};  // about (0.48, 0.6, 0.64)
  std::vector<ShapeDesc> shapes;
  for (GeometryType t : {GeometryType::Plane, GeometryType::Box, GeometryType::Sphere, GeometryType::Capsule,
                         GeometryType::Cylinder}) {
    ShapeDesc d;
    d.parts = {Geometry{}};
    d.parts[0].type = t;
    d.parts[0].halfExtents = {0.05f, 0.02f, 0.08f};
    d.parts[0].radius = 0.03f;
    d.parts[0].halfHeight = 0.06f;
    d.pose.position = {0.01f, 0.12f, -0.02f};
    d.pose.rotation = turn;
    shapes.push_back(d);
  }
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-0.25f, 0.25f), off(-0.04f, 0.04f);
  int checked = 0;
  for (const ShapeDesc& d : shapes) {
    const PartView part = placedPart(d, Vec3f{0.f, 0.1f, 0.f});
    ASSERT_TRUE(part.lipschitzDistance()) << "geometry " << (int)d.parts[0].type;
    float worst = -1e30f;  // largest (phiNode - 2 |x - xbar|) - phi, to be <= slack
    for (int t = 0; t < 20000; ++t) {
      const Vec3f x{u(rng), 0.1f + u(rng), u(rng)}, xbar = x + Vec3f{off(rng), off(rng), off(rng)};
      Vec3f n, nBar;
      const float phiNode = part.distance(x, n), phiBar = part.distance(xbar, nBar);
      const float phiSide = phiBar + dot(nBar, x - xbar);
      const float phi = dot(n, nBar) < 0.f ? std::fmin(phiSide, phiNode) : phiNode;
      const float away = norm(x - xbar);
      const float slack = 1e-5f * (std::fabs(x.x) + std::fabs(x.y) + std::fabs(x.z) + std::fabs(phiNode) + away);
      worst = std::fmax(worst, (phiNode - 2.f * away) - phi - slack);
      ++checked;
    }
    std::printf("geometry %d: largest (phiNode - 2 |x - xbar|) - phi - slack %.3g m\n", (int)d.parts[0].type, worst);
    EXPECT_LE(worst, 0.f) << "geometry " << (int)d.parts[0].type;
  }
  EXPECT_EQ(checked, 5 * 20000);
}

// G2P tries a particle against a part only inside the part's push-out box (PartView::
// mayPush): an analytic part's own box grown by the particles' largest touch distance (a
// Bonded part's glue reach, where larger) and a slack for rounding, not the grid's bounds
// (a cell and the band more). Outside it no particle of any volume up to the largest may
// be pushed or touch the part, glued or not: checked for
// each analytic part, turned, near the origin and 40 m from it (coordinates with 4e-6 m
// float spacing), at random points and at points a float outside each face of the box. The
// box must stay within the grid's bounds (the blocks' part lists are made from those) and
// be smaller than them (what it is for).
TEST(ShapeContact, NoParticlePushedOrTouchingOutsideThePushBox) {
  const float s = std::sin(0.5f * 0.6f), c = std::cos(0.5f * 0.6f);
  const Quat turn{c, 0.48f * s, 0.6f * s, 0.64f * s};
  const float dx = 0.02f, largest = 1.25e-7f;  // particles of up to half a cell's cube
  const float reach = touchDistance(largest);
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> unit(0.f, 1.f), share(0.f, 1.f);
  int outside = 0, onFaces = 0, touchingInside = 0;
  for (const float far : {0.f, 40.f, 400.f})
    for (GeometryType t : {GeometryType::Plane, GeometryType::Box, GeometryType::Sphere, GeometryType::Capsule,
                           GeometryType::Cylinder})
      for (const bool turned : {false, true})
      for (const float glueReach : {0.f, dx}) {
        const bool glued = glueReach > 0.f;  // a Bonded part, the particles having touched it
        ShapeDesc d;
        d.parts = {Geometry{}};
        d.parts[0].type = t;
        d.parts[0].halfExtents = {0.05f, 0.004f, 0.08f};  // thinner than the band: grown for the grid
        d.parts[0].radius = 0.006f;
        d.parts[0].halfHeight = 0.03f;
        d.pose.position = {far + 0.01f, 0.12f, -0.02f};
        if (turned) d.pose.rotation = turn;
        const Vec3f near{far, 0.1f, 0.f};
        if (glued) d.contact.mode = ContactMode::Bonded;
        const PartView part = placedPart(d, near, dx, reach, 0.75f * dx, glueReach);
        const std::string what = "geometry " + std::to_string((int)t) + (turned ? " turned" : "") + " at " +
                                 std::to_string(far) + " m" + (glued ? " glued" : "");
        for (int a = 0; a < 3; ++a) {
          EXPECT_GE(part.pushLower[a], part.boundsLower[a]) << what;
          EXPECT_LE(part.pushUpper[a], part.boundsUpper[a]) << what;
        }
        if (t == GeometryType::Sphere && !glued)  // the grid's cell either side is not the particles' (glued: a cell is)
          EXPECT_LT(part.pushUpper.x - part.pushLower.x, part.boundsUpper.x - part.boundsLower.x - 2.f * dx) << what;
        // points in the part's own box grown by two reaches (a plane: about its anchor)
        Vec3f lo, hi;
        for (int a = 0; a < 3; ++a) {
          lo[a] = std::fmax(part.pushLower[a], part.position[a] - 0.2f) - 2.f * reach;
          hi[a] = std::fmin(part.pushUpper[a], part.position[a] + 0.2f) + 2.f * reach;
        }
        const auto check = [&](Vec3f x, bool face) {
          if (part.mayPush(x, x)) {
            bool touch = false;
            Vec3f y = x;
            if (pushOutOfPart(y, part, largest, glued, touch) || touch) ++touchingInside;
            return;
          }
          ++outside;
          onFaces += face;
          for (const float v : {largest, largest * share(rng), 1e-12f}) {
            bool touch = false;
            Vec3f y = x;
            const bool moved = pushOutOfPart(y, part, v, glued, touch);
            EXPECT_FALSE(moved || touch) << what << ": x " << x.x << " " << x.y << " " << x.z << " volume " << v;
          }
        };
        for (int k = 0; k < 20000; ++k) {
          Vec3f x;
          for (int a = 0; a < 3; ++a) x[a] = lo[a] + (hi[a] - lo[a]) * unit(rng);
          check(x, false);
          // the same point moved a float beyond one face of the push box (a plane's faces
          // along it lie at 1e18 m: no particle's)
          const int a = k % 3;
          const float face = (k / 3) % 2 ? std::nextafter(part.pushUpper[a], INFINITY)
                                         : std::nextafter(part.pushLower[a], -INFINITY);
          if (std::fabs(face) > 1e6f) continue;
          x[a] = face;
          check(x, true);
        }
      }
  std::printf("%d points outside the push boxes (%d a float beyond a face), %d inside pushed or touching\n", outside,
              onFaces, touchingInside);
  EXPECT_GT(onFaces, 80000);
  EXPECT_GT(touchingInside, 10000);
}

// nearerSegment skips a thread's segments whose push-out box lies farther from the node
// than the node's own distance (surelyFartherThan). Its answer must be the one asking every
// segment gives: checked on a coiled 60-segment thread (segments of 2 mm, radius 0.25 mm,
// turning so that segments far apart along it lie side by side), near the origin and 40 m
// from it, placed as the grid solvers place it (a cell's margin and the particles' touch
// reach) and as MTLED does (no margin, no reach), at random nodes around it, inside the
// capsules and at their joints. The same with the contact pass's lists (NearSegments: only
// the segments listed near the node's block, the nearest kept for the node's next segment).
// A needle's arc is asked whether it is surely farther than a distance (the contact pass)
// and whether a particle surely neither touches nor enters it (the push-out) by the tube
// round its whole circle (arcLowerDistance), without the angle about it. That bound must
// never exceed the arc's distance, and the push-out must give the full test's answers
// exactly: at points near the wire, past its ends, on the missing half of the circle and
// anywhere in its bounds, for a needle turned and placed near the origin and 40 m away.
TEST(ShapeContact, ArcLowerDistanceNeverExceedsTheDistance) {
  const float dx = 2.5e-3f, volume0 = dx * dx * dx / 8.f;
  std::mt19937 rng(31);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  long long points = 0, skipped = 0, touched = 0, pushed = 0;
  for (const float far : {0.f, 40.f}) {
    ArcDesc d;  // the suturing demo's needle: 12 mm, a half circle, wire radius 0.25 mm
    ShapeState state;
    state.pose.position = {far + 1e-3f, 0.026f, -2e-3f};
    const float half = 0.6f;  // turned 1.2 rad about (1, 2, 3)
    const float axisNorm = std::sqrt(14.f);
    state.pose.rotation = {std::cos(half), std::sin(half) / axisNorm, 2.f * std::sin(half) / axisNorm,
                           3.f * std::sin(half) / axisNorm};
    std::vector<BodyView> bodies;
    std::vector<PartView> parts;
    appendNeedle(d, state, false, 0.75f * dx, dx, 0.f, state.pose.position, bodies, parts);
    PartView& arc = parts[0];
    ASSERT_EQ(arc.type, kPartArc);
    placePart(arc, bodies[arc.body], dx, touchDistance(volume0));
    for (int k = 0; k < 100000; ++k) {
      // in the arc's frame: about the wire (k % 4 == 0), about the missing half's circle
      // (1), past the tip's end (2), anywhere in the box round the circle (3)
      const float a = (k % 4 == 1 ? -1.f : 1.f) * 1.5707964f * (1.f + u(rng)) + (k % 4 == 2 ? 3.1415927f : 0.f);
      const float r = k % 4 == 3 ? 0.f : d.radius;
      const float spread = k % 4 == 3 ? d.radius + 3.f * dx : (k % 8 == 0 ? 2.f * d.wireRadius : 2.f * dx);
      const Vec3f local{r * std::cos(a) + spread * u(rng), r * std::sin(a) + spread * u(rng), spread * u(rng)};
      Vec3f x = arc.position + arc.rotation * local;
      Vec3f n;
      const float phi = arc.distance(x, n);
      const float lower = arcLowerDistance(arc, x);
      ASSERT_LE(lower, phi) << "point " << k << " at " << far << " m";
      // the push-out's answer against the full test's
      bool beyond = false;
      if (phi < 0.f) arc.curveTangent(x, beyond);
      const bool touchFull = withinTouch(phi, volume0);
      const bool movesFull = phi < 0.f && !beyond;
      bool touch = false;
      Vec3f y = x;
      const bool moved = pushOutOfPart(y, arc, volume0, false, touch);
      ASSERT_EQ(touch, touchFull) << "point " << k;
      ASSERT_EQ(moved, movesFull) << "point " << k;
      if (moved) {
        ASSERT_EQ(y.x, x.x - phi * n.x);
        ASSERT_EQ(y.y, x.y - phi * n.y);
        ASSERT_EQ(y.z, x.z - phi * n.z);
      }
      ++points;
      skipped += lower > 0.f && !withinTouch(lower, volume0);
      touched += touchFull;
      pushed += movesFull;
    }
  }
  std::printf("arc: %lld points, %lld answered by the circle's tube, %lld touching, %lld pushed out\n", points,
              skipped, touched, pushed);
  EXPECT_GT(touched, 0);
  EXPECT_GT(pushed, 0);
}

TEST(ShapeContact, NearerSegmentSkipsOnlySegmentsThatCannotBeNearer) {
  const float dx = 2e-3f;
  std::mt19937 rng(23);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  long long asked = 0, nearer = 0, skipped = 0, listedAsked = 0, bandedAsked = 0;
  constexpr int kTurn = 29;  // segments a turn of the helix (2 pi / 0.22 = 28.6)
  for (const float far : {0.f, 40.f})
    for (const bool grid : {true, false}) {
      LineSegmentsDesc d;
      d.radius = 0.25e-3f;
      std::vector<Vec3f> points;
      for (int i = 0; i <= 60; ++i) {  // a helix of radius 3 mm, 4 mm a turn: coils lie 1.3 dx apart
        const float t = 0.1f * (float)i;
        points.push_back(Vec3f{far + 3e-3f * std::cos(t * 2.2f), 0.1f + 6.4e-4f * t, 3e-3f * std::sin(t * 2.2f)});
      }
      std::vector<BodyView> bodies;
      std::vector<PartView> parts;
      appendThread(d, points, {}, grid ? 0.75f * dx : 0.f, Vec3f{far, 0.1f, 0.f}, bodies, parts);
      for (PartView& part : parts)
        placePart(part, bodies[part.body], grid ? dx : 0.f, grid ? touchDistance(dx * dx * dx / 8.f) : INFINITY);
      const int n = (int)parts.size();
      const std::vector<int> runFirst(n, 0), runLast(n, n - 1);  // one thread
      const std::vector<uint8_t> isSegment(n, 1);
      float reach = INFINITY, band = 0.f;
      for (const PartView& part : parts) {
        reach = std::min(reach, part.boundsGrowth);
        band = std::max(band, std::max(bodies[part.body].band, part.band));
      }
      // the answer asking every segment: another one nearer, or as near and earlier
      const auto askingEvery = [&](Vec3f x, int r, float ownR) {
        Vec3f nrm;
        for (int q = 0; q < n; ++q)
          if (q != r && (q < r ? parts[q].distance(x, nrm) <= ownR : parts[q].distance(x, nrm) < ownR)) return true;
        return false;
      };
      for (int k = 0; k < 20000; ++k) {
        const int p = k % n;
        // a node near segment p: within two cells of a point along it
        const float s = 0.5f + 0.5f * u(rng);
        const Vec3f along = points[p] + s * (points[p + 1] - points[p]);
        Vec3f x = along + (k % 5 == 0 ? 0.2e-3f : 2.f * dx) * Vec3f{u(rng), u(rng), u(rng)};
        if (k % 4 == 3 && p + kTurn < n) {  // or between two coils, in both segments' bands
          const Vec3f across = points[p + kTurn] + s * (points[p + kTurn + 1] - points[p + kTurn]);
          x = along + (0.5f + 0.2f * u(rng)) * (across - along) + 0.4f * dx * Vec3f{u(rng), u(rng), u(rng)};
        }
        Vec3f nrm;
        const float own = parts[p].distance(x, nrm);
        const bool every = askingEvery(x, p, own);
        for (int q = 0; q < n; ++q) skipped += q != p && surelyFartherThan(parts[q], x, own);
        const bool got = nearerSegment(x, parts.data(), n, p, bodies.data(), own);
        ASSERT_EQ(got, every) << "far " << far << (grid ? " grid" : " MTLED") << ", segment " << p << ", node "
                              << x.x << " " << x.y << " " << x.z;
        ++asked;
        nearer += got;
        // The contact pass's lists (NearSegments): the segments whose bounds meet a block's
        // box (its nodes' box of 3 cells holding x, and two cells above), and of those the
        // ones within the widest band of the nodes' box (segmentsWithin), asked for p and
        // then, with the nearest kept, for p - 1 and p + 1: the same answers as asking every
        // segment.
        std::vector<int> listed, within(n);
        Vec3f lo = x - dx * Vec3f{1.5f + 1.5f * u(rng), 1.5f + 1.5f * u(rng), 1.5f + 1.5f * u(rng)};
        if (k % 3 == 0) lo[k % 7 % 3] = x[k % 7 % 3] - (k % 2 ? 0.f : 3.f * dx);  // x on a face of the nodes' box
        const Vec3f nodesHi = lo + 3.f * dx * Vec3f{1.f, 1.f, 1.f}, hi = lo + 5.f * dx * Vec3f{1.f, 1.f, 1.f};
        for (int q = 0; q < n; ++q)
          if (parts[q].mayTouch(lo, hi)) listed.push_back(q);
        const int nWithin = segmentsWithin(parts.data(), listed.data(), (int)listed.size(), isSegment.data(), lo, nodesHi,
                                           band, within.data());
        for (const bool banded : {false, true}) {
          NearestSegment kept;
          NearSegments near;
          near.parts = banded ? within.data() : listed.data();
          near.count = banded ? nWithin : (int)listed.size();
          near.runFirst = runFirst.data();
          near.runLast = runLast.data();
          near.reach = banded ? std::min(reach, band) : reach;
          near.nearest = &kept;
          for (const int r : {p, p - 1, p + 1}) {
            if (r < 0 || r >= n || !parts[r].mayTouch(x, x)) continue;  // the pass asks only the parts in reach
            const float ownR = parts[r].distance(x, nrm);
            if (banded && !(ownR < band)) continue;  // the pass asks only for nodes in the band
            ASSERT_EQ(nearerSegment(x, parts.data(), n, r, bodies.data(), ownR, &near), askingEvery(x, r, ownR))
                << (banded ? "banded" : "listed") << ": far " << far << (grid ? " grid" : " MTLED") << ", segment "
                << r << " after " << p;
            (banded ? bandedAsked : listedAsked) += ownR < near.reach;
          }
        }
      }
    }
  std::printf("%lld nodes asked, %lld nearer another segment; %lld segment distances skipped (%.0f %%); "
              "%lld asked from a block's list, %lld from its segments within the band\n", asked, nearer, skipped,
              100.0 * (double)skipped / ((double)asked * 59.0), listedAsked, bandedAsked);
  EXPECT_GT(nearer, asked / 10);             // the coils: many nodes lie nearer another segment
  EXPECT_GT(skipped, (long long)asked * 30);  // and most segments are not asked
  EXPECT_GT(listedAsked, asked / 2);          // the lists answered most (the grid's growth: 2.5 dx)
  EXPECT_GT(bandedAsked, asked / 4);          // and the band's lists most of the band's nodes
}

// PartView::distance takes a sphere's and a plane's distance in the world frame (no turn
// into the part's frame and back); it must be the part-frame value, sdfSphere / sdfPlane of
// R^T (x - anchor) with the normal turned back by R, up to rounding, for a turned part
// placed off the origin (a wrong axis for the plane's normal, or a sphere measured from
// anything but its centre, is off by centimetres).
TEST(ShapeContact, WorldFrameDistanceOfSpheresAndPlanesIsThePartFrames) {
  const float s = std::sin(0.5f * 1.1f), c = std::cos(0.5f * 1.1f);
  const Quat turn{c, 0.48f * s, 0.6f * s, 0.64f * s};
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-0.25f, 0.25f);
  for (GeometryType t : {GeometryType::Plane, GeometryType::Sphere}) {
    ShapeDesc d;
    d.parts = {Geometry{}};
    d.parts[0].type = t;
    d.parts[0].radius = 0.03f;
    d.pose.position = {0.02f, 0.11f, -0.03f};
    d.pose.rotation = turn;
    const PartView part = placedPart(d, Vec3f{0.f, 0.1f, 0.f});
    float worstPhi = 0.f, worstN = 0.f;
    for (int k = 0; k < 10000; ++k) {
      const Vec3f x{u(rng), 0.1f + u(rng), u(rng)};
      Vec3f n, nl;
      const float phi = part.distance(x, n);
      const Vec3f p = transpose(part.rotation) * (x - part.position);
      const float ref = t == GeometryType::Plane ? sdfPlane(p, nl) : sdfSphere(p, part.radius, nl);
      worstPhi = std::fmax(worstPhi, std::fabs(phi - ref));
      worstN = std::fmax(worstN, norm(n - part.rotation * nl));
    }
    std::printf("geometry %d: largest |phi - part frame's| %.3g m, |n - part frame's| %.3g\n", (int)t, worstPhi,
                worstN);
    EXPECT_LE(worstPhi, 1e-6f) << "geometry " << (int)t;  // float rounding on 0.5 m
    EXPECT_LE(worstN, 1e-5f) << "geometry " << (int)t;
  }
}

// withinTouch skips the cube root where the cubes of phi and touchDistance decide: it must
// say what phi < touchDistance(volume0) says everywhere, also at the boundary itself and a
// float either side of it, for volumes of a micro-metre cube to a metre cube and for
// negative, zero and far distances.
TEST(ShapeContact, WithinTouchIsTheCubeRootsAnswer) {
  std::mt19937 rng(41);
  std::uniform_real_distribution<float> logVolume(-18.f, 0.f), factor(0.f, 3.f);
  long long wrong = 0, checked = 0;
  const auto check = [&](float phi, float v) {
    ++checked;
    if (withinTouch(phi, v) != (phi < touchDistance(v))) ++wrong;
  };
  for (int s = 0; s < 200000; ++s) {
    const float v = std::pow(10.f, logVolume(rng)), d = touchDistance(v);
    check(factor(rng) * d, v);
    check(d, v);
    check(std::nextafter(d, 0.f), v);
    check(std::nextafter(d, 1.f), v);
    check(d * (1.f + 1e-4f * (factor(rng) - 1.5f)), v);  // inside the band the cubes leave open
  }
  for (float v : {1e-9f, 1e-6f, 1.f})
    for (float phi : {-1.f, -0.f, 0.f, 1e-30f, 1e9f, 3e38f, INFINITY, -INFINITY}) check(phi, v);
  check(0.01f, 0.f);
  check(-0.01f, 0.f);
  check(0.f, 0.f);
  EXPECT_EQ(wrong, 0) << "of " << checked;
}

TEST(ShapeContact, RestingBoxIsHeldByItsWeight) {
  Scene scene(contactScene());
  const ParticleObjectId tissue = scene.addParticleObject(softBlock());
  ShapeDesc box;
  Geometry g;
  g.type = GeometryType::Box;
  g.halfExtents = {0.05f, 0.03f, 0.05f};
  box.parts = {g};
  const float top = 0.04f + 0.1f;
  box.pose.position = {0.f, top + 0.03f + 0.01f, 0.f};
  box.mass = 2.f;
  box.inertia = {2.f / 3.f * (0.03f * 0.03f + 0.05f * 0.05f), 2.f / 3.f * 2 * 0.05f * 0.05f,
                 2.f / 3.f * (0.03f * 0.03f + 0.05f * 0.05f)};
  box.gravity = {0.f, -9.81f, 0.f};
  box.contact.mode = ContactMode::Frictional;
  box.contact.friction = 0.5f;
  const ShapeId id = scene.addShape(box);
  const float frame = 0.005f;
  for (int f = 0; f < 200; ++f) scene.step(frame);  // settle 1 s
  double impulse = 0;
  const int frames = 100;
  for (int f = 0; f < frames; ++f) {
    scene.step(frame);
    impulse += scene.shapeImpulse(id).linear.y;
  }
  const double force = impulse / (frames * frame);
  std::printf("time-averaged support force over 1-1.5 s %.4f N (weight %.4f N)\n", force, 2.0 * 9.81);
  EXPECT_NEAR(force, 2.0 * 9.81, 0.02 * 2.0 * 9.81) << "time-averaged support force [N]";
  // penetration: the box bottom against the tissue top (highest particle under the box)
  std::vector<Vec3f> x;
  scene.readPositions(tissue, x);
  float surface = 0.f;
  for (const Vec3f& p : x)
    if (std::fabs(p.x) < 0.04f && std::fabs(p.z) < 0.04f) surface = std::fmax(surface, p.y);
  const float bottom = scene.shapeState(id).pose.position.y - 0.03f;
  EXPECT_GT(bottom - surface, -0.5f * 0.02f) << "box bottom " << bottom << " tissue top " << surface;
  EXPECT_LT(bottom - surface, 0.5f * 0.02f) << "box bottom " << bottom << " tissue top " << surface;
}

// Zero gravity, no walls: a dynamic sphere thrown at a free soft block. Total momentum of
// sphere plus particles is conserved through the collision.
TEST(ShapeContact, ThrownSphereConservesTotalMomentum) {
  SceneSettings s = contactScene();
  s.gravity = {0.f, 0.f, 0.f};
  s.domain.walls = false;
  Scene scene(s);
  ParticleObjectDesc b = softBlock();
  b.center = {0.05f, 0.3f, 0.f};
  b.halfExtents = {0.06f, 0.06f, 0.06f};
  const ParticleObjectId tissue = scene.addParticleObject(b);
  ShapeDesc ball;
  Geometry g;
  g.type = GeometryType::Sphere;
  g.radius = 0.04f;
  ball.parts = {g};
  ball.pose.position = {-0.1f, 0.3f, 0.f};
  ball.linearVelocity = {2.f, 0.f, 0.f};
  ball.mass = 0.5f;
  const float I = 0.4f * 0.5f * 0.04f * 0.04f;
  ball.inertia = {I, I, I};
  const ShapeId id = scene.addShape(ball);
  const double p0 = 0.5 * 2.0;
  for (int f = 0; f < 30; ++f) scene.step(0.005f);
  const ObjectSummary t = scene.summary(tissue);
  const ShapeState st = scene.shapeState(id);
  EXPECT_GT(t.momentum[0], 0.2 * p0) << "the sphere hit the block and pushed it";
  const double px = t.momentum[0] + 0.5 * st.linearVelocity.x;
  const double py = t.momentum[1] + 0.5 * st.linearVelocity.y;
  EXPECT_NEAR(px, p0, 0.01 * p0);
  EXPECT_NEAR(py, 0.0, 0.01 * p0);
}

// ---------------------------------------------------------------------------------------
// A backend keeps a device copy of each mesh shape's distance values. The copy must follow
// the grid it came from, not the address the grid had: a mesh shape removed and another
// added whose grid lands where the freed one was must be seen with the new values (issue
// 13: keyed by address, the new shape got the old values, impulse 0 instead of the plane's).

/// Hands out one fixed block while it is free (else the heap): a grid made right after
/// another was freed lands at the freed one's address, as a general allocator may do.
struct ReusedBlock {
  alignas(64) static inline unsigned char bytes[4096];
  static inline bool busy = false;
};
template <class T>
struct ReusingAllocator {
  using value_type = T;
  ReusingAllocator() = default;
  template <class U>
  ReusingAllocator(const ReusingAllocator<U>&) {}
  T* allocate(size_t n) {
    if (!ReusedBlock::busy && n * sizeof(T) <= sizeof(ReusedBlock::bytes)) {
      ReusedBlock::busy = true;
      return reinterpret_cast<T*>(ReusedBlock::bytes);
    }
    return static_cast<T*>(::operator new(n * sizeof(T)));
  }
  void deallocate(T* p, size_t) {
    if ((void*)p == (void*)ReusedBlock::bytes)
      ReusedBlock::busy = false;
    else
      ::operator delete(p);
  }
  template <class U>
  bool operator==(const ReusingAllocator<U>&) const { return true; }
  template <class U>
  bool operator!=(const ReusingAllocator<U>&) const { return false; }
};

/// The half-space y <= y0 as a sampled field y - y0 over the whole domain of
/// contactScene(): trilinear interpolation of a linear field is exact, so this mesh shape
/// is the plane itself.
std::shared_ptr<SignedDistanceGrid> planeGrid(float y0, float cell) {
  auto g = std::allocate_shared<SignedDistanceGrid>(ReusingAllocator<SignedDistanceGrid>());
  g->lower = {-0.4f, -0.1f, -0.4f};
  g->cellSize = cell;
  for (int a = 0; a < 3; ++a) g->dims[a] = (int)std::lround(0.8f / cell) + 1;
  g->values.resize((size_t)g->dims[0] * g->dims[1] * g->dims[2]);
  for (int i = 0; i < g->dims[0]; ++i)
    for (int j = 0; j < g->dims[1]; ++j)
      for (int k = 0; k < g->dims[2]; ++k)
        g->values[((size_t)i * g->dims[1] + j) * g->dims[2] + k] = g->lower.y + j * cell - y0;
  return g;
}

// The CPU backend always; CUDA (a device copy proper) where a device exists.
class MeshCache : public ::testing::TestWithParam<Backend> {};

TEST_P(MeshCache, MeshGridAtAFreedGridsAddressIsSeenAfresh) {
  if (GetParam() == Backend::Cuda && !cudaDeviceAvailable()) GTEST_SKIP() << "no CUDA device: GPU case skipped";
  SceneSettings s = contactScene();
  s.backend = GetParam();
  s.gravity = {0.f, 0.f, 0.f};
  ParticleObjectDesc b = softBlock();
  b.center = {0.f, 0.3f, 0.f};  // bottom at 0.25 m, falling at 1 m/s
  b.velocity = {0.f, -1.f, 0.f};
  const float frame = 0.01f, y0 = 0.25f;  // after one frame the bottom is 1 cm below y0
  // reference: one free frame, then the analytic plane y <= y0 for one frame
  Scene ref(s);
  ref.addParticleObject(b);
  ref.step(frame);
  ShapeDesc plane;
  plane.parts = {Geometry{}};
  plane.parts[0].type = GeometryType::Plane;
  plane.pose.position = {0.f, y0, 0.f};
  const ShapeId planeId = ref.addShape(plane);
  ref.step(frame);
  const float expected = ref.shapeImpulse(planeId).linear.y;
  ASSERT_LT(expected, -0.5f) << "the plane stops the tissue's bottom";
  // the old grid: the same size, then larger (finer), and a plane far below the tissue
  for (const float oldCell : {0.02f, 0.01f}) {
    Scene scene(s);
    scene.addParticleObject(b);
    ShapeDesc far;
    far.parts = {Geometry{}};
    far.parts[0].type = GeometryType::Mesh;
    far.parts[0].sdf = planeGrid(-1.f, oldCell);
    const void* oldAddress = far.parts[0].sdf.get();
    const ShapeId farId = scene.addShape(far);
    scene.step(frame);  // the backend copies the far grid's values
    EXPECT_EQ(scene.shapeImpulse(farId).linear.y, 0.f) << "the far plane touches nothing";
    scene.removeShape(farId);
    far = ShapeDesc{};  // the scene and the test hold the old grid no more
    ShapeDesc near;
    near.parts = {Geometry{}};
    near.parts[0].type = GeometryType::Mesh;
    near.parts[0].sdf = planeGrid(y0, 0.02f);
    const bool reused = near.parts[0].sdf.get() == oldAddress;
    const ShapeId nearId = scene.addShape(near);
    scene.step(frame);
    const float got = scene.shapeImpulse(nearId).linear.y;
    std::printf("old grid cell %.3f m: new grid %s the old one's address; impulse %.5f N s, analytic plane %.5f N s\n",
                oldCell, reused ? "at" : "not at", got, expected);
    EXPECT_NEAR(got, expected, 1e-3f * std::fabs(expected)) << "old grid cell " << oldCell;
  }
}

INSTANTIATE_TEST_SUITE_P(Backends, MeshCache, ::testing::Values(Backend::Cpu, Backend::Cuda),
                         [](const ::testing::TestParamInfo<Backend>& i) {
                           return std::string(i.param == Backend::Cpu ? "Cpu" : "Cuda");
                         });

}  // namespace
}  // namespace mpm
