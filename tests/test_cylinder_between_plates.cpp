// The cylinder of Horton et al. 2010 ( scenes::CylinderBetweenPlates) with the grid
// solvers: the compression forces of MLS-MPM against the closed form (slip ends) and the
// finite-element reference (bonded ends), a bonded plate holding the cylinder through
// extension, and the conservation checks of the paper's sections 4.7-4.8 for every solver
// (energy balance, a 1 Hz spin).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "mpm/scene.h"
#include "scenes/standard_scenes.h"
#include "solver_cases.h"
#include "test_paths.h"

namespace mpm {
namespace {

using Cylinder = scenes::CylinderBetweenPlates;
constexpr double kPi = 3.14159265358979;

/// Closed-form uniaxial force at stretch lambda [N] (negative in compression) (tests/reference/neo_hookean_uniaxial.csv,
/// nominal stress times the undeformed area; tabulated every 0.01, linear between).
double uniaxialForce(double stretch) {
  static const auto table = Cylinder::readCsv(test::referencePath("neo_hookean_uniaxial.csv"));
  const std::vector<double>& s = table[0];
  const std::vector<double>& P = table[1];
  const auto it = std::lower_bound(s.begin(), s.end(), stretch);
  const size_t i = std::min<size_t>(std::max<ptrdiff_t>(it - s.begin(), 1), s.size() - 1);
  const double w = (stretch - s[i - 1]) / (s[i] - s[i - 1]);
  return ((1 - w) * P[i - 1] + w * P[i]) * kPi * Cylinder::kRadius * Cylinder::kRadius;
}

/// MLS-MPM at dx = 0.5 cm (H = 20 cells, 50.6k particles), the plates' band half a cell
/// (scenes::Cylinder::plate), the ramp over 1 s instead of 3 s (quasi-static either
/// way: at dx = 1 cm the slip force after 1 s and after 3 s differ by 0.06 %).
Cylinder::Setup mlsSetup(ContactMode ends) {
  Cylinder::Setup s;
  s.solver = SolverType::MlsMpm;
  s.resolution = 0.005;
  s.ends = ends;
  s.rampTime = 1.0;
  return s;
}

TEST(CylinderBetweenPlatesMpm, MlsSlipCompressionFollowsTheClosedForm) {
  const Cylinder::Setup setup = mlsSetup(ContactMode::Frictional);
  // frames of 50 ms centred on the samples: each force is a mean over the slab's ringing
  const Cylinder::Run run = Cylinder::run(setup, Cylinder::Loading::Compression, 0.05, 0.1);
  ASSERT_FALSE(run.time.empty());
  const double finalRef = uniaxialForce(1 - Cylinder::kTravel / Cylinder::kHeight);
  double worst = 0, diff2 = 0, ref2 = 0;
  for (size_t i = 0; i < run.time.size(); ++i) {
    const double u = Cylinder::kTravel * Cylinder::smoothRamp(run.time[i] / setup.rampTime);
    const double expected = uniaxialForce(1 - u / Cylinder::kHeight);
    worst = std::max(worst, std::abs(run.axialForce[i] - expected) / std::abs(finalRef));
    diff2 += (run.axialForce[i] - expected) * (run.axialForce[i] - expected);
    ref2 += expected * expected;
    std::printf("  t = %.2f s  F = %.4f N  closed form %.4f N  (%+.2f %% of the final force)\n", run.time[i],
                run.axialForce[i], expected, 100 * (run.axialForce[i] - expected) / std::abs(finalRef));
  }
  const double finalError = run.axialForce.back() / finalRef - 1, curveError = std::sqrt(diff2 / ref2);
  std::printf("MLS-MPM slip: %zu particles, %lld substeps, %.0f s; final %.4f N vs %.4f N (%+.2f %%), curve L2 "
              "%.2f %%, largest deviation %.2f %% of the final force\n",
              run.particles, run.substeps, run.wallSeconds, run.axialForce.back(), finalRef, 100 * finalError,
              100 * curveError, 100 * worst);
  // measured: final -2.37 %, curve L2 3.53 %: over this 1 s ramp the force runs up to 4.4 %
  // of the final force low late in the ramp. Over the paper's 3 s ramp (bench_accuracy) the
  // same resolution gives final -2.33 % and curve L2 2.65 %; dx = 1 cm gives -4.26 / 4.99 %
  EXPECT_LT(std::abs(finalError), 0.03);
  EXPECT_LT(curveError, 0.04);
}

TEST(CylinderBetweenPlatesMpm, MlsBondedCompressionMatchesTheFiniteElementReference) {
  const Cylinder::Setup setup = mlsSetup(ContactMode::Bonded);
  const Cylinder::Run run = Cylinder::run(setup, Cylinder::Loading::Compression, 0.05, 0.1);
  ASSERT_FALSE(run.time.empty());
  const double finalError = run.axialForce.back() / Cylinder::kBondedFinalForce - 1;
  std::printf("MLS-MPM bonded: %zu particles, %lld substeps, %.0f s; final %.4f N vs %.4f N (%+.2f %%)\n",
              run.particles, run.substeps, run.wallSeconds, run.axialForce.back(), Cylinder::kBondedFinalForce,
              100 * finalError);
  // measured +1.90 % (bench_accuracy, 3 s ramp: +3.45 / +0.86 / +1.72 % at dx = 1 / 0.714 /
  // 0.5 cm)
  EXPECT_LT(std::abs(finalError), 0.05);
}

// A bonded plate pulling the cylinder 20 % holds it to the end, and the force lies between
// the uniaxial closed form (free ends) and 1.25 times it: bonded ends stop the ends'
// lateral contraction, which stiffens the cylinder (in compression the finite-element
// reference is 1.135 times the uniaxial force). The plates' band is the user's 0: a
// Bonded shape holds the node layer nearest its face by itself.
TEST(CylinderBetweenPlatesMpm, BondedPlateHoldsTheCylinderThroughExtension) {
  Cylinder::Setup setup;
  setup.solver = SolverType::MlsMpm;
  setup.resolution = 0.01;
  setup.ends = ContactMode::Bonded;
  setup.rampTime = 1.0;
  setup.plateBand = 0.f;
  const Cylinder::Run run = Cylinder::run(setup, Cylinder::Loading::Extension, 0.01, 0.05);
  ASSERT_FALSE(run.time.empty());
  const double uniaxial = uniaxialForce(1 + Cylinder::kTravel / Cylinder::kHeight);
  double lowest = 1e9;
  for (size_t i = run.time.size() / 2; i < run.time.size(); ++i) lowest = std::min(lowest, run.axialForce[i]);
  std::printf("MLS-MPM bonded extension: final %.4f N, uniaxial closed form %.4f N (ratio %.3f); lowest force over the "
              "second half of the ramp %.4f N\n",
              run.axialForce.back(), uniaxial, run.axialForce.back() / uniaxial, lowest);
  // measured: final 4.682 N = 1.181 x uniaxial; lowest force over the second half 2.90 N
  // (before glued material held its nodes to a full cell: 4.377 N, 1.104 x)
  EXPECT_GT(lowest, 0.3 * uniaxial) << "the plate let go";
  EXPECT_GT(run.axialForce.back(), uniaxial);
  EXPECT_LT(run.axialForce.back(), 1.25 * uniaxial);
}

// Bonded plates pulling the cylinder 20 % over the paper's 3 s ramp at H/dx = 14 (17k
// particles), against MTLED's converged curve (tests/reference/cylinder_extension_mtled.csv,
// within 0.7 % of a CalculiX extension reference). Before glued material held its nodes to a
// full cell (contact/contact_law.h, kGluedReach) the node layer pulled away from a plate went free
// at 0.65 dx, the glued particles slid inward with the necking material, and both solvers
// came out soft and not converging: MLS-MPM final -5.5 % at H/dx = 14 (-2.3 / -4.0 % at 10 /
// 20), standard MPM -10 %.
class CylinderBetweenPlatesExtension : public ::testing::TestWithParam<SolverType> {};

TEST_P(CylinderBetweenPlatesExtension, BondedForceMatchesTheMeshfreeReference) {
  Cylinder::Setup setup;
  setup.solver = GetParam();
  setup.resolution = Cylinder::kHeight / 14;
  setup.ends = ContactMode::Bonded;
  const Cylinder::Run run = Cylinder::run(setup, Cylinder::Loading::Extension, 0.01, 0.1);
  const auto ref = Cylinder::readCsv(test::referencePath("cylinder_extension_mtled.csv"));
  ASSERT_EQ(run.time.size(), 30u);
  double diff2 = 0, ref2 = 0;
  for (size_t i = 0; i < run.time.size(); ++i) {
    const double expected = Cylinder::at(ref[0], ref[1], run.time[i]);
    ASSERT_FALSE(std::isnan(expected)) << "no reference at t = " << run.time[i];
    diff2 += (run.axialForce[i] - expected) * (run.axialForce[i] - expected);
    ref2 += expected * expected;
  }
  const double finalRef = Cylinder::at(ref[0], ref[1], Cylinder::kRampTime);
  const double finalError = run.axialForce.back() / finalRef - 1, curveError = std::sqrt(diff2 / ref2);
  std::printf("%s bonded extension, H/dx = 14: final %.4f N vs %.4f N (%+.2f %%), curve L2 %.2f %%\n",
              test::solverName(GetParam()).c_str(), run.axialForce.back(), finalRef, 100 * finalError,
              100 * curveError);
  // measured: MLS-MPM final -0.11 %, L2 0.76 %; standard MPM -1.70 %, 1.99 % (bench_accuracy
  // at H/dx = 10 / 20: MLS-MPM L2 1.92 / 0.90 %, final -1.03 / -2.13 %; standard MPM L2 2.23 /
  // 1.64 %, final -4.18 / -4.03 %: at 3 s the plate face lies exactly on a node layer there,
  // and the node a cell below it has just left the glued reach, a 2.6 % drop from t = 2.9 s)
  EXPECT_LT(std::abs(finalError), 0.03);
  EXPECT_LT(curveError, 0.03);
}

INSTANTIATE_TEST_SUITE_P(GridSolvers, CylinderBetweenPlatesExtension,
                         ::testing::Values(SolverType::MlsMpm, SolverType::StandardMpm), test::solverParamName());

// ---- The MTLED paper's sections 4.7-4.8, every solver -------------------------------------

class CylinderBetweenPlatesConservation : public ::testing::TestWithParam<SolverType> {};

// Section 4.7: the work the plates do compressing the cylinder is stored as strain energy.
// Slip ends, 20 % over a 1 s ramp, 1 cm. Each frame's work is the plate's impulse times
// its mean velocity (Scene's energy account, SceneSettings::energyCheck); the stored
// energy is sum V0 W(F) of the particles (MLS-MPM, standard MPM) or of MTLED's integration
// points. PB-MPM's forces do not derive from a W(F) it could report: nothing to compare.
TEST_P(CylinderBetweenPlatesConservation, CompressionWorkIsStoredAsStrainEnergy) {
  if (GetParam() == SolverType::PbMpm) GTEST_SKIP() << "PB-MPM reports no stored elastic energy";
  Cylinder::Setup setup;
  setup.solver = GetParam();
  setup.ends = ContactMode::Frictional;
  setup.rampTime = 1.0;
  setup.energyCheck = true;
  const Cylinder::Run run = Cylinder::run(setup, Cylinder::Loading::Compression);
  const EnergyBalance& e = run.energy;
  const double stored = e.kinetic + e.strain;
  std::printf("%s: plate work %.5g J, strain %.5g J, kinetic %.3g J; (strain + kinetic) / work - 1 = %+.3f %%\n",
              test::solverName(GetParam()).c_str(), e.work, e.strain, e.kinetic, 100 * (stored / e.work - 1));
  ASSERT_GT(e.work, 0.03);  // the closed form stores about 0.052 J at 20 %
  // measured: MLS-MPM -0.43 %, standard MPM -1.14 % (grid transfers dissipate a little),
  // MTLED +0.07 % (smoothed strain); the paper's goal is 2 %
  EXPECT_LT(std::abs(stored / e.work - 1), 0.02);
}

// Section 4.8: the cylinder spun about its axis at 1 Hz for 20 s, no load: angular
// momentum about the axis kept. MTLED's central differences with torque-free point forces
// (P F^T is symmetric) and MLS-MPM's APIC transfers conserve it; standard MPM's and
// PB-MPM's transfers lose it (tests/test_conservation.cpp's spinning block). Grid solvers
// at dx = 1.25 cm (R = 4 cells, 3.3k particles; 1 cm takes 105 s per solver here).
TEST_P(CylinderBetweenPlatesConservation, AngularMomentumOfA1HzSpinOver20s) {
  const SolverType solver = GetParam();
  Cylinder::Setup setup;
  setup.solver = solver;
  setup.resolution = solver == SolverType::Mtled ? 0.01 : 0.0125;
  Scene scene(Cylinder::settings(setup));
  ParticleObjectDesc c = Cylinder::cylinder(setup);
  c.angularVelocity = {0.f, (float)(2 * kPi), 0.f};
  const ParticleObjectId id = scene.addParticleObject(c);
  // MTLED replaces the lattice's node masses by its lumped ones (the MTLED paper's section 2.5) when
  // it builds its model, on the first step or on this query: L0 is taken in those masses
  scene.maxSubstep();
  const double L0 = scene.summary(id).angularMomentum[1];
  ASSERT_GT(L0, 0.0);
  long substeps = 0;
  for (int f = 0; f < 200; ++f) substeps += scene.step(0.1f).substeps;
  const ObjectSummary after = scene.summary(id);
  const double loss = 1 - after.angularMomentum[1] / L0;
  const double R = Cylinder::kRadius;
  std::printf("%s: %zu particles, %ld substeps; L0 %.5g kg m^2/s (uniform cylinder: %.5g); L_y lost %.3g of L0 over "
              "20 s; |L_x|, |L_z| %.3g, %.3g of L0\n",
              test::solverName(solver).c_str(), after.particles, substeps, L0,
              0.5 * Cylinder::kDensity * kPi * R * R * Cylinder::kHeight * R * R * 2 * kPi, loss,
              std::abs(after.angularMomentum[0]) / L0, std::abs(after.angularMomentum[2]) / L0);
  // measured: MTLED -9e-8, MLS-MPM 1.3e-5 (1.1e-4 at 1 cm), standard MPM 1.0 (all of it:
  // its transfers drop each particle's spin about itself every substep), PB-MPM 0.87
  // (each iteration's projection replaces C without balancing torques)
  const double bound = solver == SolverType::StandardMpm ? 1.0 + 1e-3 : solver == SolverType::PbMpm ? 0.9 : 0.01;
  EXPECT_LT(loss, bound);
  EXPECT_GT(loss, -0.01) << "no transfer may add spin";
  EXPECT_LT(std::abs(after.angularMomentum[0]) / L0, 0.01);
  EXPECT_LT(std::abs(after.angularMomentum[2]) / L0, 0.01);
}

INSTANTIATE_TEST_SUITE_P(AllSolvers, CylinderBetweenPlatesConservation,
                         test::everySolver(),
                         test::solverParamName());

}  // namespace
}  // namespace mpm
