#pragma once
// The APIC scatter and gather (Jiang et al. 2015, the affine particle-in-cell method; as in
// Hu et al. 2018's MLS-MPM), shared by every particle-grid solver and by both backends.
#include "transfer/stencil.h"

namespace mpm {

// The transfers below are separable: the 27 node terms of a stencil are products of
// per-axis weights, so sums over the stencil are taken axis by axis (k innermost) and
// node values move as Float4 {mass, x, y, z}, one short vector per node.

/// One particle's APIC scatter before its weights: the node at offset (i, j, k) from its
/// stencil base takes w_ijk (q0 + i qx + j qy + k qz) as {mass, momentum}, and with
/// kCentroid w_ijk mx4 as {w m touch_p, w m x_p}.
struct ApicTerms {
  Float4 q0, qx, qy, qz, mx4;
};

/// Whether `Nodes` takes a particle's ApicTerms whole (deferApic) instead of its 27 node
/// values: the CPU's P2G tile, which sums the particles of each stencil cell before adding
/// them to the tile (backend/cpu/scatter_cells.h).
template <class Nodes, class = void>
struct DefersApic : std::false_type {};
template <class Nodes>
struct DefersApic<Nodes, std::void_t<decltype(Nodes::kDefersApic)>> : std::bool_constant<Nodes::kDefersApic> {};

/// Adds one particle's APIC terms to the 27 nodes of its stencil. Factored by x and z first
/// (q_ik = q0 + i qx + k qz, w_ik = w_0i w_2k), then y: the CPU's cell sums hold a stencil
/// row along z in one vector and take each particle's rows in this arithmetic, lane by lane
/// (backend/cpu/scatter_cells.h).
template <bool kCentroid, class Nodes>
MPM_HD void apicScatterTerms(const QuadraticStencil& st, const ApicTerms& t, Nodes& nodes) {
  const int* base = st.base;
  const float(&w)[3][3] = st.w;
  for (int i = 0; i < 3; ++i) {
    const Float4 qi = t.q0 + (float)i * t.qx;
    Float4 qik[3];
    float wik[3];
    for (int k = 0; k < 3; ++k) {
      qik[k] = qi + (float)k * t.qz;
      wik[k] = w[0][i] * w[2][k];
    }
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) {
        const float wt = w[1][j] * wik[k];
        nodes.add(base[0] + i, base[1] + j, base[2] + k, wt * (qik[k] + (float)j * t.qy));
        if constexpr (kCentroid) nodes.addCentroid(base[0] + i, base[1] + j, base[2] + k, wt * t.mx4);
      }
  }
}

/// APIC scatter of one particle: node momentum w (mv + A (x_i - x_p)) and mass w m.
/// `affine` is A: m C for APIC and PB-MPM, m C - dt V0 M^-1 tau for MLS-MPM. `Nodes` is
/// where the nodes live (the global grid with the backend's accumulate, or a CPU block
/// tile). kCentroid: also accumulate w m x_p and w m touch (only shape contact needs them).
template <bool kCentroid, class Nodes>
MPM_HD void apicScatter(const QuadraticStencil& st, float dx, float m, Vec3f mv, const Mat3f& affine, Vec3f xp,
                        float touch, Nodes& nodes) {
  // {mass, momentum} at node offset d: {m, mv + A d}, built incrementally along each axis
  const Vec3f d0{-st.fx.x * dx, -st.fx.y * dx, -st.fx.z * dx};
  const Vec3f a0 = mv + affine * d0;
  const Vec3f ax = dx * affine.column(0), ay = dx * affine.column(1), az = dx * affine.column(2);
  ApicTerms t;
  t.q0 = Float4::make(m, a0.x, a0.y, a0.z);
  t.qx = Float4::make(0.f, ax.x, ax.y, ax.z);
  t.qy = Float4::make(0.f, ay.x, ay.y, ay.z);
  t.qz = Float4::make(0.f, az.x, az.y, az.z);
  t.mx4 = m * Float4::make(touch, xp.x, xp.y, xp.z);
  if constexpr (DefersApic<Nodes>::value)
    nodes.template deferApic<kCentroid>(st, t);
  else
    apicScatterTerms<kCentroid>(st, t, nodes);
}

/// The sums of an APIC gather over a stencil: sum w v_i (lanes 1-3 of v; lane 0 the nodes'
/// mass, unused) and B's columns before their offsets, bi = sum w v_i i, bj, bk likewise
/// (apicFromSums). The CPU computes them for many particles at once
/// (backend/cpu/gather_batch.h, the same arithmetic lane by lane).
struct ApicSums {
  Float4 v, bi, bj, bk;
};

