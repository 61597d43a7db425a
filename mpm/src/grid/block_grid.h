#pragma once
// Block-sparse grid. The domain's nodes are grouped in blocks of 4x4x4; a dense table of
// one int per block (1/64 of the node count) maps a block to its slot in the pool of
// active blocks, or -1. Only blocks within reach of a particle are active, so node
// memory and per-substep work follow the particles, not the domain.
#include <cstdint>

#include "mpm/math.h"

namespace mpm {

constexpr int kBlockBits = 2;
constexpr int kBlockSize = 1 << kBlockBits;  // nodes per block edge
constexpr int kBlockNodes = kBlockSize * kBlockSize * kBlockSize;
constexpr int kBlockMask = kBlockSize - 1;

/// How a mirror plane (DomainSettings::mirrorLower) reflects a node field (MirrorFold,
/// MirrorUnfold in grid_update.h): an Amount adds as it is (mass), a Vector's normal
/// component flips (momentum, velocity), a Moment sum w m x reflects its point (x -> 2
/// plane - x).
namespace node_image {
struct Amount {};
struct Vector {};
struct Moment {};
}  // namespace node_image

/// The grid node's fields, once: X(type, name, image). All are rebuilt every substep (P2G
/// writes them from the particles), so none is state a checkpoint keeps.
///   mass   sum w m [kg]
///   mv     momentum [kg m/s]; velocity [m/s] after the grid update
///   mx     sum w m x_p: where the node's material is (m x-bar). Accumulated only when the
///          scene has shapes; contact uses it to tell which side of a thin shape the
///          material is on
///   dmv    standard MPM only: the momentum the stress adds over the substep, dt f_int;
///          the node's velocity before the update (for the FLIP increment) after it
///   touch  sum w m over the particles touching a shape (ParticleView::touch): how much of
///          the node's material rests on a shape (materialTouches)
/// The transfers move them in Float4 lanes ({mass, mv}, {touch, mx}, {0, dmv}: BlockTile,
/// GridNodes), a SIMD layout written out by hand there.
#define MPM_GRID_NODE_FIELDS(X) \
  X(float, mass, node_image::Amount) \
  X(Vec3f, mv, node_image::Vector)   \
  X(Vec3f, mx, node_image::Moment)   \
  X(Vec3f, dmv, node_image::Vector)  \
  X(float, touch, node_image::Amount)

struct GridNode {
#define MPM_NODE_MEMBER(type, name, image) type name;
  MPM_GRID_NODE_FIELDS(MPM_NODE_MEMBER)
#undef MPM_NODE_MEMBER
};

/// Zeroes a node's fields (MPM_GRID_NODE_FIELDS); with keepCentroids all but the material
/// centroids (touch, mx), which PB-MPM's later cycles of a substep keep from its first.
MPM_HD void clearNode(GridNode& g, bool keepCentroids) {
  if (!keepCentroids) {
    g = GridNode{};
    return;
  }
  g.mass = 0.f;
  g.mv = g.dmv = Vec3f{0.f, 0.f, 0.f};
}

/// A node with less mass than this holds no material: it takes no velocity and no contact.
/// Only a stencil's far corner, with a weight near 1e-39 (a particle within an ulp of a
/// node layer), puts so little on a node; 1 / mass would overflow to inf there and turn
/// a zero momentum into NaN. [kg]
constexpr float kEmptyNodeMass = 1e-30f;
MPM_HD bool holdsMaterial(const GridNode& n) { return n.mass > kEmptyNodeMass; }

/// Geometry of the grid, shared by every kernel.
struct GridGeometry {
  Vec3f lower;        ///< world position of node (0,0,0) [m]
  float dx = 0;       ///< cell size [m]
  float invDx = 0;
  int cells[3] = {0, 0, 0};   ///< cells per axis; nodes are 0..cells
  int blocks[3] = {0, 0, 0};  ///< blocks per axis

