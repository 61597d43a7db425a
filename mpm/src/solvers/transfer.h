#pragma once
// What every particle-grid solver shares: the quadratic B-spline stencil (weights and
// their gradients), the APIC scatter and gather (seed 000 eqs. 10-11), the node accessor
// through the block table, and the per-particle end-of-substep checks. The solvers in
// this folder are compositions of these pieces; none of them repeats one.
#include <type_traits>

#include "mpm/settings.h"
#include "core/particle_state.h"
#include "core/substep.h"
#include "grid/block_grid.h"
#include "shapes/shape_kernels.h"

namespace mpm {

/// A particle's 3x3x3 quadratic B-spline stencil: lowest node, offset from it (in cells)
/// and the weights along each axis.
struct QuadraticStencil {
  int base[3];
  Vec3f fx;
  float w[3][3];
  MPM_HD QuadraticStencil(const GridGeometry& geo, Vec3f x) {
    geo.stencilBase(x, base, fx);
    for (int a = 0; a < 3; ++a) quadraticWeights(fx[a], w[a]);
  }
  /// Filled by the CPU for many particles at once (backend/cpu/stencil_batch.h).
  QuadraticStencil() = default;
  /// The whole stencil lies on grid nodes (GridGeometry::stencilInside of the same x).
  MPM_HD bool inside(const GridGeometry& geo) const { return geo.baseInside(base); }
  /// d w / d x along axis a for the three nodes [1/m] (standard MPM's force and L).
  MPM_HD void gradients(float invDx, float dw[3][3]) const {
    for (int a = 0; a < 3; ++a) {
      dw[a][0] = -(1.5f - fx[a]) * invDx;
      dw[a][1] = -2.f * (fx[a] - 1.f) * invDx;
      dw[a][2] = (fx[a] - 0.5f) * invDx;
    }
  }
};

/// 1 / M_p of the quadratic B-spline APIC/MLS transfers, 4 / dx^2 [1/m^2].
MPM_HD float apicInverseInertia(const GridGeometry& geo) { return 4.f * geo.invDx * geo.invDx; }

// The transfers below are separable: the 27 node terms of a stencil are products of
// per-axis weights, so sums over the stencil are taken axis by axis (k innermost) and
// node values move as Float4 {mass, x, y, z}, one short vector per node.

/// Which node fields a P2G kernel adds to, from its optional flags (all, if it has none):
/// kCentroidSums (w m x_p and w m touch), kStressImpulse (dt f). A backend that sums the
/// particles of a grid block in a tile first (the CPU's BlockTile, the GPU's shared-memory
/// tile) keeps only these.
template <class F, class = void>
struct UsesCentroid : std::true_type {};
template <class F>
struct UsesCentroid<F, std::void_t<decltype(F::kCentroidSums)>> : std::bool_constant<F::kCentroidSums> {};
template <class F, class = void>
struct UsesImpulse : std::true_type {};
template <class F>
struct UsesImpulse<F, std::void_t<decltype(F::kStressImpulse)>> : std::bool_constant<F::kStressImpulse> {};
/// Whether a G2P kernel reads the velocity before the force (oldVelocity4), from its
/// optional flag kOldVelocity (standard MPM's FLIP); yes if it has none.
template <class F, class = void>
struct UsesOldVelocity : std::true_type {};
template <class F>
struct UsesOldVelocity<F, std::void_t<decltype(F::kOldVelocity)>> : std::bool_constant<F::kOldVelocity> {};

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

/// The end of every solver's G2P: push the particle out of the shapes it ended inside,
/// then check it (state finite, stencil on the grid) and report its speed. `near`: the
/// parts near the particle's block, from the node accessor (Nodes::nearParts; the CPU's
/// block tile has them, the GPU tries every part).
/// What finishParticle checks is finite, in any float type T (the CPU's lanes take it too,
/// backend/cpu/update_batch.h): x, v and tr F in one sum, so one NaN or inf in any shows.
template <class T>
MPM_HD T stateSum(const T x[3], const T v[3], const T F[9]) {
  return x[0] + x[1] + x[2] + v[0] + v[1] + v[2] + (F[0] + F[4] + F[8]);
}

/// Whether volume ratio J = det F is where material can be (kMinVolumeRatio, kMaxVolumeRatio,
/// mpm/settings.h), in any float type T: false for NaN too. The determinant by the rule
/// of Sarrus on the rows, so the CPU's lanes compute what this does.
template <class T>
MPM_HD auto volumeRatioSound(const T F[9]) {
  const T J = F[0] * (F[4] * F[8] - F[5] * F[7]) - F[1] * (F[3] * F[8] - F[5] * F[6]) +
              F[2] * (F[3] * F[7] - F[4] * F[6]);
  return (J > kMinVolumeRatio) & (J < kMaxVolumeRatio);
}

MPM_HD StepCheck finishParticle(uint32_t p, const ParticleView& P, const GridGeometry& geo, const PartView* parts,
                                int nParts, const NearParts& near) {
  StepCheck c;
  const Vec3f x = P.x[p], v = P.v[p];
  const float* F = &P.F[p].m[0][0];
  const float sum = stateSum(&x.x, &v.x, F);
  if (!isFinite(sum) || !geo.stencilInside(x) || !volumeRatioSound(F)) c.firstBadParticle = p;
  P.touch[p] = nParts && pushOutOfParts(P.x[p], parts, nParts, P.volume0[p], near) ? 1.f : 0.f;
  c.maxSpeed2 = dot(v, v);
  return c;
}

/// A particle whose stencil already left the grid keeps its state (G2P would read nodes
/// that do not exist) and is reported.
MPM_HD StepCheck strayParticle(uint32_t p, const ParticleView& P) {
  StepCheck c;
  c.firstBadParticle = p;
  c.maxSpeed2 = dot(P.v[p], P.v[p]);
  return c;
}

/// P2G through the kernel template K<kCentroid>, then the grid update `update` (a node
/// kernel; ParticleGridSystem::scatterAndUpdate): with the material centroid w m x_p only
/// when a shape can reach the material this substep (contact needs it; a scene without
/// shapes, or with shapes far away, does not pay) and `centroids` asks for it (false: the
/// grid keeps the centroids of this substep's first P2G).
template <template <bool> class K, class System, class Update, class... Args>
void scatterParticles(System& s, bool centroids, const Update& update, const Args&... args) {
  if (centroids && s.hasShapes())
    s.scatterAndUpdate(K<true>{args...}, update);
  else
    s.scatterAndUpdate(K<false>{args...}, update, !centroids);
}

/// A G2P kernel given the parts that can reach the material this substep (fields `parts`,
/// `nParts`; none when placeShapes found every shape out of reach) and whether any
/// particle may be cut (`cuts`).
template <class System, class G2PKernel>
G2PKernel withParts(const System& s, G2PKernel k) {
  k.parts = s.parts();
  k.nParts = s.partCount();
  k.cuts = s.cuts();
  return k;
}

/// The substep of an explicit solver (MLS-MPM, standard MPM): bin, place the shapes,
/// P2G, grid update, rigid contact and bodies, G2P. P2G<kCentroid> is built from
/// `p2gArgs`; the grid kernel (fields grid, dt, gravity, walls) only after binning, which
/// sets the grid; `g2p` gets its parts here.
template <template <bool> class P2G, class GridKernel, class System, class G2PKernel, class... P2GArgs>
void explicitSubstep(System& s, const SubstepParams& p, const G2PKernel& g2p, const P2GArgs&... p2gArgs) {
  s.binParticles();
  s.placeShapes();
  s.recordCuts(p.dt);
  scatterParticles<P2G>(s, true, GridKernel{s.grid(), p.dt, p.gravity, p.walls}, p2gArgs...);
  s.exchangeContact(p.dt, true);
  s.moveShapes(p.dt);
  s.gather(withParts(s, g2p));
}

/// Stencil nodes reached through the block table, accumulated with `Add` (GPU atomics).
template <class Add>
struct GridNodes {
  GridView grid;
  /// Adds {mass, momentum}.
  MPM_HD void add(int i, int j, int k, const Float4& q) const {
    GridNode& n = grid.node(i, j, k);
    Add::add(n.mass, q[0]);
    Add::add(n.mv.x, q[1]);
    Add::add(n.mv.y, q[2]);
    Add::add(n.mv.z, q[3]);
  }
  /// Adds w m touch_p (lane 0) and w m x_p (lanes 1-3).
  MPM_HD void addCentroid(int i, int j, int k, const Float4& mx) const {
    GridNode& n = grid.node(i, j, k);
    if (mx[0] != 0.f) Add::add(n.touch, mx[0]);
    Add::add(n.mx.x, mx[1]);
    Add::add(n.mx.y, mx[2]);
    Add::add(n.mx.z, mx[3]);
  }
  /// Adds the stress impulse dt f (lanes 1-3).
  MPM_HD void addStressImpulse(int i, int j, int k, const Float4& dmv) const {
    GridNode& n = grid.node(i, j, k);
    Add::add(n.dmv.x, dmv[1]);
    Add::add(n.dmv.y, dmv[2]);
    Add::add(n.dmv.z, dmv[3]);
  }
  /// {mass, velocity} after the grid update.
  MPM_HD Float4 velocity4(int i, int j, int k) const {
    const GridNode& n = grid.node(i, j, k);
    return Float4::make(n.mass, n.mv.x, n.mv.y, n.mv.z);
  }
  /// {0, velocity before the force} (standard MPM).
  MPM_HD Float4 oldVelocity4(int i, int j, int k) const {
    const GridNode& n = grid.node(i, j, k);
    return Float4::make(0.f, n.dmv.x, n.dmv.y, n.dmv.z);
  }
  /// No list of the parts near a particle: G2P tries every part (finishParticle).
  MPM_HD NearParts nearParts() const { return NearParts{}; }
};

}  // namespace mpm
