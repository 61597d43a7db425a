#pragma once
// The end of the APIC G2P of many particles at once, for the CPU: from each particle's
// gather sums (gather_batch.h) its velocity and affine matrix, then (when the kernel
// integrates) its position, deformation gradient and the check of finishParticle, kLanes
// particles per SIMD vector through the same per-particle source (apicAffineFromSums and
// advanceDeformation take any float type). What stays per particle: the push out of the
// shapes (a list walk), and the particles the kernel takes itself, a cut one (its sided
// stencil) and a stray (its stencil off the grid). Host only (GCC / Clang vector
// extensions); elsewhere every particle takes the kernel's gatherSummed.
//
// Why: per particle this is a chain of scalar instructions, a lane of the machine's
// vectors, and it was the largest part of G2P in a small scene (the embedding scene's
// G2P: the update 73 % of it, the gather's sums 27 %).
#include <algorithm>
#include <cstdint>

#include "backend/cpu/stencil_batch.h"
#include "transfer/cut.h"
#include "transfer/particle_check.h"

namespace mpm {

/// Runs G2P kernel f's end of gatherSummed(ids[q], st.at(q), &sums[q], tile) for q < n
/// (sums as apicSumsBatch left them) and returns the particles' StepCheck together: v and
/// C always, with the kernel's integrates() also x += dt v, F <- (I + dt C) F and
/// finishParticle; without, the check of v.v + tr C.
template <class G2P, class Tile, int kRun>
StepCheck apicUpdateBatch(const G2P& f, const uint32_t* ids, int n, const StencilRun<kRun>& st,
                          const ApicSums* sums, const Tile& tile) {
  StepCheck check{0.f, 0xffffffffu};
  const auto take = [&check](float speed2, uint32_t bad) {
    check.maxSpeed2 = std::max(check.maxSpeed2, speed2);
    check.firstBadParticle = std::min(check.firstBadParticle, bad);
  };
#ifdef MPM_CPU_LANES
  using simd::Floats;
  using simd::kLanes;
  using simd::Mask;
  static_assert(kRun % kLanes == 0, "whole vectors");
  const ParticleView& P = f.P;
  const GridGeometry& geo = f.geo;
  const bool integrate = f.integrates();
  const float dt = f.dt;
  const NearParts near = tile.nearParts();
  static_assert(sizeof(ApicSums) == 16 * sizeof(float) && 16 % kLanes == 0, "a particle's sums: whole vectors");
  Floats best = Floats{};  // per lane, the fastest particle's v.v
  for (int q0 = 0; q0 < n; q0 += kLanes) {
    const int lanes = n - q0 < kLanes ? n - q0 : kLanes;
    const uint32_t* id = ids + q0;
    // the lanes the kernel takes itself: a stray (stencil off the grid), a cut particle
    Mask own = Mask{};
    for (int a = 0; a < 3; ++a) {
      Mask b;
      __builtin_memcpy(&b, &st.base[a][q0], sizeof(b));
      own |= ~((b >= 0) & (b + 2 <= geo.cells[a]));  // QuadraticStencil::inside
    }
    if (f.cuts) {
      int cut[kLanes] = {};
      for (int l = 0; l < lanes; ++l) cut[l] = isCut(P.cut[id[l]]) ? -1 : 0;
      Mask c;
      __builtin_memcpy(&c, cut, sizeof(c));
      own |= c;
    }
    const Mask valid = simd::lanesBelow(lanes);
    const uint32_t ownBits = simd::laneBits(own & valid);
    const bool anyOwn = ownBits != 0;
    // the sums in lanes: particle q's ApicSums are 16 floats, 16 / kLanes rows of a
    // kLanes x kLanes transpose each (the lanes past n read sums left from before: unused)
    Floats field[16];
    for (int blk = 0; blk < 16 / kLanes; ++blk) {
      Floats rows[kLanes];
      for (int l = 0; l < kLanes; ++l)
        __builtin_memcpy(&rows[l], reinterpret_cast<const float*>(&sums[q0 + l]) + blk * kLanes, sizeof(Floats));
#ifdef MPM_LANE_SHUFFLES
      simd::transposeLanes(rows);
      for (int r = 0; r < kLanes; ++r) field[blk * kLanes + r] = rows[r];
#else
      for (int r = 0; r < kLanes; ++r)
        for (int l = 0; l < kLanes; ++l) field[blk * kLanes + r][l] = rows[l][r];
#endif
    }
    // ApicSums {v, bi, bj, bk}, each {mass, x, y, z}
    const Floats sv[3] = {field[1], field[2], field[3]};
    const Floats b[3][3] = {{field[5], field[6], field[7]}, {field[9], field[10], field[11]},
                            {field[13], field[14], field[15]}};
    Floats fx[3], v[3], C[9];
    for (int a = 0; a < 3; ++a) __builtin_memcpy(&fx[a], &st.fx[a][q0], sizeof(Floats));
    apicAffineFromSums(sv, b, fx, geo.dx, apicInverseInertia(geo), v, C);
    const Floats speed2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];  // dot(v, v)
    Mask bad;
    Floats x[3], F[9];
    if (integrate) {
      simd::loadVec3Lanes(P.x, id, lanes, x);
      simd::loadMat3Lanes(P.F, id, lanes, Mat3f::identity(), F);
      for (int a = 0; a < 3; ++a) x[a] = x[a] + dt * v[a];
      advanceDeformation(C, dt, F);
      // finishParticle's check: state finite, stencil on the grid (stencilInside), J sound
      const Floats sum = stateSum(x, v, F);
      Mask inside = sum - sum == 0.f;
      for (int a = 0; a < 3; ++a) {
        const Floats d = x[a] - geo.lower[a];
        Floats t;
        for (int l = 0; l < kLanes; ++l) t[l] = __builtin_fmaf(d[l], geo.invDx, -0.5f);
        inside &= (t >= 0.f) & (t < (float)(geo.cells[a] - 1));
      }
      bad = ~(inside & volumeRatioSound(F));
    } else {
      const Floats s = speed2 + (C[0] + C[4] + C[8]);
      bad = ~(s - s == 0.f);
    }
    // the lanes that may touch a part (pushOutOfParts with its list: x outside the list's
    // box, or inside the push-out box of a part on it); the others end untouched and unmoved
    Mask pushed = Mask{};
    if (integrate && f.nParts) {
      if (!near.parts) {
        pushed = ~Mask{};
      } else {
        Mask held = ~Mask{};
        for (int a = 0; a < 3; ++a) held &= (x[a] >= near.lower[a]) & (x[a] <= near.upper[a]);
        pushed = ~held;
        for (int k = 0; k < near.count; ++k) {
          const NearPart& q = near.parts[k];
          Mask meets = ~Mask{};  // NearPart::mayPush(x): NaN meets
          for (int a = 0; a < 3; ++a) meets &= ~((x[a] < q.lower[a]) | (x[a] > q.upper[a]));
          pushed |= meets;
        }
      }
    }
    if (!anyOwn) {
      // whole vectors where the particles are consecutive
      simd::storeVec3Lanes(v, id, lanes, P.v);
      simd::storeMat3Lanes(C, id, lanes, P.C);
      if (integrate) {
        simd::storeVec3Lanes(x, id, lanes, P.x);
        simd::storeMat3Lanes(F, id, lanes, P.F);
      }
    }
    // the step check of the lanes this function finished: the fastest, the first bad
    const Mask mine = ~own & valid;
    best = (mine & (best < speed2)) ? speed2 : best;  // std::max's sequence: NaN speeds ignored
    const uint32_t badBits = simd::laneBits(mine & bad);
    for (uint32_t bits = badBits; bits; bits &= bits - 1) take(0.f, id[__builtin_ctz(bits)]);
    if (anyOwn)
      for (int l = 0; l < lanes; ++l) {
        const uint32_t p = id[l];
        if (ownBits >> l & 1u) {
          const StepCheck c = f.gatherSummed(p, st.template at<QuadraticStencil>(q0 + l), &sums[q0 + l], tile);
          take(c.maxSpeed2, c.firstBadParticle);
          continue;
        }
        P.v[p] = Vec3f{v[0][l], v[1][l], v[2][l]};
        for (int e = 0; e < 9; ++e) P.C[p].m[e / 3][e % 3] = C[e][l];
        if (!integrate) continue;
        P.x[p] = Vec3f{x[0][l], x[1][l], x[2][l]};
        for (int e = 0; e < 9; ++e) P.F[p].m[e / 3][e % 3] = F[e][l];
      }
    if (!integrate) continue;
    // the particles that may touch a part walk its list (their x already stored); the
    // others are left untouched
    float touch[kLanes] = {};
    for (uint32_t bits = simd::laneBits(mine & pushed); bits; bits &= bits - 1) {
      const int l = __builtin_ctz(bits);
      const uint32_t p = id[l];
      touch[l] = pushOutOfParts(P.x[p], f.parts, f.nParts, P.volume0[p], near, P.touch[p] > 0.f) ? 1.f : 0.f;
    }
    if (!anyOwn && simd::consecutive(id, lanes)) {
      __builtin_memcpy(&P.touch[id[0]], touch, sizeof(touch));
    } else {
      for (int l = 0; l < lanes; ++l)
        if (!(ownBits >> l & 1u)) P.touch[id[l]] = touch[l];
    }
  }
  for (int l = 0; l < kLanes; ++l) take(best[l], 0xffffffffu);
#else
  for (int q = 0; q < n; ++q) {
    const StepCheck c = f.gatherSummed(ids[q], st.template at<QuadraticStencil>(q), &sums[q], tile);
    take(c.maxSpeed2, c.firstBadParticle);
  }
#endif
  return check;
}

}  // namespace mpm
