// Cutting (CRESSim-MPM, section IV-B): slicers separate the material they pass in every grid
// solver. The side test at unit level; no mass or momentum crosses a blade; a block is two
// pieces after a full cut and one before the blade arrives; a partial cut stops where the
// blade stopped; a cut stays cut after the blade has gone (the halves pulled apart carry
// almost no force); the momentum the slicer takes balances the tissue's; the spine pushes
// without cutting. CPU backend (the kernels are the CUDA ones).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "mpm/scene.h"
#include "cutting_scene.h"
#include "pieces.h"
#include "shapes/shape_builder.h"
#include "tools/tool_builder.h"
#include "solver_cases.h"
#include "tools/blade.h"

namespace mpm {
namespace {

constexpr float kDx = test::kCutDx;
using test::kBlockHalf;
// The cut plane lies off the node layers (a node on it belongs to neither side).
constexpr float kCutZ = 0.0032f;

SceneSettings settingsFor(SolverType solver) { return test::cuttingSettings(solver); }
ParticleObjectDesc block() { return test::cutBlock(); }

/// A blade in the plane z = kCutZ, its edge along x at height `edgeY`, reaching up to the
/// spine 10 cm above it (it stays above the block), moving with `velocity`.
QuadSlicerDesc blade(float edgeY, Vec3f velocity = {0.f, 0.f, 0.f}) {
  QuadSlicerDesc d;
  d.halfLength = 0.06f;  // past the block's sides
  d.width = 0.1f;
  d.pose.position = {0.f, edgeY, kCutZ};
  d.linearVelocity = velocity;
  return d;
}

/// Pairs of particles closer than 1.5 spacings whose midpoint lies in a height range and
/// that straddle the cut plane.
int bondsAcross(const std::vector<Vec3f>& x, float spacing, float yLow, float yHigh) {
  const float r2 = (1.5f * spacing) * (1.5f * spacing);
  int count = 0;
  for (size_t i = 0; i < x.size(); ++i)
    for (size_t j = i + 1; j < x.size(); ++j) {
      const Vec3f d = x[i] - x[j];
      const float y = 0.5f * (x[i].y + x[j].y);
      if (dot(d, d) < r2 && y > yLow && y < yHigh && (x[i].z - kCutZ) * (x[j].z - kCutZ) < 0.f) ++count;
    }
  return count;
}

/// Runs frames of 1/120 s until `t` seconds have passed.
void runFor(Scene& scene, double t) {
  const float frame = 1.f / 120.f;
  for (int i = 0, n = (int)std::lround(t / frame); i < n; ++i) scene.step(frame);
}

// ---------------------------------------------------------------------------------------
// The side test (tools/blade.h, transfer/cut.h): a particle beside the blade records the blade's plane,
// and the stencil nodes across it are flagged; nothing is recorded past the edge or within
// the spine's reach, so pairs across the spine are never flagged.

PartView bladePart(const QuadSlicerDesc& d, float dx) {
  std::vector<BodyView> bodies;
  std::vector<PartView> parts;
  appendSlicer(d, {d.pose, d.linearVelocity, d.angularVelocity}, 0.5f * dx, {0.f, 0.f, 0.f}, nullptr, nullptr, bodies,
               parts);
  return parts[0];
}

/// The grid of settingsFor's domain, for the unit-level tests.
GridGeometry testGrid() {
  GridGeometry geo;
  geo.lower = {-0.1f, -0.1f, -0.1f};
  geo.dx = kDx;
  geo.invDx = 1.f / kDx;
  for (int a = 0; a < 3; ++a) geo.cells[a] = 20, geo.blocks[a] = 6;
  return geo;
}

TEST(CutSideTest, StraddlingPairsAreFlaggedForAQuad) {
  const QuadSlicerDesc d = blade(-0.05f);
  const PartView p = bladePart(d, kDx);
  const GridGeometry geo = testGrid();
  int flagged = 0, wrong = 0;
  for (float z : {-0.012f, -0.004f, 0.001f, 0.0031f, 0.0045f, 0.011f, 0.0151f}) {
    const Vec3f x{0.0013f, 0.f, z};
    CutPlane cut;
    recordCut(cut, x, p, kDx);
    const bool near = std::fabs(z - kCutZ) <= 1.5f * kDx;
    ASSERT_EQ(isCut(cut), near) << "z = " << z;
    if (!near) continue;
    EXPECT_FLOAT_EQ(cut.normal.z, z >= kCutZ ? 1.f : -1.f);
    EXPECT_NEAR(cut.offset, std::fabs(z - kCutZ), 1e-7f);
    const QuadraticStencil st(geo, x);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k) {
          const Vec3f node = geo.lower + kDx * Vec3f{(float)(st.base[0] + i), (float)(st.base[1] + j),
                                                    (float)(st.base[2] + k)};
          const bool across = (node.z - kCutZ) * (z - kCutZ) < 0.f;
          const bool keep = sameSide(cut, node - x);
          flagged += !keep;
          wrong += keep == across;
        }
  }
  EXPECT_EQ(wrong, 0) << "nodes whose side the test got wrong";
  EXPECT_GT(flagged, 0);
}

TEST(CutSideTest, NothingIsRecordedPastTheEdgeOrAtTheSpine) {
  QuadSlicerDesc d = blade(0.f);
  d.spineRadius = 0.01f;
  const PartView p = bladePart(d, kDx);
  // beside the blade, between the edge and the spine's reach: cut
  for (float y : {0.0005f, 0.05f, 0.0895f}) {
    CutPlane cut;
    recordCut(cut, {0.f, y, kCutZ + 0.004f}, p, kDx);
    EXPECT_TRUE(isCut(cut)) << "y = " << y;
  }
  // ahead of the edge, within the spine's radius, past the spine, past the blade's ends
  for (Vec3f x : {Vec3f{0.f, -0.0005f, kCutZ + 0.004f}, Vec3f{0.f, 0.0905f, kCutZ + 0.004f},
                  Vec3f{0.f, 0.105f, kCutZ + 0.004f}, Vec3f{0.0605f, 0.05f, kCutZ + 0.004f}}) {
    CutPlane cut;
    recordCut(cut, x, p, kDx);
    EXPECT_FALSE(isCut(cut)) << "at (" << x.x << ", " << x.y << ", " << x.z << ")";
  }
}

using test::arcBlade;
using test::kArcCentreZ;
using test::kArcRadius;
/// Distance of x from the arc's cylinder, outside positive.
float arcSide(Vec3f x) { return std::hypot(x.x, x.z - kArcCentreZ) - kArcRadius; }

TEST(CutSideTest, StraddlingPairsAreFlaggedForACurvedBlade) {
  const MeshSlicerDesc d = arcBlade(-0.05f);
  CurvedBlade curved;
  curved.grid = std::make_shared<const SignedDistanceGrid>(buildBladeGrid(d.blade, 0.25f * kDx, 3.f * kDx));
  std::vector<BodyView> bodies;
  std::vector<PartView> parts;
  appendSlicer(commonFields(d), {d.pose, d.linearVelocity, d.angularVelocity}, 0.5f * kDx, {0.f, 0.f, 0.f}, &curved,
               curved.grid->values.data(), bodies, parts);
  const PartView& p = parts[0];
  ASSERT_EQ(p.type, kPartCurvedBlade);
  const GridGeometry geo = testGrid();
  int recorded = 0, checked = 0, wrong = 0;
  for (float x = -0.03f; x <= 0.03f; x += 0.0071f)
    for (float off : {-0.012f, -0.006f, -0.001f, 0.002f, 0.007f, 0.013f}) {
      // a particle `off` from the arc along its radius
      const float a = std::asin(x / kArcRadius);
      const Vec3f xp{(kArcRadius + off) * std::sin(a), 0.f, kArcCentreZ + (kArcRadius + off) * std::cos(a)};
      CutPlane cut;
      recordCurvedCut(cut, xp, p, geo);
      ASSERT_TRUE(isCut(cut)) << "x " << x << " off " << off;
      ++recorded;
      EXPECT_LE(cut.offset, std::fabs(off) + 5e-5f);  // the facets' sag
      const QuadraticStencil st(geo, xp);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          for (int k = 0; k < 3; ++k) {
            const Vec3f node = geo.lower + kDx * Vec3f{(float)(st.base[0] + i), (float)(st.base[1] + j),
                                                      (float)(st.base[2] + k)};
            // every node across the arc is across the particle's plane (nodes within the
            // facets' sag, 4.3e-5 m, of the arc may go either way)
            if (std::fabs(arcSide(node)) < 5e-5f) continue;
            ++checked;
            wrong += arcSide(node) * off < 0.f && sameSide(cut, node - xp);
          }
    }
  std::printf("[cut] curved blade: %d particles recorded, %d stencil nodes checked, %d across the arc but not the plane\n",
              recorded, checked, wrong);
  EXPECT_EQ(wrong, 0);
  // past the arc's ends there is no blade: nothing recorded
  CutPlane past;
  recordCurvedCut(past, {0.06f, 0.f, kArcCentreZ + 0.035f}, p, geo);
  EXPECT_FALSE(isCut(past));
}

// ---------------------------------------------------------------------------------------

class Cutting : public ::testing::TestWithParam<SolverType> {
 protected:
  SolverType solver() const { return GetParam(); }
};

// A blade stands through the whole block. A kinematic plate pushes the far side (z > cut)
// toward it. The near half must not feel it: its particles end bit for bit as they do with
// the plate at rest, so no mass or momentum crossed the blade. After every step no particle
// lies inside the blade's band.
void nothingCrosses(SolverType solver, bool curved) {
  auto run = [&](float plateSpeed, std::vector<Vec3f>& x, std::vector<Vec3f>& v, float& inBand) {
    Scene scene(settingsFor(solver));
    const ParticleObjectId id = scene.addParticleObject(block());
    if (curved)
      scene.addSlicer(arcBlade(-0.05f));
    else
      scene.addSlicer(blade(-0.05f));
    ShapeDesc plate;
    plate.parts.push_back(Geometry::box({0.06f, 0.04f, 0.01f}));
    plate.pose.position = {0.f, 0.f, kBlockHalf.z + 0.01f};
    plate.linearVelocity = {0.f, 0.f, -plateSpeed};
    scene.addShape(plate);
    inBand = 0.f;
    for (int i = 0; i < 24; ++i) {
      scene.step(1.f / 120.f);
      scene.readPositions(id, x);
      for (const Vec3f& p : x) inBand = std::max(inBand, 0.5f * kDx - std::fabs(curved ? arcSide(p) : p.z - kCutZ));
    }
    scene.readVelocities(id, v);
  };
  std::vector<Vec3f> x0, v0, x1, v1;
  float band0 = 0.f, band1 = 0.f;
  run(0.f, x0, v0, band0);
  run(0.05f, x1, v1, band1);
  ASSERT_EQ(x0.size(), x1.size());
  int nearHalf = 0, differ = 0;
  float farSpeed = 0.f, nearChange = 0.f;
  for (size_t i = 0; i < x0.size(); ++i) {
    if (curved ? arcSide(x0[i]) < 0.f : x0[i].z < kCutZ) {
      ++nearHalf;
      nearChange = std::max(nearChange, norm(v1[i] - v0[i]));
      differ += x0[i].x != x1[i].x || x0[i].y != x1[i].y || x0[i].z != x1[i].z || v0[i].x != v1[i].x ||
                v0[i].y != v1[i].y || v0[i].z != v1[i].z;
    } else {
      farSpeed = std::max(farSpeed, norm(v1[i]));
    }
  }
  std::printf("[cut] %s %s blade: near side %d particles, %d differ (by up to %.2e m/s); far side fastest %.4f m/s; "
              "deepest in band %.2e m\n",
              test::solverName(solver).c_str(), curved ? "curved" : "quad", nearHalf, differ, nearChange, farSpeed,
              std::max(band0, band1));
  EXPECT_GT(nearHalf, 0);
  EXPECT_EQ(differ, 0) << "particles of the near side changed when only the far side was pushed";
  EXPECT_GT(farSpeed, 0.01f) << "the plate did push the far side";
  // the curved blade is a mesh of 24 facets: the arc lies up to their sag, 4.3e-5 m, off it
  EXPECT_LE(std::max(band0, band1), curved ? 5e-5f : 1e-6f) << "a particle ended inside the blade's band";
}

TEST_P(Cutting, NothingCrossesTheBlade) { nothingCrosses(solver(), false); }
// The same with the curved blade through the block: its two sides are the arc's inside and
// outside.
TEST_P(Cutting, NothingCrossesACurvedBlade) { nothingCrosses(solver(), true); }

// A blade moving down through the block: one piece while it is on its way, two once its edge
// has passed the bottom. (The pieces are what the faces' push-out makes: this passes without
// the pair test too. NothingCrossesTheBlade and ACutStaysCutAfterTheBladeHasGone are the ones
// that fail without it.) Stopped half way, the cut ends where the edge stopped: no bond
// crosses the plane above the edge, the material below it stays joined, one piece.
TEST_P(Cutting, AFullCutMakesTwoPiecesAndAPartialCutStopsAtTheEdge) {
  const float speed = 0.2f;
  const float spacing = 0.5f * kDx;
  {
    Scene scene(settingsFor(solver()));
    const ParticleObjectId id = scene.addParticleObject(block());
    const SlicerId s = scene.addSlicer(blade(kBlockHalf.y + 0.01f, {0.f, -speed, 0.f}));
    std::vector<Vec3f> x;
    runFor(scene, 0.025);  // edge 5 mm above the top
    scene.readPositions(id, x);
    const int before = test::pieces(x, spacing);
    runFor(scene, 0.35 - 0.025);  // edge 2 cm below the bottom
    scene.readPositions(id, x);
    const int after = test::pieces(x, spacing);
    std::printf("[cut] %s full cut: %d piece(s) before the blade arrives, %d after; edge at %.3f m\n",
                test::solverName(solver()).c_str(), before, after, scene.slicerState(s).pose.position.y);
    EXPECT_EQ(before, 1);
    EXPECT_EQ(after, 2);
  }
  {
    Scene scene(settingsFor(solver()));
    const ParticleObjectId id = scene.addParticleObject(block());
    const SlicerId s = scene.addSlicer(blade(kBlockHalf.y + 0.01f, {0.f, -speed, 0.f}));
    runFor(scene, 0.15);  // the edge at the block's mid-height
    ShapeState st = scene.slicerState(s);
    const float edge = st.pose.position.y;
    st.linearVelocity = {0.f, 0.f, 0.f};
    scene.setSlicerState(s, st);
    runFor(scene, 0.1);
    std::vector<Vec3f> x;
    scene.readPositions(id, x);
    const int above = bondsAcross(x, spacing, edge + kDx, 1.f);
    const int below = bondsAcross(x, spacing, -1.f, edge - kDx);
    const int n = test::pieces(x, spacing);
    std::printf("[cut] %s partial cut, edge at %.4f m: %d bonds across above the edge, %d below, %d piece(s)\n",
                test::solverName(solver()).c_str(), edge, above, below, n);
    EXPECT_NEAR(edge, 0.f, 2e-4f);
    EXPECT_EQ(above, 0);
    EXPECT_GT(below, 20);
    EXPECT_EQ(n, 1);
  }
}

// A cut stays cut. Bonded plates hold the block's two z faces; a blade cuts it through and
// is removed; then the plates pull the halves apart, their speed ramped up smoothly. The
// force the far plate carries, averaged over the last 50 ms, against the uncut block's at
// the same displacement: below 2 %. (Cut only while the blade is there, the halves would
// join again: the gap the blade leaves is within the kernel's reach.)
TEST_P(Cutting, ACutStaysCutAfterTheBladeHasGone) {
  auto pull = [&](bool cut) {
    Scene scene(settingsFor(solver()));
    scene.addParticleObject(block());
    ShapeId plates[2];
    for (int side = 0; side < 2; ++side) {
      ShapeDesc plate;
      plate.parts.push_back(Geometry::box({0.05f, 0.03f, 0.005f}));
      plate.pose.position = {0.f, 0.f, (side ? 1.f : -1.f) * (kBlockHalf.z + 0.005f)};
      plate.contact.mode = ContactMode::Bonded;
      plates[side] = scene.addShape(plate);
    }
    const float frame = 1.f / 240.f;
    if (cut) {
      const SlicerId s = scene.addSlicer(blade(kBlockHalf.y + 0.01f, {0.f, -0.2f, 0.f}));
      for (int i = 0; i < 84; ++i) scene.step(frame);  // 0.35 s: the edge 2 cm below the block
      scene.removeSlicer(s);
    } else {
      for (int i = 0; i < 84; ++i) scene.step(frame);
    }
    for (int i = 0; i < 24; ++i) scene.step(frame);  // settle
    // pull: each plate outward at up to 2 cm/s, ramped over 50 ms, for 0.2 s
    const float top = 0.02f, ramp = 0.05f;
    double t = 0, force = 0;
    int samples = 0;
    for (int i = 0; i < 48; ++i) {
      const double a = std::min(1.0, (t + 0.5 * frame) / ramp);
      const float v = top * (float)(a * a * (3 - 2 * a));
      for (int side = 0; side < 2; ++side) {
        ShapeState st = scene.shapeState(plates[side]);
        st.linearVelocity = {0.f, 0.f, (side ? 1.f : -1.f) * v};
        scene.setShapeState(plates[side], st);
      }
      scene.step(frame);
      t += frame;
      if (i >= 36) {
        force += -scene.shapeImpulse(plates[1]).linear.z / frame;  // the material pulls the plate back
        ++samples;
      }
    }
    return force / samples;
  };
  const double uncut = pull(false), cut = pull(true);
  std::printf("[cut] %s pulled apart: uncut %.4f N, cut %.5f N (%.2f %%)\n", test::solverName(solver()).c_str(), uncut,
              cut, 100.0 * cut / uncut);
  EXPECT_GT(uncut, 0.1);
  EXPECT_LT(std::fabs(cut), 0.02 * uncut);
}

// Momentum: with gravity off, the tissue's momentum plus the impulses the slicer took stays
// what it was. The blade cuts down while moving across its plane, so its face pushes the
// far half, and the tissue resists the cut (G_c 0.5 J/m^2: the block is free, and a tougher
// one would be thrown into the domain's walls). For PB-MPM the blade's impulse must not grow with the iteration count (each
// iteration exchanges again).
TEST_P(Cutting, TheSlicerTakesTheMomentumTheTissueLoses) {
  auto run = [&](int iterations, double& drift, double& scale, double& impulseZ) {
    SceneSettings settings = settingsFor(solver());
    settings.pbMpm.iterations = iterations;
    Scene scene(settings);
    ParticleObjectDesc tough = block();
    tough.material.fractureToughness = 0.5f;
    const ParticleObjectId id = scene.addParticleObject(tough);
    const SlicerId s = scene.addSlicer(blade(kBlockHalf.y + 0.01f, {0.f, -0.2f, 0.05f}));
    double J[3] = {0, 0, 0};
    for (int i = 0; i < 42; ++i) {
      scene.step(1.f / 120.f);
      const ShapeImpulse imp = scene.slicerImpulse(s);
      for (int a = 0; a < 3; ++a) J[a] += imp.linear[a];
    }
    const ObjectSummary sum = scene.summary(id);
    drift = 0, scale = 0;
    for (int a = 0; a < 3; ++a) {
      drift = std::max(drift, std::fabs(sum.momentum[a] + J[a]));
      scale = std::max(scale, std::fabs(J[a]));
    }
    impulseZ = J[2];
  };
  double drift, scale, impulseZ;
  run(10, drift, scale, impulseZ);
  std::printf("[cut] %s momentum: slicer impulse %.4e N s (z %.4e), tissue + slicer %.3e (%.2e relative)\n",
              test::solverName(solver()).c_str(), scale, impulseZ, drift, drift / scale);
  EXPECT_GT(scale, 1e-5) << "the blade did push the tissue";
  EXPECT_LT(drift, 1e-4 * scale);
  if (solver() == SolverType::PbMpm) {
    double drift20, scale20, impulseZ20;
    run(20, drift20, scale20, impulseZ20);
    std::printf("[cut] PbMpm, 20 iterations: slicer impulse z %.4e N s (10 iterations: %.4e)\n", impulseZ20, impulseZ);
    EXPECT_LT(std::fabs(impulseZ20 / impulseZ - 1.0), 0.2);
  }
}

// The spine is blunt: pushed 1 cm into the block's top (the blade upside down, spine first)
// it cuts nothing, one piece stays, and it pushes as a capsule of its radius does (the
// force within 10 % of the capsule's). The block's bottom is bonded to a base.
TEST_P(Cutting, TheSpinePushesWithoutCutting) {
  const float speed = 0.1f, radius = 0.01f, depth = 0.01f;
  const float startY = kBlockHalf.y + radius + 0.005f;
  const double pushTime = (0.005 + depth) / speed;
  auto push = [&](bool spine, int& n) {
    Scene scene(settingsFor(solver()));
    const ParticleObjectId id = scene.addParticleObject(block());
    ShapeDesc base;  // holds the block's bottom
    base.parts.push_back(Geometry::box({0.06f, 0.005f, 0.05f}));
    base.pose.position = {0.f, -kBlockHalf.y - 0.005f, 0.f};
    base.contact.mode = ContactMode::Bonded;
    scene.addShape(base);
    SlicerId s;
    ShapeId c;
    if (spine) {
      QuadSlicerDesc d = blade(0.f);
      d.spineRadius = radius;
      d.width = 0.06f;
      d.pose.rotation = {0.f, 0.f, 0.f, 1.f};  // half a turn about z: the spine below the edge
      d.pose.position = {0.f, startY + d.width, kCutZ};
      d.linearVelocity = {0.f, -speed, 0.f};
      s = scene.addSlicer(d);
    } else {
      ShapeDesc cap;
      Geometry g;
      g.type = GeometryType::Capsule;
      g.axis = 0;
      g.radius = radius;
      g.halfHeight = 0.06f;
      cap.parts.push_back(g);
      cap.contact.mode = ContactMode::Sticky;
      cap.pose.position = {0.f, startY, kCutZ};
      cap.linearVelocity = {0.f, -speed, 0.f};
      c = scene.addShape(cap);
    }
    const float frame = 1.f / 240.f;
    double force = 0;
    const int frames = (int)std::lround(pushTime / frame);
    for (int i = 0; i < frames; ++i) {
      scene.step(frame);
      if (i == frames - 1) force = (spine ? scene.slicerImpulse(s) : scene.shapeImpulse(c)).linear.y / frame;
    }
    std::vector<Vec3f> x;
    scene.readPositions(id, x);
    n = test::pieces(x, 0.5f * kDx);
    return force;
  };
  int nSpine = 0, nCapsule = 0;
  const double fSpine = push(true, nSpine), fCapsule = push(false, nCapsule);
  std::printf("[cut] %s spine 1 cm in: %.4f N, %d piece(s); capsule %.4f N, %d piece(s)\n",
              test::solverName(solver()).c_str(), fSpine, nSpine, fCapsule, nCapsule);
  EXPECT_EQ(nSpine, 1);
  EXPECT_GT(fCapsule, 0.01);
  EXPECT_LT(std::fabs(fSpine / fCapsule - 1.0), 0.1);
}

// Toughness: a blade drawn sideways through a block (bonded at its base) at depth d cuts
// with its leading end, and feels G_c d against its motion once that end is inside. The
// force averaged while the end crosses the middle half of the block, for two toughness
// values and two depths: within 20 % of G_c d. And with half the cell size (MLS-MPM, one
// case: eight times the particles) it changes by less than 15 %.
double steadyCuttingForce(SolverType solver, float dx, float toughness, float depth) {
  SceneSettings settings = settingsFor(solver);
  settings.dx = dx;
  Scene scene(settings);
  ParticleObjectDesc b = block();
  b.material.youngsModulus = 1e5f;
  b.material.fractureToughness = toughness;
  scene.addParticleObject(b);
  ShapeDesc base;
  base.parts.push_back(Geometry::box({0.06f, 0.005f, 0.05f}));
  base.pose.position = {0.f, -kBlockHalf.y - 0.005f, 0.f};
  base.contact.mode = ContactMode::Bonded;
  scene.addShape(base);
  const float speed = 0.1f;
  QuadSlicerDesc d = blade(kBlockHalf.y - depth, {-speed, 0.f, 0.f});
  d.halfLength = 0.02f;
  d.pose.position.x = kBlockHalf.x + d.halfLength + 0.005f;  // its leading end 5 mm off the block
  const SlicerId s = scene.addSlicer(d);
  const float frame = 1.f / 240.f;
  double force = 0;
  int samples = 0;
  for (int i = 0; i < 240; ++i) {
    scene.step(frame);
    const float lead = scene.slicerState(s).pose.position.x - d.halfLength;
    if (std::fabs(lead) < 0.5f * kBlockHalf.x) {
      force += scene.slicerImpulse(s).linear.x / frame;
      ++samples;
    }
    if (lead < -kBlockHalf.x) break;
  }
  return samples ? force / samples : 0.0;
}

TEST_P(Cutting, TheBladeFeelsTheToughnessTimesTheDepth) {
  for (float gc : {20.f, 50.f})
    for (float depth : {0.01f, 0.02f}) {
      const double f = steadyCuttingForce(solver(), kDx, gc, depth), expected = gc * depth;
      std::printf("[cut] %s G_c %.0f J/m^2, depth %.0f mm: %.4f N, G_c d = %.4f N (%+.1f %%)\n",
                  test::solverName(solver()).c_str(), gc, depth * 1e3, f, expected, 100.0 * (f / expected - 1.0));
      EXPECT_NEAR(f, expected, 0.2 * expected);
    }
  const double none = steadyCuttingForce(solver(), kDx, 0.f, 0.02f);
  std::printf("[cut] %s G_c 0: %.5f N\n", test::solverName(solver()).c_str(), none);
  EXPECT_LT(std::fabs(none), 0.01) << "without toughness the blade cuts freely";
}

// The cut is part of the saved state: a scene saved half way through a cut and loaded into
// a fresh scene steps on bit for bit as the one that was saved, the blade and the cut
// included; a scene that loads it after cutting elsewhere has its own cut replaced.
TEST(CuttingCheckpoint, ACutSceneResumesBitForBit) {
  auto make = [] {
    auto scene = std::make_unique<Scene>(settingsFor(SolverType::MlsMpm));
    scene->addParticleObject(block());
    return scene;
  };
  std::unique_ptr<Scene> a = make();
  const SlicerId s = a->addSlicer(blade(kBlockHalf.y + 0.01f, {0.f, -0.2f, 0.f}));
  runFor(*a, 0.15);
  const std::vector<uint8_t> saved = a->saveToMemory();
  std::unique_ptr<Scene> b = make();
  b->addSlicer(blade(0.f, {0.f, 0.f, 0.1f}));  // another blade, cutting elsewhere
  runFor(*b, 0.05);
  b->loadFromMemory(saved);
  ASSERT_TRUE(b->isValid(s));
  runFor(*a, 0.2);
  runFor(*b, 0.2);
  std::vector<Vec3f> xa, xb;
  a->readPositions(ParticleObjectId{0, 0}, xa);
  b->readPositions(ParticleObjectId{0, 0}, xb);
  ASSERT_EQ(xa.size(), xb.size());
  int differ = 0;
  for (size_t i = 0; i < xa.size(); ++i) differ += xa[i].x != xb[i].x || xa[i].y != xb[i].y || xa[i].z != xb[i].z;
  EXPECT_EQ(differ, 0);
  EXPECT_EQ(test::pieces(xb, 0.5f * kDx), 2) << "the loaded scene finished the cut";
  EXPECT_EQ(a->slicerState(s).pose.position.y, b->slicerState(s).pose.position.y);
}

// Bad slicers are refused naming the field and the value; the scene keeps stepping.
TEST(CuttingValidation, BadSlicersAreRefusedByName) {
  Scene scene(settingsFor(SolverType::MlsMpm));
  scene.addParticleObject(block());
  auto refused = [&](auto desc, const std::string& field) {
    try {
      scene.addSlicer(desc);
      ADD_FAILURE() << field << " was accepted";
    } catch (const InvalidArgument& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  QuadSlicerDesc q = blade(0.f);
  q.halfLength = -1.f;
  refused(q, "QuadSlicerDesc.halfLength");
  q = blade(0.f);
  q.spineRadius = q.width;
  refused(q, "QuadSlicerDesc.spineRadius");
  q = blade(0.f);
  q.pose.position.x = std::nanf("");
  refused(q, "ShapeState.pose.position");
  MeshSlicerDesc m = arcBlade(0.f);
  std::swap(m.blade.indices[1], m.blade.indices[2]);  // one triangle turned over
  refused(m, "MeshSlicerDesc.blade");
  m = arcBlade(0.f);
  m.spineRadius = -0.01f;
  refused(m, "MeshSlicerDesc.spineRadius");
  EXPECT_THROW(scene.setSlicerState(SlicerId{}, ShapeState{}), InvalidArgument);
  SceneSettings meshless = settingsFor(SolverType::Mtled);
  Scene mtled(meshless);
  try {
    mtled.addSlicer(blade(0.f));
    ADD_FAILURE() << "MTLED accepted a slicer";
  } catch (const InvalidArgument& e) {
    EXPECT_NE(std::string(e.what()).find("SceneSettings.solver"), std::string::npos) << e.what();
  }
  scene.step(1.f / 120.f);  // still steps
}

TEST(CuttingConvergence, TheToughnessForceHoldsWithHalfTheCellSize) {
  const double coarse = steadyCuttingForce(SolverType::MlsMpm, kDx, 50.f, 0.02f);
  const double fine = steadyCuttingForce(SolverType::MlsMpm, 0.5f * kDx, 50.f, 0.02f);
  std::printf("[cut] MlsMpm G_c 50 J/m^2, depth 20 mm: dx 10 mm %.4f N, dx 5 mm %.4f N (%+.1f %%)\n", coarse, fine,
              100.0 * (fine / coarse - 1.0));
  EXPECT_LT(std::fabs(fine / coarse - 1.0), 0.15);
}

// A curved blade moved down through the block cuts it along its curve: two pieces, each on
// one side of the arc's cylinder (no particle of a piece on the other side).
TEST_P(Cutting, ACurvedBladeCutsAlongItsCurve) {
  Scene scene(settingsFor(solver()));
  const ParticleObjectId id = scene.addParticleObject(block());
  scene.addSlicer(arcBlade(kBlockHalf.y + 0.01f, {0.f, -0.2f, 0.f}));
  runFor(scene, 0.35);
  std::vector<Vec3f> x;
  scene.readPositions(id, x);
  // the pieces, and how many of each piece's particles lie inside the arc's cylinder
  const float link = 1.5f * 0.5f * kDx;
  std::vector<size_t> parent(x.size());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](size_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (size_t i = 0; i < x.size(); ++i)
    for (size_t j = i + 1; j < x.size(); ++j) {
      const Vec3f d = x[i] - x[j];
      if (dot(d, d) < link * link) parent[find(i)] = find(j);
    }
  std::map<size_t, std::pair<int, int>> inOut;  // root -> (inside, outside)
  float closest = 1.f;
  for (size_t i = 0; i < x.size(); ++i) {
    auto& c = inOut[find(i)];
    (arcSide(x[i]) < 0.f ? c.first : c.second)++;
    closest = std::min(closest, std::fabs(arcSide(x[i])));
  }
  int mixed = 0;
  for (const auto& c : inOut) mixed += std::min(c.second.first, c.second.second);
  std::printf("[cut] %s curved blade: %zu piece(s), %d particles on the wrong side of the arc, nearest %.2f mm\n",
              test::solverName(solver()).c_str(), inOut.size(), mixed, closest * 1e3);
  EXPECT_EQ(inOut.size(), 2u);
  EXPECT_EQ(mixed, 0);
}

INSTANTIATE_TEST_SUITE_P(GridSolvers, Cutting, test::allSolvers(), test::solverParamName());

}  // namespace
}  // namespace mpm
