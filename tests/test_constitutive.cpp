// Constitutive laws and the polar decomposition, checked against closed forms, Eigen and
// the analytic uniaxial Neo-Hookean curve in reference/ (from shared/reference, CalculiX
// material law).
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "backend/cpu/stress_batch.h"
#include "core/constitutive.h"
#include "test_paths.h"

namespace mpm {
namespace {

Eigen::Matrix3d toEigen(const Mat3f& a) {
  Eigen::Matrix3d m;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) m(i, j) = a.m[i][j];
  return m;
}

Mat3f fromEigen(const Eigen::Matrix3d& m) {
  Mat3f a;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) a.m[i][j] = (float)m(i, j);
  return a;
}

Eigen::Matrix3d randomRotation(std::mt19937& rng) {
  std::normal_distribution<double> n;
  Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
  return q.normalized().toRotationMatrix();
}

// R from Eigen's SVD with the sign fixed so det R = +1 (the reference for polarRotation).
Eigen::Matrix3d referenceRotation(const Eigen::Matrix3d& F) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(F, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU(), V = svd.matrixV();
  if (U.determinant() < 0) U.col(2) *= -1;
  if (V.determinant() < 0) V.col(2) *= -1;
  return U * V.transpose();
}

TEST(PolarDecomposition, MatchesEigenSvdForRandomAndInvertedF) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> s(0.3, 2.0);
  for (int trial = 0; trial < 500; ++trial) {
    const Eigen::Matrix3d U = randomRotation(rng), V = randomRotation(rng);
    Eigen::Vector3d sig(s(rng), s(rng), s(rng));
    if (trial % 5 == 0) sig(trial % 3) *= -1;  // inverted element
    const Eigen::Matrix3d F = U * sig.asDiagonal() * V.transpose();
    float sigma[3];
    const Eigen::Matrix3d R = toEigen(polarRotation(fromEigen(F), sigma));
    EXPECT_NEAR(R.determinant(), 1.0, 1e-4) << "trial " << trial;
    EXPECT_LT((R * R.transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-4) << "trial " << trial;
    // R^T F must be symmetric (F = R S); for det F > 0 it is also the unique polar factor
    const Eigen::Matrix3d S = R.transpose() * F;
    EXPECT_LT((S - S.transpose()).norm(), 1e-4 * F.norm()) << "trial " << trial;
    if (F.determinant() > 0) EXPECT_LT((R - referenceRotation(F)).norm(), 1e-4) << "trial " << trial;
    EXPECT_NEAR((double)sigma[0] * sigma[1] * sigma[2], F.determinant(), 1e-4 * std::abs(F.determinant()) + 1e-5);
  }
}

TEST(PolarDecomposition, FastPathMatchesJacobiPath) {
  // fastPolarRotation (Newton where det F > 0, else the Jacobi path) gives polarRotation's R
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> s(0.2, 3.0);
  for (int trial = 0; trial < 1000; ++trial) {
    const Eigen::Matrix3d U = randomRotation(rng), V = randomRotation(rng);
    Eigen::Vector3d sig(s(rng), s(rng), s(rng));
    if (trial % 4 == 0) sig(trial % 3) *= -1;         // inverted
    if (trial % 7 == 0) sig((trial + 1) % 3) *= 1e-3;  // nearly flat
    const Mat3f F = fromEigen(U * sig.asDiagonal() * V.transpose());
    const Eigen::Matrix3d fast = toEigen(fastPolarRotation(F)), jacobi = toEigen(polarRotation(F));
    EXPECT_NEAR(fast.determinant(), 1.0, 1e-4) << "trial " << trial;
    EXPECT_LT((fast - jacobi).norm(), 1e-4) << "trial " << trial;
  }
}

