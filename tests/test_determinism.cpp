// The CPU path colours grid blocks instead of using float atomics, so every node sums its
// contributions in the same order whatever the thread count: 1 and 2 threads must give
// bit-identical trajectories, with every solver. And a pinned hash of one trajectory per
// solver, so a change that alters the physics shows.
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <csignal>
#include <limits>
#include <vector>

#include <algorithm>
#include <random>

#include <sys/wait.h>
#include <unistd.h>

#include "backend/cpu/cpu_exec.h"
#include "backend/cpu/thread_team.h"
#include "mpm/scene.h"
#include "transfer/apic.h"
#include "scenes/standard_scenes.h"
#include "forked_child.h"
#include "solver_cases.h"

namespace mpm {
namespace {

std::vector<Vec3f> runBenchScene(SolverType solver, int threads, int frames) {
  SceneSettings s = scenes::CressimBench::settings(Backend::Cpu, threads);
  s.solver = solver;
  // PB-MPM runs `iterations` (10) P2G/G2P cycles per substep and is made for large steps:
  // one substep per frame gives it the 200 cycles the others make in 200 substeps (10x
  // the test's time otherwise, 17 s).
  if (solver == SolverType::PbMpm) s.substeps.fixedSubsteps = 1;
  Scene scene(s);
  ParticleObjectDesc box = scenes::CressimBench::box(1.f);  // 8k particles
  box.angularVelocity = {0.5f, 1.f, 0.f};                   // exercise all directions
  const ParticleObjectId id = scene.addParticleObject(box);
  for (int f = 0; f < frames; ++f) scene.step(scenes::CressimBench::kFrameDt);
  std::vector<Vec3f> x;
  scene.readPositions(id, x);
  return x;
}

class Determinism : public ::testing::TestWithParam<SolverType> {};

TEST_P(Determinism, OneAndTwoThreadsBitIdenticalOver20Frames) {
  const std::vector<Vec3f> a = runBenchScene(GetParam(), 1, 20), b = runBenchScene(GetParam(), 2, 20);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a.size(), 8000u);
  EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3f)));
  // and the block actually moved (falling under gravity (0, -1, 0))
  double meanY = 0;
  for (const Vec3f& p : a) meanY += p.y;
  meanY /= a.size();
  std::printf("%s: mean height after 20 frames %.4f m\n", test::solverName(GetParam()).c_str(), meanY);
  EXPECT_LT(meanY, -0.05);
}

/// FNV-1a of the bytes of `x`.
uint64_t fnv1a(const std::vector<Vec3f>& x) {
  uint64_t h = 1469598103934665603ull;
  const auto* b = reinterpret_cast<const unsigned char*>(x.data());
  for (size_t i = 0; i < x.size() * sizeof(Vec3f); ++i) h = (h ^ b[i]) * 1099511628211ull;
  return h;
}

// The positions after 20 frames of the bench scene (one thread), hashed and pinned. The
// bits depend on the instruction set the library is compiled for (with FMA the compiler
// contracts a * b + c), so the values hold for builds for the x86-64 baseline
// (MPM_NATIVE_ARCH=OFF, as the sanitizer tree of scripts/sanitize.sh is built: no FMA, the
// same bits at -O1 and -O3). A change that alters the physics changes them: say why in
// its commit and pin the new values it prints.
TEST_P(Determinism, PinnedTrajectoryHash) {
#ifndef MPM_BASELINE_ISA
  GTEST_SKIP() << "built for this machine's instruction set (MPM_NATIVE_ARCH=ON); the pinned hashes are for "
                  "x86-64 baseline builds (MPM_NATIVE_ARCH=OFF), which scripts/sanitize.sh makes";
#endif
  const uint64_t h = fnv1a(runBenchScene(GetParam(), 1, 20));
  std::printf("%s: trajectory hash 0x%016llx\n", test::solverName(GetParam()).c_str(), (unsigned long long)h);
  const uint64_t pinned = GetParam() == SolverType::MlsMpm        ? 0xba561996f3217713ull
                          : GetParam() == SolverType::StandardMpm ? 0x9cd6dbd94161b758ull
                                                                  : 0xa911bce9d864c1b9ull;
  EXPECT_EQ(h, pinned) << "the trajectory changed: if the physics was meant to change, pin the new hash";
}

