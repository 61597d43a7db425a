// The CPU's G2P end in SIMD lanes (backend/cpu/update_batch.h) and the moves of particle
// fields between their arrays and lanes (backend/cpu/lanes_layout.h) against the
// per-particle code they stand for, bit for bit: the lanes run the same source
// (apicAffineFromSums, advanceDeformation) on another float type.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "backend/cpu/cpu_exec.h"
#include "mpm/scene.h"
#include "shapes/shape_builder.h"
#include "solvers/mls_mpm.h"
#include "solvers/pb_mpm.h"

namespace mpm {
namespace {

bool sameBits(float a, float b) { return std::memcmp(&a, &b, sizeof a) == 0; }
bool sameBits(const Vec3f& a, const Vec3f& b) { return std::memcmp(&a, &b, sizeof a) == 0; }
bool sameBits(const Mat3f& a, const Mat3f& b) { return std::memcmp(&a, &b, sizeof a) == 0; }

#ifdef MPM_CPU_LANES
// Loading kLanes particles' Vec3f and Mat3f into lanes and storing them back: the lanes
// hold each particle's components (consecutive ids through the shuffles, others one by
// one, and a partial vector with the fill), and a store writes exactly the particles named.
TEST(LanesLayout, LoadsAndStoresEachParticlesComponents) {
  using simd::Floats;
  using simd::kLanes;
  const int n = 4 * kLanes;
  std::vector<Vec3f> x(n);
  std::vector<Mat3f> M(n);
  for (int p = 0; p < n; ++p) {
    x[p] = Vec3f{(float)p, 100.f + p, 200.f + p};
    for (int e = 0; e < 9; ++e) M[p].m[e / 3][e % 3] = 1000.f * (float)e + (float)p;
  }
  std::vector<uint32_t> consecutive(kLanes), scattered(kLanes);
  for (int l = 0; l < kLanes; ++l) {
    consecutive[l] = (uint32_t)(kLanes + l);
    scattered[l] = (uint32_t)((7 * l + 3) % n);
  }
  Mat3f fill;
  for (int e = 0; e < 9; ++e) fill.m[e / 3][e % 3] = -1.f - (float)e;
  for (const auto* ids : {&consecutive, &scattered})
    for (int lanes : {kLanes, kLanes - 1}) {
      Floats xa[3], f[9];
      simd::loadVec3Lanes(x.data(), ids->data(), lanes, xa);
      simd::loadMat3Lanes(M.data(), ids->data(), lanes, fill, f);
      for (int l = 0; l < kLanes; ++l) {
        const uint32_t p = (*ids)[l < lanes ? l : 0];  // loadVec3Lanes repeats the first
        for (int a = 0; a < 3; ++a) EXPECT_EQ(xa[a][l], x[p][a]) << "lane " << l << " axis " << a;
        for (int e = 0; e < 9; ++e)
          EXPECT_EQ(f[e][l], l < lanes ? M[(*ids)[l]].m[e / 3][e % 3] : fill.m[e / 3][e % 3]) << "lane " << l;
      }
      // back, each lane + 0.5, into copies: the named particles change, no other
      std::vector<Vec3f> x2 = x;
      std::vector<Mat3f> M2 = M;
      for (auto& v : xa) v += 0.5f;
      for (auto& v : f) v += 0.5f;
      simd::storeVec3Lanes(xa, ids->data(), lanes, x2.data());
      simd::storeMat3Lanes(f, ids->data(), lanes, M2.data());
      std::vector<bool> named(n, false);
      for (int l = 0; l < lanes; ++l) named[(*ids)[l]] = true;
      for (int p = 0; p < n; ++p) {
        const float d = named[p] ? 0.5f : 0.f;
        for (int a = 0; a < 3; ++a) EXPECT_EQ(x2[p][a], x[p][a] + d) << "particle " << p;
        for (int e = 0; e < 9; ++e) EXPECT_EQ(M2[p].m[e / 3][e % 3], M[p].m[e / 3][e % 3] + d) << "particle " << p;
      }
    }
}
#endif

/// The particles of one block with everything G2P's end meets: random positions,
/// velocities and deformation gradients, a stray (stencil off the grid), a cut particle, a
/// particle with a NaN F (reported), some inside a box part (pushed out) or near it.
struct G2PCase {
  GridGeometry geo;
  int origin[3] = {4, 8, 4};  // block (1, 2, 1)
  std::vector<Vec3f> x, v;
  std::vector<Mat3f> C, F;
  std::vector<float> touch, volume0;
  std::vector<CutPlane> cut;
  std::vector<uint32_t> ids;
  std::vector<PartView> parts;
  std::vector<NearPart> nearList;
  BlockTile tile;

