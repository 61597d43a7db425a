// Hertz contact (mpm::scenes::HertzIndentation, bench/hertz.cpp): a kinematic frictionless
// sphere of radius R pressed slowly into an elastic slab, the window-averaged force against
// depth compared with F_H = 4/3 E* sqrt(R) d^1.5 for d <= 0.1 R, at the benchmark's coarsest
// resolution, R = 4 dx, on the benchmark's scene (a quarter of an 8R x 8R x 4R slab on mirror
// planes). There 0.1 R is 0.4 dx and the force is 30 % below Hertz; bench/results/h100/hertz.md
// shows the L2 error falling to 9.4 % at R/dx = 20 (run on a GPU). The tolerances below are
// that table's R/dx = 4 row plus headroom for other compilers, CPUs and the CUDA backend's
// float order (the CUDA row matched the CPU row to every printed digit).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "scenes/standard_scenes.h"

namespace mpm {
namespace {

using scenes::HertzIndentation;

class Hertz : public ::testing::TestWithParam<Backend> {
 protected:
  void SetUp() override {
    if (GetParam() == Backend::Cuda && !cudaDeviceAvailable()) GTEST_SKIP() << "no CUDA device: GPU case skipped";
  }
};

// bench/results/h100/hertz.md, R/dx = 4: L2 error over d = 0.02 R ... 0.1 R 29.7%, F/F_H - 1 at
// d = 0.1 R -30.0% (depth lost 0.085 cells), standoff force at d = 0 6.2% of F_H(0.1 R).
// With the contact reach of resting material 20.4 / -23.7 %; with
// nodes beyond the material's surface out of contact (takesContact) 30.1 / -31.0 %, depth
// lost 0.088 cells, standoff 2.1 % (bench/results/epyc-2core/hertz.md): back to the first row's margin.
constexpr double kL2Tolerance = 0.33;
constexpr double kMaxDepthTolerance = 0.33;
constexpr double kStandoffTolerance = 0.10;

TEST_P(Hertz, CoarsestResolutionWithinTheBenchmarkTolerance) {
  HertzIndentation::Setup setup;
  setup.cellsPerRadius = 4;
  setup.backend = GetParam();
  const HertzIndentation::Run run = HertzIndentation::run(setup);
  const HertzIndentation::Comparison c = HertzIndentation::compare(run);
  std::printf("R/dx = 4: %zu particles, L2 error %.1f%%, F/F_H - 1 at 0.1 R %.1f%%, depth lost %.3f cells\n",
              run.particles, 100 * c.l2Error, 100 * c.errorAtMaxDepth, c.depthLossCells);
  EXPECT_LT(c.l2Error, kL2Tolerance);
  EXPECT_LT(std::fabs(c.errorAtMaxDepth), kMaxDepthTolerance);

  // nothing touches the sphere until it reaches the node layer above the surface
  ASSERT_FALSE(run.approach.empty());
  EXPECT_EQ(run.approach.front().force, 0.0) << "force with the sphere 1.05 dx above the slab";
  // the standoff: the force at first contact (d = 0) is small against the force compared
  double nearest = 1e30, atContact = 0;
  for (const HertzIndentation::Sample& s : run.loading)
    if (std::fabs(s.depth) < nearest) nearest = std::fabs(s.depth), atContact = s.force;
  EXPECT_GE(atContact, 0.0);
  EXPECT_LT(atContact, kStandoffTolerance * HertzIndentation::hertzForce(HertzIndentation::kMaxDepth));

  // the averaged force grows with depth over the compared range
  double previous = 0;
  for (int i = 0; i <= 8; ++i) {
    const double d = (0.02 + 0.01 * i) * HertzIndentation::kRadius;
    const double f = HertzIndentation::averagedForce(run, d);
    EXPECT_GT(f, previous) << "averaged force at d = " << d << " m";
    previous = f;
  }
}

INSTANTIATE_TEST_SUITE_P(Backends, Hertz, ::testing::Values(Backend::Cpu, Backend::Cuda),
                         [](const ::testing::TestParamInfo<Backend>& info) {
                           return info.param == Backend::Cpu ? std::string("Cpu") : std::string("Cuda");
                         });

}  // namespace
}  // namespace mpm