/// The 40^3-cell grid of the binning tests, [-1, 1]^3.
GridGeometry binningGrid() {
  GridGeometry geo;
  geo.lower = {-1.f, -1.f, -1.f};
  geo.dx = 0.05f;
  geo.invDx = 1.f / geo.dx;
  for (int a = 0; a < 3; ++a) {
    geo.cells[a] = 40;
    geo.blocks[a] = (geo.cells[a] + kBlockSize) / kBlockSize;
  }
  return geo;
}

// The CPU binning is a parallel counting sort: each thread takes a range of particles. Its
// result must be the one stable sort by block (and the same active blocks in the same
// slots) whatever the thread count, also for particles in no particular order (after a
// cut or an import, before the first reorder) and with strays off the grid (binned to
// block 0, as P2G expects).
TEST(Binning, StableSortByBlockWhateverTheThreadCount) {
  const GridGeometry geo = binningGrid();
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> inBox(-0.6f, 0.7f), offGrid(-3.f, 3.f);
  const size_t n = 20011;  // above CpuExec::kMinParallel, not a multiple of any team size
  std::vector<Vec3f> x(n), v(n);
  for (size_t i = 0; i < n; ++i)
    x[i] = i % 97 == 0 ? Vec3f{offGrid(rng), offGrid(rng), offGrid(rng)} : Vec3f{inBox(rng), inBox(rng), inBox(rng)};
  // and a sorted stretch: long runs of one block, as after the per-frame reorder
  std::sort(x.begin() + n / 2, x.end(), [&](const Vec3f& a, const Vec3f& b) {
    return geo.particleBlock(a) < geo.particleBlock(b);
  });
  ParticleView P;
  P.x = x.data();
  P.v = v.data();
  P.count = (uint32_t)n;

  std::vector<uint32_t> key(n), want(n);
  size_t strays = 0;
  for (size_t i = 0; i < n; ++i) {
    key[i] = geo.stencilInside(x[i]) ? geo.particleBlock(x[i]) : 0u;
    strays += !geo.stencilInside(x[i]);
  }
  ASSERT_GT(strays, 50u);
  for (size_t i = 0; i < n; ++i) want[i] = (uint32_t)i;
  std::stable_sort(want.begin(), want.end(), [&](uint32_t a, uint32_t b) { return key[a] < key[b]; });

  std::vector<uint32_t> active1;
  for (int threads : {1, 2, 3, 4}) {
    CpuExec exec(threads);
    CpuExec::Binning bins(exec, geo);
    for (int pass = 0; pass < 2; ++pass) {  // the second reuses the tables the first left
      exec.bin(P, bins);
      EXPECT_TRUE(std::equal(want.begin(), want.end(), bins.order())) << threads << " threads, pass " << pass;
      const GridView g = bins.gridView();
      const std::vector<uint32_t> active(g.activeBlocks, g.activeBlocks + g.activeCount);
      if (threads == 1 && pass == 0) active1 = active;
      EXPECT_EQ(active, active1) << threads << " threads, pass " << pass;
      for (uint32_t s = 0; s < g.activeCount; ++s) EXPECT_EQ(g.blockSlot[g.activeBlocks[s]], (int32_t)s);
    }
  }
  EXPECT_GT(active1.size(), 100u);
}