  explicit G2PCase(int n) {
    geo.lower = Vec3f{-0.3f, -0.25f, -0.2f};
    geo.dx = 0.05f;
    geo.invDx = 1.f / geo.dx;
    for (int a = 0; a < 3; ++a) geo.cells[a] = 24, geo.blocks[a] = 6;
    std::mt19937 rng(17);
    std::uniform_real_distribution<float> u(-1.f, 1.f), inBlock(0.5f, 0.5f + (float)kBlockSize);
    x.resize(n), v.resize(n), C.resize(n), F.resize(n), touch.assign(n, 0.5f), volume0.resize(n), cut.resize(n);
    for (int p = 0; p < n; ++p) {
      for (int a = 0; a < 3; ++a) x[p][a] = geo.lower[a] + geo.dx * ((float)origin[a] + inBlock(rng));
      v[p] = Vec3f{u(rng), u(rng), u(rng)};
      F[p] = Mat3f::identity();
      for (int e = 0; e < 9; ++e) F[p].m[e / 3][e % 3] += 0.2f * u(rng), C[p].m[e / 3][e % 3] = u(rng);
      volume0[p] = 1e-4f * (1.f + 0.5f * u(rng));
    }
    x[40] = Vec3f{-9.f, 0.f, 0.f};  // a stray (its vector stored lane by lane), at rest:
    v[40] = Vec3f{};                 // the fastest particle is one the lanes finish
    cut[5].normal = Vec3f{0.f, 1.f, 0.f};  // a cut particle
    cut[5].offset = 0.01f;
    F[20].m[1][2] = std::numeric_limits<float>::quiet_NaN();  // reported from whole vectors
    // the tile's grid velocities
    tile.setBlock(geo, geo.blockIndex(origin[0] >> kBlockBits, origin[1] >> kBlockBits, origin[2] >> kBlockBits));
    for (Float4& m : tile.mv) m = Float4::make(0.5f + 0.5f * u(rng), u(rng), u(rng), u(rng));
    // a box over the block's upper half: some particles end inside it, some near
    ShapeDesc box;
    box.parts = {Geometry::box({0.05f, 0.04f, 0.05f})};
    const float top = geo.lower[1] + geo.dx * ((float)origin[1] + 3.5f);
    box.pose.position = {geo.lower[0] + geo.dx * (origin[0] + 2.5f), top + 0.02f, geo.lower[2] + geo.dx * (origin[2] + 2.5f)};
    const ShapeState state{box.pose, box.linearVelocity, box.angularVelocity};
    appendParts(box, state, 0, 0.f, box.pose.position,
                [](const std::shared_ptr<const SignedDistanceGrid>&) { return (const float*)nullptr; }, parts);
    placePart(parts[0], makeBody(box, state, 0.f), geo.dx, touchDistance(1.5e-4f));  // the largest volume0 below
    nearList.push_back(NearPart{0, parts[0].pushLower, parts[0].pushUpper});
    tile.near.parts = nearList.data();
    tile.near.count = 1;
    for (int a = 0; a < 3; ++a) {  // the block's box as Binning::nearBox draws it, ...
      tile.near.lower[a] = geo.lower[a] + geo.dx * (float)origin[a];
      tile.near.upper[a] = geo.lower[a] + geo.dx * (float)(origin[a] + kBlockSize + 1);
    }
    // ... but ending 3 cells into the block along x, so that some particles lie outside it
    // (every part is tried for them: the list holds all the parts there are)
    tile.near.upper[0] = geo.lower[0] + geo.dx * (float)(origin[0] + 3);
    ids.resize(n);
    for (int p = 0; p < n; ++p) ids[p] = (uint32_t)p;
  }
  ParticleView view() {
    ParticleView P;
    P.x = x.data(), P.v = v.data(), P.C = C.data(), P.F = F.data();
    P.touch = touch.data(), P.volume0 = volume0.data(), P.cut = cut.data();
    P.count = (uint32_t)x.size();
    return P;
  }
};

/// Runs apicUpdateBatch on one copy of the case and each particle's gatherSummed on
/// another, and compares every field and the step check bit for bit.
template <class Kernel>
void expectPerParticleBits(const G2PCase& start, Kernel k, int count, int* touched) {
  G2PCase batch = start, single = start;
  constexpr int kRun = 64;
  StencilRun<kRun> st;
  st.compute(batch.geo, batch.x.data(), batch.ids.data(), count);
  ApicSums sums[kRun]{};
  apicSumsBatch<BlockTile::kEdge>(st, count, batch.geo, batch.tile.mv, batch.tile.origin, sums);
  batch.tile.near.parts = batch.nearList.data();
  single.tile.near.parts = single.nearList.data();

  k.P = batch.view();
  k.parts = batch.parts.data();
  const StepCheck got = apicUpdateBatch(k, batch.ids.data(), count, st, sums, batch.tile);
  k.P = single.view();
  k.parts = single.parts.data();
  StepCheck want{0.f, 0xffffffffu};
  for (int q = 0; q < count; ++q) {
    const StepCheck c = k.gatherSummed(single.ids[q], st.at<QuadraticStencil>(q), &sums[q], single.tile);
    want.maxSpeed2 = std::max(want.maxSpeed2, c.maxSpeed2);
    want.firstBadParticle = std::min(want.firstBadParticle, c.firstBadParticle);
  }
  EXPECT_TRUE(sameBits(got.maxSpeed2, want.maxSpeed2)) << got.maxSpeed2 << " against " << want.maxSpeed2;
  EXPECT_EQ(got.firstBadParticle, want.firstBadParticle);
  for (int p = 0; p < (int)start.x.size(); ++p) {
    EXPECT_TRUE(sameBits(batch.x[p], single.x[p])) << "x of particle " << p;
    EXPECT_TRUE(sameBits(batch.v[p], single.v[p])) << "v of particle " << p;
    EXPECT_TRUE(sameBits(batch.C[p], single.C[p])) << "C of particle " << p;
    EXPECT_TRUE(sameBits(batch.F[p], single.F[p])) << "F of particle " << p;
    EXPECT_TRUE(sameBits(batch.touch[p], single.touch[p])) << "touch of particle " << p;
    EXPECT_TRUE(sameBits(batch.cut[p].offset, single.cut[p].offset)) << "cut of particle " << p;
    if (single.touch[p] == 1.f) ++*touched;
  }
}

// MLS-MPM's G2P end and PB-MPM's (integrating and not), runs of 64 and of 45 particles
// (a partial last vector), with and without the box part, with cuts on and off.
TEST(ApicUpdateBatch, GivesEachParticlesUpdateBits) {
  const G2PCase start(64);
  int touched = 0;
  for (int count : {64, 45})
    for (bool withParts : {true, false})
      for (bool cuts : {true, false}) {
        SCOPED_TRACE(::testing::Message() << count << " particles, parts " << withParts << ", cuts " << cuts);
        MlsMpm::G2P mls{ParticleView{}, start.geo, 2e-3f};
        mls.nParts = withParts ? 1 : 0;
        mls.cuts = cuts;
        expectPerParticleBits(start, mls, count, &touched);
        for (bool integrate : {true, false}) {
          PbMpm::G2P pb{ParticleView{}, start.geo, 2e-3f, integrate};
          pb.nParts = withParts ? 1 : 0;
          pb.cuts = cuts;
          expectPerParticleBits(start, pb, count, &touched);
        }
      }
  EXPECT_GT(touched, 0) << "no particle reached the part: the push-out went untested";
}

}  // namespace
}  // namespace mpm