/// apicGather's sums. B = sum w v (x_i - x_p)^T is accumulated as sum (w v) i^T dx minus
/// (sum w v) fx^T dx, separably (k innermost).
template <class Nodes>
MPM_HD ApicSums apicSums(const QuadraticStencil& st, const Nodes& nodes) {
  const int* base = st.base;
  const float(&w)[3][3] = st.w;
  Float4 sv = Float4::zero(), bi = Float4::zero(), bj = Float4::zero(), bk = Float4::zero();
  for (int i = 0; i < 3; ++i) {
    Float4 si = Float4::zero(), sj = Float4::zero(), sk = Float4::zero();
    for (int j = 0; j < 3; ++j) {
      const Float4 n0 = nodes.velocity4(base[0] + i, base[1] + j, base[2]);
      const Float4 n1 = nodes.velocity4(base[0] + i, base[1] + j, base[2] + 1);
      const Float4 n2 = nodes.velocity4(base[0] + i, base[1] + j, base[2] + 2);
      const Float4 s = w[2][0] * n0 + w[2][1] * n1 + w[2][2] * n2;
      const Float4 t = w[2][1] * n1 + (2.f * w[2][2]) * n2;
      si += w[1][j] * s;
      sj += ((float)j * w[1][j]) * s;
      sk += w[1][j] * t;
    }
    sv += w[0][i] * si;
    bi += ((float)i * w[0][i]) * si;
    bj += w[0][i] * sj;
    bk += w[0][i] * sk;
  }
  return ApicSums{sv, bi, bj, bk};
}

/// apicFromSums in any float type T: float for one particle, the CPU's simd::Floats for a
/// run of particles in lanes (backend/cpu/update_batch.h), one source for both. v = sum w v_i
/// and C = M^-1 dx (b_c - fx_c v) column by column, with b[c][r] the sums bi, bj, bk (c =
/// 0, 1, 2) at row r, C row-major.
template <class T>
MPM_HD void apicAffineFromSums(const T sv[3], const T b[3][3], const T fx[3], float dx, float inertiaInv, T v[3],
                               T C[9]) {
  for (int r = 0; r < 3; ++r) v[r] = sv[r];
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) C[3 * r + c] = inertiaInv * (dx * (b[c][r] - fx[c] * v[r]));
}

/// v = sum w v_i and C = M^-1 sum w v_i (x_i - x_p)^T from the sums.
MPM_HD void apicFromSums(const QuadraticStencil& st, const GridGeometry& geo, const ApicSums& sums, Vec3f& v,
                         Mat3f& C) {
  const float sv[3] = {sums.v[1], sums.v[2], sums.v[3]};
  const float b[3][3] = {{sums.bi[1], sums.bi[2], sums.bi[3]},
                         {sums.bj[1], sums.bj[2], sums.bj[3]},
                         {sums.bk[1], sums.bk[2], sums.bk[3]}};
  const float fx[3] = {st.fx.x, st.fx.y, st.fx.z};
  float vv[3];
  apicAffineFromSums(sv, b, fx, geo.dx, apicInverseInertia(geo), vv, &C.m[0][0]);
  v = Vec3f{vv[0], vv[1], vv[2]};
}

/// F <- (I + dt C) F, the update of the deformation gradient over a substep, in any float
/// type T (as apicAffineFromSums); C and F row-major.
template <class T>
MPM_HD void advanceDeformation(const T C[9], float dt, T F[9]) {
  T a[9], out[9];
  for (int e = 0; e < 9; ++e) a[e] = (e % 4 == 0 ? 1.f : 0.f) + dt * C[e];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out[3 * r + c] = a[3 * r] * F[c] + a[3 * r + 1] * F[3 + c] + a[3 * r + 2] * F[6 + c];
  for (int e = 0; e < 9; ++e) F[e] = out[e];
}
MPM_HD void advanceDeformation(const Mat3f& C, float dt, Mat3f& F) { advanceDeformation(&C.m[0][0], dt, &F.m[0][0]); }

/// APIC gather from the updated grid: v = sum w v_i and C = M^-1 sum w v_i (x_i - x_p)^T.
template <class Nodes>
MPM_HD void apicGather(const QuadraticStencil& st, const GridGeometry& geo, const Nodes& nodes, Vec3f& v,
                       Mat3f& C) {
  apicFromSums(st, geo, apicSums(st, nodes), v, C);
}

}  // namespace mpm
