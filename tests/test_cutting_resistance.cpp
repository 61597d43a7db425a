// The resistance to cutting (Atkins, "The Science and Engineering of Cutting", 2009: a blade
// opening a crack does work G_c per unit area it opens): a curved blade (MeshSlicerDesc)
// pressed down through a block feels G_c times the length of its edge in material, as a
// straight one does (Cutting.TheBladeFeelsTheToughnessTimesTheDepth). CPU backend (the
// kernels are the CUDA ones).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "cutting_scene.h"
#include "mpm/scene.h"
#include "solver_cases.h"

namespace mpm {
namespace {

using test::kBlockHalf;

SceneSettings settingsFor(SolverType solver) { return test::cuttingSettings(solver); }

/// The block, stiffer (E 100 kPa), of toughness G_c [J/m^2].
ParticleObjectDesc block(float toughness) {
  ParticleObjectDesc d = test::cutBlock();
  d.material.youngsModulus = 1e5f;
  d.material.fractureToughness = toughness;
  return d;
}

void addBase(Scene& scene) {
  ShapeDesc base;
  base.parts.push_back(Geometry::box({0.06f, 0.005f, 0.05f}));
  base.pose.position = {0.f, -kBlockHalf.y - 0.005f, 0.f};
  base.contact.mode = ContactMode::Bonded;
  scene.addShape(base);
}

/// The length of the arc blade's edge over the block's top: the arc within |x| < half x
/// (its ends at +-50 degrees lie outside the block, its z within the block's).
double engagedArc() { return 2.0 * test::kArcRadius * std::asin(kBlockHalf.x / test::kArcRadius); }

class CuttingResistance : public ::testing::TestWithParam<SolverType> {};

// The curved blade pressed down at 10 cm/s through a block of G_c 200 J/m^2: once its edge
// is a cell below the top, the force on it averaged while the edge goes from 1 to 2.5 cm
// deep (of the block's 4 cm) is G_c times the arc in the block within 20 %. Without
// toughness the same blade cuts freely (its faces slide along their own surface).
double curvedBladeForce(SolverType solver, float toughness) {
  SceneSettings settings = settingsFor(solver);
  // PB-MPM takes the whole frame as its substep here (its step follows the motion alone),
  // and its iterations do not carry the edge's load (0.75 N on each particle ahead of it at
  // G_c 200) through the block within 1/240 s: the particles ahead are thrown (2.5 m/s, the
  // divergence check). Two substeps a frame carry it (+3.0 %).
  if (solver == SolverType::PbMpm) settings.substeps.fixedSubsteps = 2;
  Scene scene(settings);
  scene.addParticleObject(block(toughness));
  addBase(scene);
  const float speed = 0.1f, start = kBlockHalf.y + 0.005f;
  const SlicerId s = scene.addSlicer(test::arcBlade(start, {0.f, -speed, 0.f}, 48));
  const float frame = 1.f / 240.f;
  double force = 0;
  int samples = 0;
  for (int i = 0; i < 240; ++i) {
    scene.step(frame);
    const float depth = kBlockHalf.y - scene.slicerState(s).pose.position.y;
    if (depth > 0.01f && depth < 0.025f) {
      force += scene.slicerImpulse(s).linear.y / frame;
      ++samples;
    }
    if (depth >= 0.025f) break;
  }
  return samples ? force / samples : 0.0;
}

TEST_P(CuttingResistance, ACurvedBladeFeelsTheToughnessTimesItsEdgeInMaterial) {
  const float gc = 200.f;
  const double f = curvedBladeForce(GetParam(), gc), expected = gc * engagedArc();
  std::printf("[cut] %s curved blade, G_c %.0f J/m^2: %.3f N, G_c L = %.3f N (%+.1f %%)\n",
              test::solverName(GetParam()).c_str(), gc, f, expected, 100.0 * (f / expected - 1.0));
  EXPECT_NEAR(f, expected, 0.2 * expected);
  const double none = curvedBladeForce(GetParam(), 0.f);
  std::printf("[cut] %s curved blade, G_c 0: %.4f N\n", test::solverName(GetParam()).c_str(), none);
  EXPECT_LT(std::fabs(none), 0.05 * expected) << "without toughness the blade cuts freely";
}

INSTANTIATE_TEST_SUITE_P(GridSolvers, CuttingResistance, test::allSolvers(), test::solverParamName());

}  // namespace
}  // namespace mpm
