// Grips that hold: a Bonded plate glued to a block's face pulls the block to large strain.
// The block (fixed corotated, Poisson's ratio 0, no gravity) is held at its bottom by a
// Bonded floor plate; with nu = 0 it does not narrow, its bonded ends restrain nothing, and
// its tension is uniaxial at every stretch s: P = 2 mu (s - 1) = E (s - 1), so the plate's
// force is E A (s - 1) exactly (A the block's section). MLS-MPM and standard MPM are held to
// it; PB-MPM, far softer than its E at its default iterations, only to never letting go.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "mpm/scene.h"
#include "solver_cases.h"

namespace mpm {
namespace {

struct PullResult {
  std::vector<double> strain, force, expected;  ///< per frame while pulling
};

/// The block (W x H x W, E, nu 0) between two Bonded plates; the top one first moves
/// `pressIn` [m] into the block, then is pulled away at `speed` until the block's
/// nominal strain reaches `maxStrain`.
PullResult pullOff(SolverType solver, double pressIn, double maxStrain) {
  const float dx = 0.01f, W = 0.06f, H = 0.1f, E = 2e4f, plate = 0.01f;
  const float speed = 0.02f;
  SceneSettings st;
  st.backend = Backend::Cpu;
  st.solver = solver;
  st.dx = dx;
  st.gravity = {0.f, 0.f, 0.f};
  st.domain.lower = {-0.1f, 0.f, -0.1f};
  st.domain.upper = {0.1f, 0.25f, 0.1f};
  Scene scene(st);
  ParticleObjectDesc d;
  const float bottom = 0.03f;
  d.center = {0.f, bottom + 0.5f * H, 0.f};
  d.halfExtents = {0.5f * W, 0.5f * H, 0.5f * W};
  d.material.model = MaterialModel::FixedCorotated;
  d.material.youngsModulus = E;
  d.material.poissonRatio = 0.f;
  d.material.density = 1000.f;
  scene.addParticleObject(d);

  ShapeDesc p;
  p.parts = {Geometry::box({0.04f, 0.5f * plate, 0.04f})};
  p.contact.mode = ContactMode::Bonded;
  p.pose.position = {0.f, bottom - 0.5f * plate, 0.f};
  scene.addShape(p);
  p.pose.position = {0.f, bottom + H + 0.5f * plate, 0.f};
  const ShapeId top = scene.addShape(p);

  const float frame = 0.01f;
  PullResult r;
  const auto move = [&](float v, double until, bool record) {
    ShapeState s = scene.shapeState(top);
    s.linearVelocity = {0.f, v, 0.f};
    scene.setShapeState(top, s);
    for (int f = 0; f < 100000; ++f) {
      const double y = scene.shapeState(top).pose.position.y;
      const double strain = (y - (bottom + H + 0.5 * plate)) / H;
      if ((v < 0 && strain <= until + 1e-9) || (v > 0 && strain >= until - 1e-9)) break;
      scene.step(frame);
      if (!record) continue;
      const double after = (scene.shapeState(top).pose.position.y - (bottom + H + 0.5 * plate)) / H;
      r.strain.push_back(after);
      r.force.push_back(-scene.shapeImpulse(top).linear.y / frame);
      r.expected.push_back(E * W * W * after);
    }
  };
  if (pressIn > 0) move(-speed, -pressIn / H, false);
  move(speed, maxStrain, true);
  return r;
}

class Grips : public ::testing::TestWithParam<SolverType> {};

/// The plate's force against E A s beyond 5 % strain, each a mean over 50 ms of frames
/// (5 frames, about two periods of the block's axial ringing; 1 mm of travel), and the
/// least force of any frame beyond 2 % strain.
struct PullCheck {
  double worst = 0, worstAt = 0, mean = 0, least = 1e30;
};

PullCheck check(const PullResult& r) {
  PullCheck c;
  int n = 0;
  for (size_t i = 2; i + 2 < r.strain.size(); ++i) {
    if (r.strain[i] > 0.02) c.least = std::min(c.least, r.force[i]);
    if (r.strain[i] < 0.05) continue;
    double f = 0, e = 0;
    for (size_t k = i - 2; k <= i + 2; ++k) f += r.force[k], e += r.expected[k];
    const double d = f / e - 1;
    c.mean += d, ++n;
    if (std::abs(d) > std::abs(c.worst)) c.worst = d, c.worstAt = r.strain[i];
  }
  c.mean /= std::max(n, 1);
  return c;
}

PullCheck pullAndReport(SolverType solver, double pressIn) {
  const PullResult r = pullOff(solver, pressIn, 0.6);
  for (size_t i = 0; i < r.strain.size(); i += 10)
    std::printf("  strain %6.3f  force %8.3f N  E A s %8.3f N\n", r.strain[i], r.force[i], r.expected[i]);
  const PullCheck c = check(r);
  std::printf("%s, pressed %.0f mm in first, pulled to %.0f %% strain: force vs E A s (50 ms means) %+.1f %% at worst "
              "(strain %.3f), %+.1f %% on average; least frame force %.3f N\n",
              test::solverName(solver).c_str(), 1e3 * pressIn, 100 * r.strain.back(), 100 * c.worst, c.worstAt,
              100 * c.mean, c.least);
  return c;
}

// measured (dx 1 cm, H 10 cm): MLS-MPM -6.6 % at worst, -2.7 % on average; standard MPM
// -8.0 / -4.7 %; the same after pressing 1 cm in. Before material stayed glued, the force
// levelled off at 14 % strain and was 0 from 26 % (MLS-MPM), 42 % (PB-MPM).
TEST_P(Grips, BondedPlatePullsABlockToSixtyPercent) {
  const PullCheck c = pullAndReport(GetParam(), 0.0);
  EXPECT_LT(std::abs(c.worst), 0.10);
  EXPECT_GT(c.least, 0.0);
}
TEST_P(Grips, BondedPlatePressedInFirstPullsABlockToSixtyPercent) {
  const PullCheck c = pullAndReport(GetParam(), 0.01);
  EXPECT_LT(std::abs(c.worst), 0.10);
  EXPECT_GT(c.least, 0.0);
}

// PB-MPM holds on too, but its tissue is softer than its E at a fixed iteration count
// (docs/limits.md): only that it never lets go is checked here.
TEST(GripsPbMpm, BondedPlateNeverLetsGo) {
  for (double pressIn : {0.0, 0.01}) {
    const PullCheck c = pullAndReport(SolverType::PbMpm, pressIn);
    EXPECT_GT(c.least, 0.0) << "pressed in " << pressIn << " m first";
  }
}

INSTANTIATE_TEST_SUITE_P(GridSolvers, Grips,
                         ::testing::Values(SolverType::MlsMpm, SolverType::StandardMpm),
                         [](const auto& info) { return test::solverName(info.param); });

}  // namespace
}  // namespace mpm