// The GPU's binning sorts particles by GridGeometry::particleKey so that a block's particles
// lie together and within them each stencil cell's (its P2G sums a cell's warp lanes before
// adding them to the block's tile): the key must order by block first, then by the stencil
// base's cell, and give the block back.
TEST(Binning, GpuSortKeyOrdersByBlockThenCell) {
  const GridGeometry geo = binningGrid();
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> inBox(-0.95f, 0.95f);
  std::vector<Vec3f> x(5000);
  for (Vec3f& p : x) p = {inBox(rng), inBox(rng), inBox(rng)};
  const auto baseOf = [&](const Vec3f& p) {
    int b[3];
    Vec3f fx;
    geo.stencilBase(p, b, fx);
    return std::array<int, 3>{b[0], b[1], b[2]};
  };
  std::sort(x.begin(), x.end(), [&](const Vec3f& a, const Vec3f& b) { return geo.particleKey(a) < geo.particleKey(b); });
  for (size_t i = 0; i < x.size(); ++i) {
    ASSERT_TRUE(geo.stencilInside(x[i]));
    EXPECT_EQ(GridGeometry::keyBlock(geo.particleKey(x[i])), geo.particleBlock(x[i])) << i;
    if (i == 0) continue;
    const uint32_t blockA = geo.particleBlock(x[i - 1]), blockB = geo.particleBlock(x[i]);
    ASSERT_LE(blockA, blockB) << "blocks out of order at " << i;
    // equal keys <=> equal stencil bases (block and cell)
    const bool sameKey = geo.particleKey(x[i - 1]) == geo.particleKey(x[i]);
    EXPECT_EQ(sameKey, baseOf(x[i - 1]) == baseOf(x[i])) << i;
  }
  // a base once left does not come back: each base is one run
  std::vector<std::array<int, 3>> runs;
  for (size_t i = 0; i < x.size(); ++i)
    if (i == 0 || baseOf(x[i]) != baseOf(x[i - 1])) runs.push_back(baseOf(x[i]));
  std::sort(runs.begin(), runs.end());
  EXPECT_EQ(std::adjacent_find(runs.begin(), runs.end()), runs.end()) << "a stencil cell's particles are split";
  EXPECT_GT(runs.size(), 1000u);  // the test saw many cells
}

INSTANTIATE_TEST_SUITE_P(AllSolvers, Determinism, test::allSolvers(), test::solverParamName());

// The CPU backend's own threads (backend/cpu/thread_team.h). Every member of a run writes
// its slot, waits at the barrier, then reads all the others': a barrier that let one member
// through early reads a slot still holding the previous round's value. Runs of 2, 3 and 1
// members in turn, so workers sit out some runs (they must still report back).
TEST(ThreadTeam, BarrierSeparatesRounds) {
  ThreadTeam team;
  std::vector<int> slot(3, -1);
  int wrong = 0, runs = 0;
  for (int round = 0; round < 3000; ++round) {
    const int nt = 1 + (round % 3 == 2 ? 0 : 1 + round % 3);  // 2, 3, 1, 2, 3, 1, ...
    std::vector<int> seen(nt, 0);
    team.run(nt, [&](int t, int n) {
      slot[t] = round;
      team.barrier(n);
      for (int u = 0; u < n; ++u) seen[t] += slot[u] == round;
      team.barrier(n);  // nobody writes the next round's slot before all have read
    });
    for (int t = 0; t < nt; ++t) wrong += seen[t] != nt;
    ++runs;
  }
  EXPECT_EQ(wrong, 0) << "of " << runs << " runs";
}

// A process that forks after stepping on two threads (Python's multiprocessing does, for
// data generation): the child has only the forking thread, so the team it inherited has no
// workers. Before the child made a crew of its own, its first threaded loop waited for them
// forever (here the alarm ends it after 60 s). The child's next frames must be the
// parent's, bit for bit.
TEST(ThreadTeam, ForkedChildStepsLikeItsParent) {
  SceneSettings s = scenes::CressimBench::settings(Backend::Cpu, 2);
  Scene scene(s);
  const ParticleObjectId id = scene.addParticleObject(scenes::CressimBench::box(1.f));
  for (int f = 0; f < 3; ++f) scene.step(scenes::CressimBench::kFrameDt);  // the team is working

  int pipeFd[2];
  ASSERT_EQ(pipe(pipeFd), 0);
  const pid_t child = test::forkChild([&] {
    for (int f = 0; f < 3; ++f) scene.step(scenes::CressimBench::kFrameDt);
    std::vector<Vec3f> x;
    scene.readPositions(id, x);
    return test::writeAll(pipeFd[1], x);
  });
  ASSERT_GE(child, 0);
  close(pipeFd[1]);
  for (int f = 0; f < 3; ++f) scene.step(scenes::CressimBench::kFrameDt);
  std::vector<Vec3f> parent;
  scene.readPositions(id, parent);
  ASSERT_EQ(parent.size(), 8000u);
  const std::vector<Vec3f> fromChild = test::readAll<Vec3f>(pipeFd[0], parent.size());
  close(pipeFd[0]);
  test::expectChildSucceeded(child);
  ASSERT_EQ(fromChild.size(), parent.size());
  EXPECT_EQ(0, std::memcmp(parent.data(), fromChild.data(), parent.size() * sizeof(Vec3f)));
}