  MPM_HD uint32_t blockIndex(int bx, int by, int bz) const {
    return (uint32_t)((bx * blocks[1] + by) * blocks[2] + bz);
  }
  MPM_HD void blockCoords(uint32_t b, int& bx, int& by, int& bz) const {
    bz = (int)(b % (uint32_t)blocks[2]);
    by = (int)((b / (uint32_t)blocks[2]) % (uint32_t)blocks[1]);
    bx = (int)(b / ((uint32_t)blocks[2] * (uint32_t)blocks[1]));
  }
  /// Lowest node of the particle's 3x3x3 quadratic B-spline stencil.
  MPM_HD void stencilBase(Vec3f x, int base[3], Vec3f& fx) const {
    for (int a = 0; a < 3; ++a) {
      // One explicit fused multiply-add, rounded once: written as (x - lower) * invDx - 0.5
      // the compiler may or may not contract it, differently where it inlines this, and a
      // particle within an ulp of a half-cell then gets one base in binning and another in
      // P2G (its tile index out of range: seen as memory corruption with particles at cell
      // centres). fmaf gives the same base on every path, host and device.
      // Clamped to a few cells around the grid before the int conversion: a diverging
      // particle (x = 1e24, or NaN: it takes the lower bound) would not fit an int, which
      // is undefined behaviour (found by fuzz_checkpoint); its base is outside either way.
      // Compares, not fmaxf / fminf: GCC calls libm for those (their NaN rule is not x86's
      // maxss), 8 % of an MLS-MPM substep at 125k particles; these give the same values.
      float t = fmaf(x[a] - lower[a], invDx, -0.5f);
      t = t > -4.f ? t : -4.f;
      t = t < (float)cells[a] + 4.f ? t : (float)cells[a] + 4.f;
      base[a] = (int)floorf(t);
      fx[a] = (t - (float)base[a]) + 0.5f;
    }
  }
  /// Block that owns a particle for binning: the block holding its stencil base.
  MPM_HD uint32_t particleBlock(Vec3f x) const {
    int base[3];
    Vec3f fx;
    stencilBase(x, base, fx);
    return blockIndex(base[0] >> kBlockBits, base[1] >> kBlockBits, base[2] >> kBlockBits);
  }
  /// The GPU's sort key of a particle (backend/cuda): the block of particleBlock, then the
  /// stencil base's cell within the block, kBlockBits per axis, so that sorting by it puts a
  /// block's particles together and, within them, each cell's (the lanes of a warp that add
  /// to the same nodes). keyBlock gives the block back. Holds 2^26 blocks.
  static constexpr int kCellKeyBits = 3 * kBlockBits;
  MPM_HD uint32_t particleKey(Vec3f x) const {
    int base[3];
    Vec3f fx;
    stencilBase(x, base, fx);
    const uint32_t block = blockIndex(base[0] >> kBlockBits, base[1] >> kBlockBits, base[2] >> kBlockBits);
    const uint32_t cell = (uint32_t)((((base[0] & kBlockMask) << kBlockBits) | (base[1] & kBlockMask)) << kBlockBits |
                                     (base[2] & kBlockMask));
    return block << kCellKeyBits | cell;
  }
  MPM_HD static uint32_t keyBlock(uint32_t key) { return key >> kCellKeyBits; }
  /// True if a stencil with this lowest node lies on grid nodes.
  MPM_HD bool baseInside(const int base[3]) const {
    for (int a = 0; a < 3; ++a)
      if (!(base[a] >= 0 && base[a] + 2 <= cells[a])) return false;
    return true;
  }
  /// True if the particle's whole stencil lies on grid nodes: baseInside(stencilBase(x))
  /// without the rounding to a node, as t >= 0 <=> floor(t) >= 0 and t < cells - 1 <=>
  /// floor(t) + 2 <= cells (a clamped or NaN t fails either way). Every G2P checks it.
  MPM_HD bool stencilInside(Vec3f x) const {
    for (int a = 0; a < 3; ++a) {
      const float t = fmaf(x[a] - lower[a], invDx, -0.5f);  // stencilBase's t, before its clamp
      if (!(t >= 0.f && t < (float)(cells[a] - 1))) return false;
    }
    return true;
  }
};

/// Whether a node's material touches a shape: at least 30 % of its mass lies on particles
/// within their touch distance of one (ParticleView::touch). Such a node is in contact
/// beyond a shape's surface (contact/contact_law.h, contactNodePart: kRestingReach,
/// kGluedReach). Only material that touches: a reach for every node would stop material
/// approaching a surface early (a pressing sphere's Hertz force +45 % at R = 4 dx with any
/// touching particle; with the 30 % share its L2 error falls from 29.7 % to 20.4 %).
MPM_HD bool materialTouches(const GridNode& n) { return n.touch >= 0.3f * n.mass; }

/// Whether a node takes part in contact with shapes: it holds material, and it is not a
/// node beyond its material's surface (the centroid of its material, x-bar, more than a
/// cell away: past the next node layer, in the tail of the node's stencil) unless that
/// material touches a shape.
///
/// Why: such a node carries almost no mass but its share of the outer particles' stress
/// (standard MPM: a force per unit mass sigma / rho times dw / w, 10 / dx for a particle
/// 1.3 dx away), and a shape holding it takes that share as a contact force though the
/// material does not touch it. On a 30 kPa block the node layer above the top (nodes of
/// 0.8 % of a full node's mass) carried all of a 0.2 g capsule's weight, 1.96 mN, and
/// standard MPM held it 0.9-1.3 dx above the block (MLS-MPM's layer: 1.3 mN). Material
/// resting on a shape keeps such nodes: under a slab on a floor 1/8 dx above a node layer,
/// the layer inside the floor below it holds the slab's bottom particles (without it they
/// were pushed into the floor: 1.22 times the uniaxial shortening, 1.08 with it).
MPM_HD bool takesContact(const GridNode& n, Vec3f x, const GridGeometry& geo) {
  if (!holdsMaterial(n)) return false;
  const Vec3f fromMaterial = x - (1.f / n.mass) * n.mx;
  return dot(fromMaterial, fromMaterial) <= geo.dx * geo.dx || materialTouches(n);
}

/// Four floats moved together: a node's mass and momentum (or velocity) as the transfers
/// read and write them, {mass, x, y, z}. On the CPU a tile keeps its nodes this way, 16
/// bytes each, and host compilers that have vector extensions (GCC, Clang) do the
/// arithmetic below as one SIMD instruction; device code gets four plain floats. The
/// kernels are written once against these operations.
#if defined(__GNUC__) && !defined(__CUDACC__)
#define MPM_FLOAT4_VECTOR 1
#endif
struct alignas(16) Float4 {
#ifdef MPM_FLOAT4_VECTOR
  typedef float V __attribute__((vector_size(16)));
  V v;
  static Float4 make(float a, float b, float c, float d) {
    Float4 r;
    r.v = V{a, b, c, d};
    return r;
  }
#else
  float v[4];
  MPM_HD static Float4 make(float a, float b, float c, float d) {
    Float4 r;
    r.v[0] = a; r.v[1] = b; r.v[2] = c; r.v[3] = d;
    return r;
  }
#endif
  MPM_HD static Float4 zero() { return make(0.f, 0.f, 0.f, 0.f); }
  MPM_HD float operator[](int i) const { return v[i]; }
  /// Lanes 1-3 as a vector.
  MPM_HD Vec3f xyz() const { return Vec3f{v[1], v[2], v[3]}; }
};
#ifdef MPM_FLOAT4_VECTOR
inline Float4 operator+(Float4 a, Float4 b) { Float4 r; r.v = a.v + b.v; return r; }
inline Float4 operator-(Float4 a, Float4 b) { Float4 r; r.v = a.v - b.v; return r; }
inline Float4 operator*(float s, Float4 a) { Float4 r; r.v = s * a.v; return r; }
inline Float4& operator+=(Float4& a, Float4 b) { a.v += b.v; return a; }
#else
MPM_HD Float4 operator+(Float4 a, Float4 b) {
  return Float4::make(a.v[0] + b.v[0], a.v[1] + b.v[1], a.v[2] + b.v[2], a.v[3] + b.v[3]);
}
MPM_HD Float4 operator-(Float4 a, Float4 b) {
  return Float4::make(a.v[0] - b.v[0], a.v[1] - b.v[1], a.v[2] - b.v[2], a.v[3] - b.v[3]);
}
MPM_HD Float4 operator*(float s, Float4 a) {
  return Float4::make(s * a.v[0], s * a.v[1], s * a.v[2], s * a.v[3]);
}
MPM_HD Float4& operator+=(Float4& a, Float4 b) { a = a + b; return a; }
#endif

/// Non-owning view of the active grid, passed to kernels by value.
struct GridView {
  GridGeometry geo;
  const int32_t* blockSlot = nullptr;  ///< dense table: block -> active slot, or -1
  const uint32_t* activeBlocks = nullptr;  ///< slot -> block index
  GridNode* nodes = nullptr;               ///< kBlockNodes per active slot
  uint32_t activeCount = 0;

