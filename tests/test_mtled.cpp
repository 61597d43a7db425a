// MTLED (SolverType::Mtled) against the seed 004 cylinder: 20 % compression of a decoupled
// Neo-Hookean cylinder between two plates over T = 3 s with the smooth ramp of eq. 43,
// compared with the CalculiX references in tests/reference (see its README). Axis along y
// (the library's up axis), no gravity. The plates are kinematic box shapes; the force is
// the impulse the nodes gave the top plate over a frame, divided by the frame.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "mpm/scene.h"
#include "settings_checks.h"
#include "test_paths.h"

namespace mpm {
namespace {

constexpr double kRadius = 0.05, kHeight = 0.1, kCompression = 0.02, kRampTime = 3.0;
constexpr double kMu = 1007.0, kBulk = 50001.333, kDensity = 1000.0;  // reference README

/// Plate displacement of eq. 43: u(t) = D (10 - 15 s + 6 s^2) s^3, s = t / T.
double ramp(double t) {
  const double s = std::min(std::max(t / kRampTime, 0.0), 1.0);
  return kCompression * (10 - 15 * s + 6 * s * s) * s * s * s;
}

/// Columns of a reference CSV ('#' lines are comments, one header line).
std::vector<std::vector<double>> readCsv(const std::string& name) {
  std::ifstream in(test::referencePath(name));
  EXPECT_TRUE(in.good()) << "cannot open " << test::referencePath(name);
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

struct CylinderRun {
  std::vector<double> time, force;  ///< force on the cylinder from the top plate [N] (negative: compression)
  size_t nodes = 0;
  float substepDt = 0;
  double seconds = 0;
};

/// Runs the compression with nodes `spacing` apart; forces sampled at the reference times
/// 0.1 s, 0.2 s, ... (each the mean over a frame centred on the time, so the mean is the
/// value at the sample to second order).
CylinderRun compressCylinder(float spacing, ContactMode ends, bool smoothedStrain = true) {
  SceneSettings s;
  s.mtled.smoothedStrain = smoothedStrain;
  s.domain = {{-0.1f, -0.05f, -0.1f}, {0.1f, 0.15f, 0.1f}};
  s.domain.walls = false;
  s.dx = 0.01f;
  s.gravity = {0.f, 0.f, 0.f};
  s.solver = SolverType::Mtled;
  s.backend = Backend::Cpu;
  Scene scene(s);

  ParticleObjectDesc cyl;
  cyl.primitive = PrimitiveType::Cylinder;
  cyl.center = {0.f, (float)kHeight / 2, 0.f};
  cyl.radius = (float)kRadius;
  cyl.halfExtents = {0.f, (float)kHeight / 2, 0.f};
  cyl.particleSpacing = spacing;
  // E and nu from mu and K exactly (the rounded nu = 0.48999 would shift K by 0.07 %)
  cyl.material = {MaterialModel::NeoHookeanDecoupled, (float)(9 * kBulk * kMu / (3 * kBulk + kMu)),
                  (float)((3 * kBulk - 2 * kMu) / (2 * (3 * kBulk + kMu))), (float)kDensity};
  const ParticleObjectId id = scene.addParticleObject(cyl);

  // plates wider than the bulged cylinder; nodes on the end faces lie in the band
  const float thick = 0.02f;
  ShapeDesc plate;
  Geometry box;
  box.type = GeometryType::Box;
  box.halfExtents = {0.1f, thick, 0.1f};
  plate.parts = {box};
  plate.contact.mode = ends;
  plate.contact.friction = 0.f;
  plate.contact.band = 0.1f * spacing;
  plate.pose.position = {0.f, -thick, 0.f};
  scene.addShape(plate);
  plate.pose.position = {0.f, (float)kHeight + thick, 0.f};
  const ShapeId top = scene.addShape(plate);

  CylinderRun run;
  run.nodes = scene.particleCount(id);
  const double frame = 0.01, sample = 0.1;
  const auto t0 = std::chrono::steady_clock::now();
  double t = 0;
  // frames [0, f/2], then [k f - f/2, k f + f/2]: every 10th is centred on a sample time,
  // the last on T
  for (int k = 0; t < kRampTime; ++k) {
    const double t1 = k == 0 ? frame / 2 : t + frame;
    ShapeState st;
    st.pose.position = {0.f, (float)(kHeight + thick - ramp(t)), 0.f};
    st.linearVelocity = {0.f, (float)(-(ramp(t1) - ramp(t)) / (t1 - t)), 0.f};
    scene.setShapeState(top, st);
    const StepReport r = scene.step((float)(t1 - t));
    run.substepDt = r.substepDt;
    const double mid = 0.5 * (t + t1);
    if (std::abs(mid / sample - std::round(mid / sample)) < 1e-6 && mid > 1e-6) {
      run.time.push_back(mid);
      // the plate receives +impulse; the force on the cylinder is its opposite
      run.force.push_back(-scene.shapeImpulse(top).linear.y / (t1 - t));
    }
    t = t1;
  }
  run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return run;
}

/// Reference value at time t (the CSVs are tabulated every 0.1 s).
double at(const std::vector<double>& times, const std::vector<double>& values, double t) {
  for (size_t i = 0; i < times.size(); ++i)
    if (std::abs(times[i] - t) < 1e-6) return values[i];
  ADD_FAILURE() << "no reference value at t = " << t;
  return 0;
}

/// Slip ends against the closed-form homogeneous solution: the largest deviation over the
/// ramp and the final one, both relative to the final force (early samples are small and
/// carry the wave noise).
struct SlipErrors {
  double worst = 0, final = 0;
};
SlipErrors slipErrors(const CylinderRun& run, const char* label) {
  const auto ref = readCsv("cylinder_compression_slip.csv");  // t, FE force, closed-form force
  SlipErrors e;
  if (run.time.empty()) {
    ADD_FAILURE() << "no samples";
    return e;
  }
  const double finalRef = at(ref[0], ref[2], kRampTime);
  for (size_t i = 0; i < run.time.size(); ++i) {
    const double expected = at(ref[0], ref[2], run.time[i]);
    e.worst = std::max(e.worst, std::abs(run.force[i] - expected) / std::abs(finalRef));
    std::printf("  t = %.1f s  F = %.5f N  closed form %.5f N  (%.2f %%)\n", run.time[i], run.force[i], expected,
                100 * (run.force[i] - expected) / std::abs(expected));
  }
  e.final = std::abs(run.force.back() - finalRef) / std::abs(finalRef);
  std::printf("slip, %s: %zu nodes, substep %.3g s, %.1f s; final %.2f %%, largest deviation %.2f %% of the final force\n",
              label, run.nodes, run.substepDt, run.seconds, 100 * e.final, 100 * e.worst);
  return e;
}

/// Bonded ends against the extrapolated finite-element curve: final and L2 errors.
struct BondedErrors {
  double final = 0, curve = 0;
};
BondedErrors bondedErrors(const CylinderRun& run, const char* label) {
  const auto ref = readCsv("cylinder_compression_extrapolated.csv");
  BondedErrors e;
  if (run.time.empty()) {
    ADD_FAILURE() << "no samples";
    return e;
  }
  double diff2 = 0, ref2 = 0;
  for (size_t i = 0; i < run.time.size(); ++i) {
    const double expected = at(ref[0], ref[1], run.time[i]);
    diff2 += (run.force[i] - expected) * (run.force[i] - expected);
    ref2 += expected * expected;
    std::printf("  t = %.1f s  F = %.5f N  reference %.5f N  (%.2f %%)\n", run.time[i], run.force[i], expected,
                100 * (run.force[i] - expected) / std::abs(expected));
  }
  const double finalRef = at(ref[0], ref[1], kRampTime);
  e.final = std::abs(run.force.back() - finalRef) / std::abs(finalRef);
  e.curve = std::sqrt(diff2 / ref2);
  std::printf("bonded, %s: %zu nodes, substep %.3g s, %.1f s; final %.4f N vs %.4f N (%.2f %%), curve L2 %.2f %%\n",
              label, run.nodes, run.substepDt, run.seconds, run.force.back(), finalRef, 100 * e.final,
              100 * e.curve);
  return e;
}

// Measured, smoothed strain (the default) | the paper's point derivatives
// (MtledSettings::smoothedStrain), +: stiffer:
//   node spacing        slip, largest deviation   bonded, final / L2
//   0.01 m (891)        0.19 % | 2.9 %            +6.0 / 5.3 % | +1.1 / 0.8 %
//   0.0083 m (1469)     0.40 % | 3.3 %            +1.5 / 1.2 % | +0.1 / 0.7 %
//   0.00625 m (3349)    0.34 % | 3.1 %            +2.4 / 2.0 % | -3.5 / 3.7 %
// Finite elements of the coarsest size are 4.4 % (axisymmetric 8 x 16) and 4.9 % (3-D
// quarter (8,4,12)) stiff in the bonded case and converge slowly from above (reference
// README). The point derivatives are about 3 % soft whatever the spacing (slip), which
// offsets that at the coarse spacings only. The tests run at 0.0083 m, the coarsest
// spacing that meets the goals (1 %; 3 % and 5 %).
constexpr float kSpacing = 0.1f / 12;

TEST(Mtled, SlipCompressionFollowsTheHomogeneousSolution) {
  const SlipErrors e = slipErrors(compressCylinder(kSpacing, ContactMode::Frictional), "smoothed strain");
  EXPECT_LT(e.final, 0.01);
  EXPECT_LT(e.worst, 0.01);
}

TEST(Mtled, BondedCompressionMatchesTheFiniteElementReference) {
  const BondedErrors e = bondedErrors(compressCylinder(kSpacing, ContactMode::Bonded), "smoothed strain");
  EXPECT_LT(e.final, 0.03);
  EXPECT_LT(e.curve, 0.05);
}

// The paper's point derivatives at 0.01 m, bounded at what they achieve so a regression
// shows: slip 2.9 % soft (they fail the patch test), bonded within 1.1 %.
TEST(Mtled, PaperPointDerivativesKeepTheirMeasuredErrors) {
  const SlipErrors slip = slipErrors(compressCylinder(0.01f, ContactMode::Frictional, false), "point derivatives");
  EXPECT_LT(slip.worst, 0.035);
  const BondedErrors bonded = bondedErrors(compressCylinder(0.01f, ContactMode::Bonded, false), "point derivatives");
  EXPECT_LT(bonded.final, 0.03);
  EXPECT_LT(bonded.curve, 0.05);
}

TEST(Mtled, SettingsAreValidated) {
  const auto rejects = [](auto change, const std::string& field) {
    SceneSettings s;
    s.solver = SolverType::Mtled;
    change(s.mtled);
    test::expectSettingsRejected(s, field);
  };
  rejects([](MtledSettings& m) { m.supportNodes = 3; }, "SceneSettings.mtled.supportNodes");
  rejects([](MtledSettings& m) { m.supportNodes = 33; }, "SceneSettings.mtled.supportNodes");
  rejects([](MtledSettings& m) { m.supportScale = 1.f; }, "SceneSettings.mtled.supportScale");
  rejects([](MtledSettings& m) { m.supportScale = NAN; }, "SceneSettings.mtled.supportScale");
  rejects([](MtledSettings& m) { m.integrationCellsPerSpacing = 0.5f; },
          "SceneSettings.mtled.integrationCellsPerSpacing");
  rejects([](MtledSettings& m) { m.integrationCellsPerSpacing = INFINITY; },
          "SceneSettings.mtled.integrationCellsPerSpacing");
  rejects([](MtledSettings& m) { m.timeStepSafety = 0.f; }, "SceneSettings.mtled.timeStepSafety");
  rejects([](MtledSettings& m) { m.timeStepSafety = 1.5f; }, "SceneSettings.mtled.timeStepSafety");

  // a cylinder needs a radius and a height
  Scene scene(SceneSettings{});
  ParticleObjectDesc d;
  d.primitive = PrimitiveType::Cylinder;
  d.radius = -0.1f;
  EXPECT_THROW(scene.addParticleObject(d), InvalidArgument);
  d.radius = 0.1f;
  d.halfExtents.y = 0.f;
  try {
    scene.addParticleObject(d);
    ADD_FAILURE() << "a cylinder of zero height accepted";
  } catch (const InvalidArgument& e) {
    EXPECT_EQ(e.field(), "ParticleObjectDesc.halfExtents.y");
  }
}

}  // namespace
}  // namespace mpm