// Forked while a step runs (between advance and fetchResults): the step runs on a thread of
// the parent's, so the child's scene is half stepped. Its fetchResults says so instead of
// waiting forever for a thread it does not have; the parent fetches as usual.
TEST(ThreadTeam, ForkedChildRefusesAStepInFlight) {
  Scene scene(scenes::CressimBench::settings(Backend::Cpu, 2));
  scene.addParticleObject(scenes::CressimBench::box(1.f));
  scene.advance(scenes::CressimBench::kFrameDt);
  const pid_t child = test::forkChild([&] {
    return test::throwsSaying([&] { scene.fetchResults(); }, "forked while a step was running");
  });
  ASSERT_GE(child, 0);
  scene.fetchResults();
  test::expectChildSucceeded(child, "1: fetchResults returned, 2: another error");
}


/// The grid of the lane tests below: 24 cells of 5 cm a side (6 blocks), off the origin.
GridGeometry laneTestGrid() {
  GridGeometry geo;
  geo.lower = Vec3f{-0.3f, -0.25f, -0.2f};
  geo.dx = 0.05f;
  geo.invDx = 1.f / geo.dx;
  for (int a = 0; a < 3; ++a) geo.cells[a] = 24, geo.blocks[a] = 6;
  return geo;
}

// The CPU's P2G and G2P take the stencils of a run of particles from StencilRun (SIMD
// lanes). Its base must be QuadraticStencil's exactly (binning found the block from it:
// another base is a tile index out of range), and so must fx, computed from it with
// exact operations; the weights may differ by the rounding of a contracted multiply-add
// (3e-8 on weights <= 0.75). Positions at and near half cells (the grid's last ones too),
// strays (below, above, NaN, infinite), consecutive ids (the vector loads) and not, and a
// partial last vector.
TEST(StencilRun, MatchesQuadraticStencil) {
  const GridGeometry geo = laneTestGrid();
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-0.4f, 1.0f);
  const int n = 1000;
  std::vector<Vec3f> x(n);
  for (int i = 0; i < n; ++i) {
    x[i] = Vec3f{u(rng), u(rng), u(rng)};
    if (i % 5 == 0)  // on a half cell, or the float next to it
      for (int a = 0; a < 3; ++a) {
        const float half = geo.lower[a] + geo.dx * (0.5f + (float)(i % 17));
        x[i][a] = i % 3 == 0 ? half : std::nextafter(half, i % 2 ? 1.f : -1.f);
      }
  }
  for (int i = 10; i < 16; ++i) {  // the stencil's last node on the grid's last, or one beyond
    const float edge = geo.lower[i % 3] + geo.dx * ((float)geo.cells[i % 3] - 0.5f);
    x[i] = Vec3f{0.2f, 0.2f, 0.2f};
    x[i][i % 3] = i < 13 ? edge : std::nextafter(edge, -1.f);
  }
  x[7] = Vec3f{std::nanf(""), 0.1f, 0.1f};
  x[8] = Vec3f{0.1f, 1e30f, -1e30f};
  x[9] = Vec3f{0.1f, 0.1f, std::numeric_limits<float>::infinity()};
  std::vector<uint32_t> ids(n);
  for (int i = 0; i < n; ++i) ids[i] = (uint32_t)i;
  std::shuffle(ids.begin() + 500, ids.end(), rng);  // the first half consecutive
  constexpr int kRun = 64;
  StencilRun<kRun> run;
  for (int r = 0; r < n; r += kRun) {
    const int count = std::min(kRun, n - r) - (r == 0 ? 3 : 0);  // and one partial run
    run.compute(geo, x.data(), &ids[r], count);
    for (int q = 0; q < count; ++q) {
      const uint32_t i = ids[r + q];
      const QuadraticStencil want(geo, x[i]), got = run.at<QuadraticStencil>(q);
      // and GridGeometry::stencilInside, which skips the rounding, agrees with the base
      EXPECT_EQ(geo.stencilInside(x[i]), want.inside(geo)) << "particle " << i;
      for (int a = 0; a < 3; ++a) {
        ASSERT_EQ(got.base[a], want.base[a]) << "particle " << i << " axis " << a;
        if (!std::isfinite(x[i][a])) continue;  // NaN fx for NaN x either way
        EXPECT_EQ(got.fx[a], want.fx[a]) << "particle " << i << " axis " << a;
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(got.w[a][k], want.w[a][k], 3e-8f) << "particle " << i;
      }
    }
  }
}