// The CPU's P2G takes the stress of many particles at once (kirchhoffStressBatch: fixed
// corotated in SIMD lanes, each lane running fastPolarRotation's Newton iteration until it
// converges on its own). It must give kirchhoffStress's tau particle by particle: for
// mixed materials, inverted, nearly flat and non-finite F (the Jacobi path), and a count
// that leaves a partial last batch.
TEST(FixedCorotated, BatchedStressMatchesPerParticle) {
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> s(0.2, 3.0);
  std::vector<MaterialParams> materials(3);
  materials[0].model = kFixedCorotated, materials[0].mu = 1e5f, materials[0].lambda = 4e5f;
  materials[1].model = kNeoHookeanDecoupled, materials[1].mu = 3e4f, materials[1].bulk = 1e6f;
  materials[2].model = kFixedCorotated, materials[2].mu = 2e3f, materials[2].lambda = 5e3f;
  const int n = 1003;
  std::vector<Mat3f> F(n), tau(n);
  std::vector<uint32_t> object(n), ids(n);
  for (int i = 0; i < n; ++i) {
    const Eigen::Matrix3d U = randomRotation(rng), V = randomRotation(rng);
    Eigen::Vector3d sig(s(rng), s(rng), s(rng));
    if (i % 4 == 0) sig(i % 3) *= -1;         // inverted
    if (i % 7 == 0) sig((i + 1) % 3) *= 1e-3;  // nearly flat
    F[i] = fromEigen(U * sig.asDiagonal() * V.transpose());
    if (i % 11 == 0) F[i] = Mat3f::identity() + 0.01f * F[i];  // small strain: few iterations
    object[i] = (uint32_t)(i % 5 == 0 ? 1 : i % 3 == 0 ? 2 : 0);
  }
  F[500].m[1][2] = std::nanf("");
  // the particles in a shuffled order, as a block's run of the binning gives them
  for (int i = 0; i < n; ++i) ids[i] = (uint32_t)i;
  std::shuffle(ids.begin(), ids.end(), rng);
  kirchhoffStressBatch(materials.data(), object.data(), F.data(), ids.data(), n, tau.data());
  for (int q = 0; q < n; ++q) {
    const uint32_t i = ids[q];
    const Mat3f want = kirchhoffStress(materials[object[i]], F[i]);
    if (i == 500) {
      const auto finite = [](const Mat3f& m) { return toEigen(m).allFinite(); };
      EXPECT_FALSE(finite(want));
      EXPECT_FALSE(finite(tau[q])) << "a non-finite F gives a non-finite stress";
      continue;
    }
    const double scale = toEigen(want).norm() + 1e-3 * materials[object[i]].mu;
    // the lanes and the per-particle code may contract multiply-adds differently
    EXPECT_LT((toEigen(tau[q]) - toEigen(want)).norm(), 1e-5 * scale) << "particle " << i << " object " << object[i];
  }
}

#ifdef MPM_CPU_LANES
// J^-2/3 of the batched Neo-Hookean stress is Newton's iteration from a guess made of the
// exponent bits: over 60 decades of x it must give 1 / cbrt(x) to a few float roundings,
// and mark the lanes it cannot take (zero, negative, huge, NaN).
TEST(NeoHookeanDecoupled, LaneInverseCubeRootIsCorrectlyRounded) {
  using simd::kLanes;
  double worst = 0;
  for (double e = -29.5; e < 29.5; e += 0.0137 * kLanes) {
    simd::Floats x;
    for (int l = 0; l < kLanes; ++l) x[l] = (float)std::pow(10.0, e + 0.0137 * l);
    simd::Mask outside;
    const simd::Floats y = inverseCbrtLanes(x, outside);
    for (int l = 0; l < kLanes; ++l) {
      ASSERT_EQ(outside[l], 0) << x[l];
      worst = std::max(worst, std::abs(y[l] * std::cbrt((double)x[l]) - 1.0));
    }
  }
  EXPECT_LT(worst, 4.0 * 6e-8) << "relative error of the lanes' 1 / cbrt(x)";
  simd::Floats odd = simd::splat(1.f);
  odd[0] = 0.f, odd[1] = -1.f, odd[2] = std::nanf(""), odd[3] = 1e35f;
  simd::Mask outside;
  inverseCbrtLanes(odd, outside);
  for (int l = 0; l < 4; ++l) EXPECT_NE(outside[l], 0) << "lane " << l << " x " << odd[l];
}
#endif

