// Self-weight: an elastic column on a slip floor shortens by the uniaxial-stress value
// rho g / E * integral (H - z) dz. Gravity is switched on suddenly, so the column
// oscillates about that static value with no damping; the test averages the length
// over whole periods of the fundamental mode, T = 4 H / sqrt(E / rho). MLS-MPM and
// standard MPM are held to the closed form; PB-MPM, whose stiffness is not E, to standing
// and settling.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "column_layers.h"
#include "mpm/scene.h"
#include "solver_cases.h"

namespace mpm {
namespace {

class SelfWeight : public ::testing::TestWithParam<SolverType> {};

TEST_P(SelfWeight, ColumnOnSlipFloorSettlesToUniaxialShortening) {
  const float dx = 0.05f, H = 1.f, rho = 1000.f, E = 5e5f, g = 9.81f;
  SceneSettings s;
  s.solver = GetParam();
  s.domain.lower = {-0.3f, 0.f, -0.3f};
  s.domain.upper = {0.3f, 1.3f, 0.3f};
  s.domain.wallMode = WallMode::Slip;
  s.dx = dx;
  s.gravity = {0.f, -g, 0.f};
  Scene scene(s);
  ParticleObjectDesc d;
  // the floor wall acts on nodes 0 and 1; the column stands on node 2 at y = 2 dx
  d.center = {0.f, 2.f * dx + 0.5f * H, 0.f};
  d.halfExtents = {0.1f, 0.5f * H, 0.1f};
  d.material.model = MaterialModel::FixedCorotated;
  d.material.youngsModulus = E;
  d.material.poissonRatio = 0.3f;
  d.material.density = rho;
  const ParticleObjectId id = scene.addParticleObject(d);

  std::vector<Vec3f> x;
  scene.readPositions(id, x);
  const test::ColumnLayers layers(x);
  auto length = [&] {
    scene.readPositions(id, x);
    return layers.length(x);
  };
  const double L0 = length();
  const double expected = layers.uniaxialShortening(rho, g, E, H, 2 * dx);

  const double period = 4.0 * H / std::sqrt(E / rho);
  const int perPeriod = 40;
  const float frame = (float)(period / perPeriod);
  for (int f = 0; f < 2 * perPeriod; ++f) scene.step(frame);  // two periods of start-up
  double sum = 0, firstHalf = 0;
  const int periods = 8, samples = periods * perPeriod;
  for (int f = 0; f < samples; ++f) {
    scene.step(frame);
    sum += L0 - length();
    if (f == samples / 2 - 1) firstHalf = sum / (samples / 2);
  }
  const double shortening = sum / samples, secondHalf = 2 * shortening - firstHalf;
  std::printf("%s: time-averaged shortening %.4g m (periods 3-6 %.4g, 7-10 %.4g), uniaxial theory %.4g m (%+.2f%%)\n",
              test::solverName(GetParam()).c_str(), shortening, firstHalf, secondHalf, expected,
              100 * (shortening - expected) / expected);
  if (GetParam() == SolverType::PbMpm) {
    // PB-MPM's stiffness comes from its constraint iterations, not from E, so the uniaxial
    // closed form does not apply (measured 0.0149 m, 56% above it at 10 iterations). What
    // holds for it: the column stands (shortening under 5% of H; measured 1.5%) and has
    // settled, its mean length the same over periods 3-6 and 7-10 within 2% of the
    // shortening (measured 0.07%; a column creeping under gravity fails this).
    EXPECT_GT(shortening, 0.0);
    EXPECT_LT(shortening, 0.05 * H) << "the column did not stand";
    EXPECT_NEAR(secondHalf, firstHalf, 0.02 * shortening) << "still creeping";
  } else {
    EXPECT_NEAR(shortening, expected, 0.05 * expected)
        << "time-averaged shortening " << shortening << " m, uniaxial theory " << expected << " m";
  }
}

INSTANTIATE_TEST_SUITE_P(AllSolvers, SelfWeight, test::allSolvers(), test::solverParamName());

}  // namespace
}  // namespace mpm
