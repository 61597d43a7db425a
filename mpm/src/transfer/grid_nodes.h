#pragma once
// How a transfer reaches the grid nodes: the flags a kernel declares for the node fields it
// uses, and the node accessor through the block table.
#include <type_traits>

#include "grid/block_grid.h"
#include "contact/push_out.h"

namespace mpm {

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