// A batch of Neo-Hookean particles only (the lanes of fixed corotated are not computed):
// kirchhoffStress's tau particle by particle, at large strains, inverted (J < 0), nearly
// flat, exactly flat (J = 0: the scalar path's infinite J^-2/3) and tiny J (outside the
// lanes' range: the scalar path).
TEST(NeoHookeanDecoupled, BatchedStressMatchesPerParticle) {
  std::mt19937 rng(29);
  std::uniform_real_distribution<double> s(0.2, 3.0);
  MaterialParams mat;
  mat.model = kNeoHookeanDecoupled, mat.mu = 3e4f, mat.bulk = 1e6f;
  const int n = 517;
  std::vector<Mat3f> F(n), tau(n);
  std::vector<uint32_t> object(n, 0), ids(n);
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d sig(s(rng), s(rng), s(rng));
    if (i % 4 == 0) sig(i % 3) *= -1;          // inverted
    if (i % 7 == 0) sig((i + 1) % 3) *= 1e-3;  // nearly flat
    if (i % 13 == 0) sig((i + 2) % 3) *= 1e-16;  // J^2 below the lanes' range
    F[i] = fromEigen(randomRotation(rng) * sig.asDiagonal() * randomRotation(rng).transpose());
    ids[i] = (uint32_t)((i * 7) % n);
  }
  F[100] = Mat3f::identity();
  F[100].m[2][2] = 0.f;  // flat: J = 0
  kirchhoffStressBatch(&mat, object.data(), F.data(), ids.data(), n, tau.data());
  for (int q = 0; q < n; ++q) {
    const uint32_t i = ids[q];
    const Mat3f want = kirchhoffStress(mat, F[i]);
    if (!toEigen(want).allFinite()) {
      EXPECT_FALSE(toEigen(tau[q]).allFinite()) << "particle " << i;
      continue;
    }
    const double scale = toEigen(want).norm() + 1e-3 * mat.mu;
    EXPECT_LT((toEigen(tau[q]) - toEigen(want)).norm(), 1e-5 * scale) << "particle " << i;
  }
}

// PB-MPM's P2G projects many particles at once (pbProjectionBatch: the polar rotation,
// J^(1/3) and F^-1 in SIMD lanes). It must give pbProjectedVelocityGradient particle by
// particle: large strains and rates, F* inverted (J <= 0: F_c = R) or nearly flat, a
// non-finite C, rigidity 1 and 0.3, and a partial last batch.
TEST(PbProjection, BatchedMatchesPerParticle) {
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> s(0.3, 2.5), u(-1.0, 1.0);
  const float dt = 1.f / 240.f;
  const int n = 389;
  std::vector<Mat3f> F(n), C(n), Cc(n);
  std::vector<uint32_t> ids(n);
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d sig(s(rng), s(rng), s(rng));
    if (i % 7 == 0) sig((i + 1) % 3) *= 1e-3;  // nearly flat
    F[i] = fromEigen(randomRotation(rng) * sig.asDiagonal() * randomRotation(rng).transpose());
    Eigen::Matrix3d c;
    for (int e = 0; e < 9; ++e) c(e / 3, e % 3) = 30.0 * u(rng);  // |dt C| up to about 0.4
    if (i % 5 == 0) c = -1.5 / dt * Eigen::Matrix3d::Identity();  // F* = -F / 2: inverted
    C[i] = fromEigen(c);
    ids[i] = (uint32_t)((i * 11) % n);
  }
  C[200].m[0][1] = std::nanf("");
  for (float rigidity : {1.f, 0.3f}) {
    pbProjectionBatch(F.data(), C.data(), ids.data(), n, dt, 0.9f, rigidity, Cc.data());
    for (int q = 0; q < n; ++q) {
      const uint32_t i = ids[q];
      const Mat3f want = pbProjectedVelocityGradient(F[i], C[i], dt, 0.9f, rigidity);
      if (!toEigen(want).allFinite()) {
        EXPECT_FALSE(toEigen(Cc[q]).allFinite()) << "particle " << i;
        continue;
      }
      // C_c is a rate: compare dt C_c, the deformation it makes in a step, against 1
      const double scale = dt * toEigen(want).norm() + 1.0;
      EXPECT_LT(dt * (toEigen(Cc[q]) - toEigen(want)).norm(), 2e-5 * scale)
          << "particle " << i << " rigidity " << rigidity;
    }
  }
}

TEST(FixedCorotated, PureRotationIsStressFree) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 50; ++trial) {
    const Mat3f R = fromEigen(randomRotation(rng));
    const Mat3f tau = kirchhoffFixedCorotated(R, 1e5f, 2e5f);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) EXPECT_NEAR(tau.m[i][j], 0.f, 0.05f) << "trial " << trial;
  }
}