// G2P's gather sums of a run of particles side by side in SIMD lanes (apicSumsBatch: four
// particles' nodes per AVX-512 vector) against each particle's own apicSums from the same
// stencil and tile. The same arithmetic lane by lane; they may differ only by the rounding
// of a multiply-add the compiler contracts in one and not the other (sums of about 1 here,
// so 1e-6). A wrong node or weight is off by about 0.1. Particles anywhere in the block, a
// stray (its sums are not written), and runs of 64 and of 61 (a partial last vector).
TEST(ApicSumsBatch, MatchesEachParticlesSums) {
  const GridGeometry geo = laneTestGrid();
  constexpr int kEdge = kBlockSize + 2;
  const int origin[3] = {4, 8, 12};  // block (1, 2, 3)
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> vel(-1.f, 1.f), inBlock(0.5f, 0.5f + (float)kBlockSize);
  std::vector<Float4> mv(kEdge * kEdge * kEdge);
  for (Float4& n : mv) n = Float4::make(0.5f + 0.5f * vel(rng), vel(rng), vel(rng), vel(rng));
  struct TileNodes {
    const Float4* mv;
    const int* origin;
    Float4 velocity4(int i, int j, int k) const {
      return mv[((i - origin[0]) * kEdge + (j - origin[1])) * kEdge + (k - origin[2])];
    }
  } nodes{mv.data(), origin};
  constexpr int kRun = 64;
  std::vector<Vec3f> x(kRun);
  std::vector<uint32_t> ids(kRun);
  for (int count : {kRun, kRun - 3}) {
    for (int q = 0; q < kRun; ++q) {
      ids[q] = (uint32_t)q;
      for (int a = 0; a < 3; ++a) x[q][a] = geo.lower[a] + geo.dx * ((float)origin[a] + inBlock(rng));
    }
    x[5] = Vec3f{-9.f, 0.f, 0.f};  // a stray
    StencilRun<kRun> st;
    st.compute(geo, x.data(), ids.data(), count);
    ApicSums got[kRun];
    const ApicSums unwritten{Float4::make(7.f, 7.f, 7.f, 7.f), {}, {}, {}};
    for (ApicSums& g : got) g = unwritten;
    apicSumsBatch<kEdge>(st, count, geo, mv.data(), origin, got);
    for (int q = 0; q < count; ++q) {
      const QuadraticStencil s = st.at<QuadraticStencil>(q);
      if (!s.inside(geo)) {
        EXPECT_EQ(q, 5);
        continue;
      }
      const ApicSums want = apicSums(s, nodes);
      const Float4* w[4] = {&want.v, &want.bi, &want.bj, &want.bk};
      const Float4* g[4] = {&got[q].v, &got[q].bi, &got[q].bj, &got[q].bk};
      for (int f = 0; f < 4; ++f)
        for (int c = 0; c < 4; ++c)
          EXPECT_NEAR((*g[f])[c], (*w[f])[c], 1e-6f) << "run of " << count << ", particle " << q << ", sum " << f
                                                      << ", lane " << c;
    }
  }
}

