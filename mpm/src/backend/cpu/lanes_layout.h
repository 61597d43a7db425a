#pragma once
// What a SIMD lane is on the CPU, and particle fields between their arrays of structures
// (Vec3f, Mat3f per particle) and lanes (one vector per component, a particle per lane),
// for the CPU's batched kernels. kLanes consecutive particles' fields are whole vectors in
// memory: then a few shuffles per vector move them (GCC's two-source __builtin_shuffle, a
// vpermt2ps each on AVX-512) instead of one scalar load or store per component and
// particle. Other particles, and compilers without that builtin, go component by
// component. Host only (GCC / Clang vector extensions, MPM_CPU_LANES); elsewhere every
// particle takes the per-particle path.
#include <cstdint>

#include "mpm/math.h"

namespace mpm {
#if defined(__GNUC__) && !defined(__CUDACC__)
#define MPM_CPU_LANES 1
namespace simd {
// the machine's vector width (the x86-64 baseline's 4 too: wider vectors would be passed
// between functions differently from what an AVX caller expects, -Wpsabi)
#if defined(__AVX512F__)
constexpr int kLanes = 16;
#elif defined(__AVX__)
constexpr int kLanes = 8;
#else
constexpr int kLanes = 4;
#endif
typedef float Floats __attribute__((vector_size(4 * kLanes)));
typedef int Mask __attribute__((vector_size(4 * kLanes)));

inline Floats splat(float s) { return Floats{} + s; }
inline Floats sqrtLanes(Floats x) {
  Floats r;
  for (int l = 0; l < kLanes; ++l) r[l] = __builtin_sqrtf(x[l]);  // one vsqrtps (-fno-math-errno)
  return r;
}
inline bool any(Mask m) {
  int a = 0;
  for (int l = 0; l < kLanes; ++l) a |= m[l];
  return a != 0;
}

// inlined always: GCC had left some out of line (the vectors then go through memory)
#define MPM_LANES_INLINE inline __attribute__((always_inline))

/// n whole vectors from memory and back, one vector move each (a single memcpy of a
/// Mat3f run, 576 bytes, was a call to memcpy through the stack)
template <int n>
MPM_LANES_INLINE void loadVectors(const void* src, Floats* v) {
  for (int k = 0; k < n; ++k) __builtin_memcpy(&v[k], static_cast<const char*>(src) + k * sizeof(Floats), sizeof(Floats));
}
template <int n>
MPM_LANES_INLINE void storeVectors(const Floats* v, void* dst) {
  for (int k = 0; k < n; ++k) __builtin_memcpy(static_cast<char*>(dst) + k * sizeof(Floats), &v[k], sizeof(Floats));
}

#if defined(__GNUC__) && !defined(__clang__)
#define MPM_LANE_SHUFFLES 1
typedef int Ints __attribute__((vector_size(4 * kLanes)));

/// out[c][l] = component c of element l of the 3 kLanes floats in[0], in[1], in[2] (kLanes
/// triples, x y z x y z ...).
MPM_LANES_INLINE void deinterleave3(const Floats in[3], Floats out[3]) {
  for (int c = 0; c < 3; ++c) {
    Ints lo, hi;
    for (int l = 0; l < kLanes; ++l) {
      const int e = 3 * l + c;  // 0 .. 3 kLanes - 1
      lo[l] = e < 2 * kLanes ? e : 0;
      hi[l] = e < 2 * kLanes ? l : e - 2 * kLanes + kLanes;
    }
    out[c] = __builtin_shuffle(__builtin_shuffle(in[0], in[1], lo), in[2], hi);
  }
}
/// The inverse of deinterleave3: the triples (in[0][l], in[1][l], in[2][l]) in order.
MPM_LANES_INLINE void interleave3(const Floats in[3], Floats out[3]) {
  for (int k = 0; k < 3; ++k) {
    Ints lo, hi;
    for (int j = 0; j < kLanes; ++j) {
      const int e = k * kLanes + j, c = e % 3, l = e / 3;
      lo[j] = c == 0 ? l : c == 1 ? kLanes + l : 0;
      hi[j] = c == 2 ? kLanes + l : j;
    }
    out[k] = __builtin_shuffle(__builtin_shuffle(in[0], in[1], lo), in[2], hi);
  }
}
/// Transposes the kLanes x kLanes matrix rows[r][c] in place: swaps bit s of the row and
/// column indices for s = kLanes / 2 .. 1 (two shuffles per pair of rows and bit). One
/// template per bit, so every mask is a constant.
template <int s = kLanes / 2>
MPM_LANES_INLINE void transposeLanes(Floats rows[kLanes]) {
  Ints keep, swap;
#pragma GCC unroll 16
  for (int c = 0; c < kLanes; ++c) {
    keep[c] = (c & s) ? kLanes + c - s : c;
    swap[c] = (c & s) ? kLanes + c : c + s;
  }
#pragma GCC unroll 16
  for (int i = 0; i < kLanes; ++i) {
    if (i & s) continue;
    const Floats a = rows[i], b = rows[i + s];
    rows[i] = __builtin_shuffle(a, b, keep);
    rows[i + s] = __builtin_shuffle(a, b, swap);
  }
  if constexpr (s > 1) transposeLanes<s / 2>(rows);
}
#endif

/// Whether ids[0 .. kLanes) are kLanes consecutive particles (their fields whole vectors).
MPM_LANES_INLINE bool consecutive(const uint32_t* ids, int lanes) {
  return lanes == kLanes && ids[kLanes - 1] - ids[0] == (uint32_t)(kLanes - 1);
}

/// xa[a][l] = x[ids[l]][a]; lanes from `lanes` on repeat the first. Particles come sorted
/// by block (reordered every frame), so ids are mostly consecutive.
MPM_LANES_INLINE void loadVec3Lanes(const Vec3f* x, const uint32_t* ids, int lanes, Floats xa[3]) {
#ifdef MPM_LANE_SHUFFLES
  if (consecutive(ids, lanes)) {
    Floats v[3];
    loadVectors<3>(&x[ids[0]], v);
    deinterleave3(v, xa);
    return;
  }
#endif
  for (int l = 0; l < kLanes; ++l) {
    const Vec3f xl = x[ids[l < lanes ? l : 0]];
    for (int a = 0; a < 3; ++a) xa[a][l] = xl[a];
  }
}
/// x[ids[l]] = (xa[0][l], xa[1][l], xa[2][l]) for l < lanes.
MPM_LANES_INLINE void storeVec3Lanes(const Floats xa[3], const uint32_t* ids, int lanes, Vec3f* x) {
#ifdef MPM_LANE_SHUFFLES
  if (consecutive(ids, lanes)) {
    Floats v[3];
    interleave3(xa, v);
    storeVectors<3>(v, &x[ids[0]]);
    return;
  }
#endif
  for (int l = 0; l < lanes; ++l) x[ids[l]] = Vec3f{xa[0][l], xa[1][l], xa[2][l]};
}

/// f[3 r + c][l] = M[l].m[r][c] for kLanes consecutive matrices. Their 9 kLanes floats
/// are 3 kLanes rows of 3: deinterleaved once into the columns (rows of all matrices), each
/// column once more into its rows.
MPM_LANES_INLINE void loadMat3Run(const Mat3f* M, Floats f[9]) {
#ifdef MPM_LANE_SHUFFLES
  Floats v[9], col[3][3];  // col[c][k]: entry c of the rows kLanes k .. kLanes k + kLanes - 1
  loadVectors<9>(M, v);
  for (int k = 0; k < 3; ++k) {
    Floats t[3];
    deinterleave3(&v[3 * k], t);
    for (int c = 0; c < 3; ++c) col[c][k] = t[c];
  }
  for (int c = 0; c < 3; ++c) {
    Floats r[3];
    deinterleave3(col[c], r);
    for (int i = 0; i < 3; ++i) f[3 * i + c] = r[i];
  }
#else
  for (int l = 0; l < kLanes; ++l)
    for (int e = 0; e < 9; ++e) f[e][l] = M[l].m[e / 3][e % 3];
#endif
}

/// f[3 r + c][l] = M[ids[l]].m[r][c]; `fill` in the lanes from `lanes` on.
MPM_LANES_INLINE void loadMat3Lanes(const Mat3f* M, const uint32_t* ids, int lanes, const Mat3f& fill, Floats f[9]) {
  if (consecutive(ids, lanes)) {
    loadMat3Run(&M[ids[0]], f);
    return;
  }
  for (int l = 0; l < kLanes; ++l) {
    const Mat3f& Ml = l < lanes ? M[ids[l]] : fill;
    for (int e = 0; e < 9; ++e) f[e][l] = Ml.m[e / 3][e % 3];
  }
}

/// -1 in lanes 0 .. n - 1, 0 in the others.
MPM_LANES_INLINE Mask lanesBelow(int n) {
  static_assert(kLanes <= 16, "the index table below");
  static constexpr int kIndex[16] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
  Mask index;
  __builtin_memcpy(&index, kIndex, sizeof(index));
  return index < n;
}
/// Bit l set where lane l of m is (nonzero).
/// The lanes are read from an array: reading them from the vector in this loop, GCC 12 with
/// -fsanitize=undefined at -O2 returned every bit set for {-1, 0, 0, 0} (reproduced in a
/// ten-line program; the CI's sanitized build).
MPM_LANES_INLINE uint32_t laneBits(const Mask& m) {
  int lane[kLanes];
  __builtin_memcpy(lane, &m, sizeof(lane));
  uint32_t bits = 0;
  for (int l = 0; l < kLanes; ++l) bits |= (lane[l] != 0 ? 1u : 0u) << l;
  return bits;
}

/// M[l].m[r][c] = f[3 r + c][l] for kLanes consecutive matrices (loadMat3Run backwards).
MPM_LANES_INLINE void storeMat3Run(const Floats f[9], Mat3f* M) {
#ifdef MPM_LANE_SHUFFLES
  Floats col[3][3], v[9];
  for (int c = 0; c < 3; ++c) {
    const Floats r[3] = {f[c], f[3 + c], f[6 + c]};
    interleave3(r, col[c]);
  }
  for (int k = 0; k < 3; ++k) {
    const Floats t[3] = {col[0][k], col[1][k], col[2][k]};
    interleave3(t, &v[3 * k]);
  }
  storeVectors<9>(v, M);
#else
  for (int l = 0; l < kLanes; ++l)
    for (int e = 0; e < 9; ++e) M[l].m[e / 3][e % 3] = f[e][l];
#endif
}

/// M[l].m[r][c] = f[3 r + c][l] for l < lanes: a caller's own run of matrices (the batched
/// stresses' results), by shuffles when the lanes fill it.
MPM_LANES_INLINE void storeMat3Prefix(const Floats f[9], int lanes, Mat3f* M) {
  if (lanes == kLanes) {
    storeMat3Run(f, M);
    return;
  }
  for (int l = 0; l < lanes; ++l)
    for (int e = 0; e < 9; ++e) M[l].m[e / 3][e % 3] = f[e][l];
}

/// M[ids[l]].m[r][c] = f[3 r + c][l] for l < lanes (loadMat3Lanes backwards).
MPM_LANES_INLINE void storeMat3Lanes(const Floats f[9], const uint32_t* ids, int lanes, Mat3f* M) {
  if (consecutive(ids, lanes)) {
    storeMat3Run(f, &M[ids[0]]);
    return;
  }
  for (int l = 0; l < lanes; ++l)
    for (int e = 0; e < 9; ++e) M[ids[l]].m[e / 3][e % 3] = f[e][l];
}

}  // namespace simd
#endif
}  // namespace mpm