TEST(FixedCorotated, SmallStrainIsLinearElasticity) {
  // tau ~ 2 mu eps + lambda tr(eps) I for F = I + eps, eps symmetric and small
  const float mu = 3e4f, lambda = 5e4f, e = 1e-4f;
  Mat3f eps;
  eps.m[0][0] = e; eps.m[1][1] = -0.3f * e; eps.m[2][2] = 0.5f * e;
  eps.m[0][1] = eps.m[1][0] = 0.2f * e;
  const Mat3f tau = kirchhoffFixedCorotated(Mat3f::identity() + eps, mu, lambda);
  const float tr = trace(eps);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const float lin = 2.f * mu * eps.m[i][j] + (i == j ? lambda * tr : 0.f);
      EXPECT_NEAR(tau.m[i][j], lin, 0.01f * 2.f * mu * e) << i << "," << j;
    }
}

// Closed-form homogeneous uniaxial stress of the decoupled Neo-Hookean law (CalculiX
// NEO HOOKE, mu = 1007 Pa, K = 50001.333 Pa): F = diag(stretch, lat, lat) must give zero
// lateral Cauchy stress and the tabulated nominal axial stress.
TEST(NeoHookeanDecoupled, UniaxialMatchesReferenceCurve) {
  std::ifstream in(test::referencePath("neo_hookean_uniaxial.csv"));
  ASSERT_TRUE(in.good());
  const float mu = 1007.f, bulk = 50001.333f;
  std::string line;
  int rows = 0;
  double worst = 0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line[0] == 's') continue;
    std::stringstream ss(line);
    double stretch, nominal, lateral;
    char c;
    ss >> stretch >> c >> nominal >> c >> lateral;
    const Mat3f F = Mat3f::diagonal((float)stretch, (float)lateral, (float)lateral);
    const Mat3f tau = kirchhoffNeoHookeanDecoupled(F, mu, bulk);
    // nominal (first Piola) axial stress P = tau F^-T: P_11 = tau_11 / stretch
    const double P11 = tau.m[0][0] / stretch;
    worst = std::max(worst, std::abs(P11 - nominal) / std::max(std::abs(nominal), 10.0));
    // lateral Kirchhoff stress vanishes to float rounding of the K (J-1) term
    EXPECT_NEAR(tau.m[1][1], 0.f, 0.05f) << "stretch " << stretch;
    ++rows;
  }
  EXPECT_GT(rows, 50);
  EXPECT_LT(worst, 1e-4) << "largest relative error of the nominal stress";
}

TEST(NeoHookeanDecoupled, SmallStrainMatchesLameModuli) {
  const float E = 3000.f, nu = 0.3f;
  const float mu = E / (2 * (1 + nu)), K = E / (3 * (1 - 2 * nu));
  const float e = 1e-4f;
  const Mat3f tau = kirchhoffNeoHookeanDecoupled(Mat3f::diagonal(1 + e, 1, 1), mu, K);
  const float lambda = K - 2.f * mu / 3.f;
  EXPECT_NEAR(tau.m[0][0], (lambda + 2 * mu) * e, 0.01f * (lambda + 2 * mu) * e);
  EXPECT_NEAR(tau.m[1][1], lambda * e, 0.02f * (lambda + 2 * mu) * e);
}

// The strain energy the energy check sums is the potential of the stress the solvers use:
// its derivative dW/dF (central differences in double precision of the float energy)
// matches P = tau F^-T for both laws at random, large deformations (up to 40 % stretch),
// to 1 % of |P|.
TEST(StrainEnergy, DerivativeIsTheFirstPiolaStress) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.4, 0.4);
  for (const int model : {kFixedCorotated, kNeoHookeanDecoupled}) {
    MaterialParams mat;
    mat.model = model;
    mat.mu = 1000.f;
    mat.lambda = 4000.f;
    mat.bulk = mat.lambda + 2.f * mat.mu / 3.f;
    for (int trial = 0; trial < 20; ++trial) {
      Eigen::Matrix3d Fd = randomRotation(rng);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) Fd(i, j) += 0.5 * u(rng);
      if (Fd.determinant() < 0.3) continue;
      const Mat3f F = fromEigen(Fd);
      const Mat3f P = kirchhoffStress(mat, F) * transpose(inverse(F));
      double scale = 0;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) scale = std::max(scale, (double)std::abs(P.m[i][j]));
      const float h = 1e-3f;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
          Mat3f up = F, down = F;
          up.m[i][j] += h;
          down.m[i][j] -= h;
          const double dW = ((double)strainEnergyDensity(mat, up) - strainEnergyDensity(mat, down)) / (2.0 * h);
          EXPECT_NEAR(dW, P.m[i][j], 0.01 * scale) << "model " << model << ", trial " << trial << ", P" << i << j;
        }
    }
  }
}

}  // namespace
}  // namespace mpm