/// A particle at a random place in the block whose first node is `origin` (its stencil
/// base inside the block), with random mass, momentum, affine matrix and touch, scattered
/// (with the centroid sums) into both `tile` and `want`.
void scatterRandomParticle(const GridGeometry& geo, const int origin[3], std::mt19937& rng, P2GTile& tile,
                           BlockTile& want) {
  std::uniform_real_distribution<float> u(-1.f, 1.f), inBlock(0.5f, 0.5f + (float)kBlockSize);
  Vec3f x;
  for (int a = 0; a < 3; ++a) x[a] = geo.lower[a] + geo.dx * ((float)origin[a] + inBlock(rng));
  const QuadraticStencil st(geo, x);
  ASSERT_TRUE(st.inside(geo));
  const float m = 0.5f + 0.4f * u(rng), touch = u(rng) > 0.f ? 1.f : 0.f;
  const Vec3f mv{u(rng), u(rng), u(rng)};
  Mat3f A;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) A.m[r][c] = 20.f * u(rng);
  apicScatter<true>(st, geo.dx, m, mv, A, x, touch, tile);
  apicScatter<true>(st, geo.dx, m, mv, A, x, touch, want);
}

// The CPU's P2G records each particle's APIC terms and sums a block's particles cell by
// cell (stencil rows in 16-float vectors where the CPU has AVX-512) before adding them to
// the tile (backend/cpu/scatter_cells.h). Every node of the tile must hold what adding each
// particle's scatter node by node gives, up to the rounding of the different order: 300
// particles in one block (about 5 per cell, so cells of one and of many), random masses,
// momenta, affine matrices and touch values, with the centroid sums.
TEST(CellScatter, SumsMatchEachParticlesScatter) {
  const GridGeometry geo = laneTestGrid();
  const int origin[3] = {4, 8, 12};  // block (1, 2, 3)
  std::mt19937 rng(13);
  P2GTile tile;
  BlockTile want;
  const uint32_t block = geo.blockIndex(1, 2, 3);
  tile.setBlock(geo, block);
  want.setBlock(geo, block);
  ASSERT_EQ(tile.origin[0], origin[0]);
  tile.clear<true, false>();
  want.clear<true, false>();
  CellScatter cells;
  tile.cells = &cells;
  const int n = 300;
  cells.reserve(n);
  for (int p = 0; p < n; ++p) {
    scatterRandomParticle(geo, origin, rng, tile, want);
  }
  tile.finish<true>();
  float worst = 0.f;
  for (int node = 0; node < BlockTile::kNodes; ++node)
    for (int c = 0; c < 4; ++c) {
      worst = std::max(worst, std::fabs(tile.mv[node][c] - want.mv[node][c]));
      worst = std::max(worst, std::fabs(tile.mx[node][c] - want.mx[node][c]));
      EXPECT_NEAR(tile.mv[node][c], want.mv[node][c], 2e-6f) << "node " << node << " lane " << c;
      EXPECT_NEAR(tile.mx[node][c], want.mx[node][c], 2e-6f) << "node " << node << " lane " << c;
    }
  std::printf("largest difference from the node-by-node scatter: %.3g\n", worst);
}

// A cell's sum (scatter_cells.h: with AVX-512, stencil rows in 16-float vectors) is, lane
// by lane, apicScatterTerms's arithmetic: a particle alone in its block must leave exactly
// the node-by-node scatter's bits in the tile (summed with zeros only). 2000 particles,
// each alone in a fresh tile, random stencils, terms and weights, with the centroid sums.
TEST(CellScatter, ParticleAloneGivesTheNodeByNodeBits) {
  const GridGeometry geo = laneTestGrid();
  std::mt19937 rng(29);
  const uint32_t block = geo.blockIndex(1, 2, 3);
  const int origin[3] = {4, 8, 12};
  CellScatter cells;
  int differing = 0;
  for (int p = 0; p < 2000; ++p) {
    P2GTile tile;
    BlockTile want;
    tile.setBlock(geo, block);
    want.setBlock(geo, block);
    tile.clear<true, false>();
    want.clear<true, false>();
    tile.cells = &cells;
    cells.reserve(1);
    scatterRandomParticle(geo, origin, rng, tile, want);
    tile.finish<true>();
    for (int node = 0; node < BlockTile::kNodes; ++node)
      for (int c = 0; c < 4; ++c)
        if (tile.mv[node][c] != want.mv[node][c] || tile.mx[node][c] != want.mx[node][c]) ++differing;
  }
  EXPECT_EQ(differing, 0) << "node lanes whose bits differ from the node-by-node scatter";
}

}  // namespace
}  // namespace mpm
