// MTLED (SolverType::Mtled) against the cylinder of Horton et al. 2010: 20 %
// compression of a decoupled Neo-Hookean cylinder between two plates over T = 3 s with
// the smooth ramp of eq. 43, compared with the CalculiX references in tests/reference
// (see its README). The scene is scenes::CylinderBetweenPlates (axis along y, no gravity,
// kinematic box plates; the force is the impulse the nodes gave the top plate over a
// frame, divided by the frame).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "mpm/scene.h"
#include "scenes/standard_scenes.h"
#include "settings_checks.h"
#include "test_paths.h"

namespace mpm {
namespace {

using scenes::CylinderBetweenPlates;
constexpr double kRampTime = CylinderBetweenPlates::kRampTime;

/// Columns of a reference CSV in tests/reference.
std::vector<std::vector<double>> readCsv(const std::string& name) {
  return CylinderBetweenPlates::readCsv(test::referencePath(name));
}

/// Runs the compression with nodes `spacing` apart; forces sampled at the reference times
/// 0.1 s, 0.2 s, ... (each the mean over a frame centred on the time, so the mean is the
/// value at the sample to second order).
CylinderBetweenPlates::Run compressCylinder(float spacing, ContactMode ends, bool smoothedStrain = true) {
  CylinderBetweenPlates::Setup setup;
  setup.solver = SolverType::Mtled;
  setup.resolution = spacing;
  setup.ends = ends;
  setup.smoothedStrain = smoothedStrain;
  return CylinderBetweenPlates::run(setup, CylinderBetweenPlates::Loading::Compression, 0.01, 0.1);
}

/// Reference value at time t (the CSVs are tabulated every 0.1 s).
double at(const std::vector<double>& times, const std::vector<double>& values, double t) {
  const double v = CylinderBetweenPlates::at(times, values, t);
  if (std::isnan(v)) ADD_FAILURE() << "no reference value at t = " << t;
  return std::isnan(v) ? 0 : v;
}

/// Slip ends against the closed-form homogeneous solution: the largest deviation over the
/// ramp and the final one, both relative to the final force (early samples are small and
/// carry the wave noise).
struct SlipErrors {
  double worst = 0, final = 0;
};
SlipErrors slipErrors(const CylinderBetweenPlates::Run& run, const char* label) {
  const auto ref = readCsv("cylinder_compression_slip.csv");  // t, FE force, closed-form force
  SlipErrors e;
  if (run.time.empty()) {
    ADD_FAILURE() << "no samples";
    return e;
  }
  const double finalRef = at(ref[0], ref[2], kRampTime);
  for (size_t i = 0; i < run.time.size(); ++i) {
    const double expected = at(ref[0], ref[2], run.time[i]);
    e.worst = std::max(e.worst, std::abs(run.axialForce[i] - expected) / std::abs(finalRef));
    std::printf("  t = %.1f s  F = %.5f N  closed form %.5f N  (%.2f %%)\n", run.time[i], run.axialForce[i], expected,
                100 * (run.axialForce[i] - expected) / std::abs(expected));
  }
  e.final = std::abs(run.axialForce.back() - finalRef) / std::abs(finalRef);
  std::printf("slip, %s: %zu nodes, substep %.3g s, %.1f s; final %.2f %%, largest deviation %.2f %% of the final force\n",
              label, run.particles, run.substepDt, run.wallSeconds, 100 * e.final, 100 * e.worst);
  return e;
}

/// Bonded ends against the extrapolated finite-element curve: final and L2 errors.
struct BondedErrors {
  double final = 0, curve = 0;
};
BondedErrors bondedErrors(const CylinderBetweenPlates::Run& run, const char* label) {
  const auto ref = readCsv("cylinder_compression_extrapolated.csv");
  BondedErrors e;
  if (run.time.empty()) {
    ADD_FAILURE() << "no samples";
    return e;
  }
  double diff2 = 0, ref2 = 0;
  for (size_t i = 0; i < run.time.size(); ++i) {
    const double expected = at(ref[0], ref[1], run.time[i]);
    diff2 += (run.axialForce[i] - expected) * (run.axialForce[i] - expected);
    ref2 += expected * expected;
    std::printf("  t = %.1f s  F = %.5f N  reference %.5f N  (%.2f %%)\n", run.time[i], run.axialForce[i], expected,
                100 * (run.axialForce[i] - expected) / std::abs(expected));
  }
  const double finalRef = at(ref[0], ref[1], kRampTime);
  e.final = std::abs(run.axialForce.back() - finalRef) / std::abs(finalRef);
  e.curve = std::sqrt(diff2 / ref2);
  std::printf("bonded, %s: %zu nodes, substep %.3g s, %.1f s; final %.4f N vs %.4f N (%.2f %%), curve L2 %.2f %%\n",
              label, run.particles, run.substepDt, run.wallSeconds, run.axialForce.back(), finalRef, 100 * e.final,
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