  /// Global coordinates of node `n` (an index into the active pool).
  MPM_HD void nodeCoords(uint32_t n, int idx[3]) const {
    int bx, by, bz;
    geo.blockCoords(activeBlocks[n / kBlockNodes], bx, by, bz);
    const int local = (int)(n % kBlockNodes);
    idx[0] = (bx << kBlockBits) + (local >> (2 * kBlockBits));
    idx[1] = (by << kBlockBits) + ((local >> kBlockBits) & kBlockMask);
    idx[2] = (bz << kBlockBits) + (local & kBlockMask);
  }
  /// Node (i, j, k) if it lies on the grid in an active block, else null.
  MPM_HD GridNode* find(int i, int j, int k) const {
    if (i < 0 || j < 0 || k < 0 || i > geo.cells[0] || j > geo.cells[1] || k > geo.cells[2]) return nullptr;
    const int32_t slot =
        blockSlot[geo.blockIndex(i >> kBlockBits, j >> kBlockBits, k >> kBlockBits)];
    return slot < 0 ? nullptr : &node(i, j, k);
  }
  /// Node of global coordinates (i, j, k); its block must be active.
  MPM_HD GridNode& node(int i, int j, int k) const {
    const int32_t slot =
        blockSlot[geo.blockIndex(i >> kBlockBits, j >> kBlockBits, k >> kBlockBits)];
    const int local = ((i & kBlockMask) << (2 * kBlockBits)) | ((j & kBlockMask) << kBlockBits) |
                      (k & kBlockMask);
    return nodes[(size_t)slot * kBlockNodes + local];
  }
};

/// Quadratic B-spline weights for the three stencil nodes along one axis, given the
/// particle's offset fx in [0.5, 1.5) from the stencil base.
/// (T: float, or a vector of floats on the CPU, backend/cpu/stencil_batch.h.)
template <class T>
MPM_HD void quadraticWeights(T fx, T w[3]) {
  const T a = 1.5f - fx, b = fx - 1.f, c = fx - 0.5f;
  w[0] = 0.5f * a * a;
  w[1] = 0.75f - b * b;
  w[2] = 0.5f * c * c;
}

}  // namespace mpm
