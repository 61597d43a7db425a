#pragma once
// Grid update: momentum to velocity, gravity, and the domain walls.
#include "grid/block_grid.h"

namespace mpm {

/// Domain wall behaviour as the kernel sees it.
struct WallParams {
  int enabled = 1;
  int mode = 2;       ///< static_cast<int>(WallMode): 0 sticky, 1 slip, 2 separate
  int thickness = 2;  ///< nodes from each face the wall acts on
};

/// Updates node `n` (index into the active pool): v = mv / m + dt g, then walls.
MPM_HD void gridUpdateNode(uint32_t n, const GridView& grid, float dt, Vec3f gravity,
                           const WallParams& walls) {
  GridNode& node = grid.nodes[n];
  if (!holdsMaterial(node)) {
    node.mv = Vec3f{0.f, 0.f, 0.f};
    return;
  }
  Vec3f v = (1.f / node.mass) * node.mv + dt * gravity;
  if (walls.enabled) {
    int bx, by, bz;
    grid.geo.blockCoords(grid.activeBlocks[n / kBlockNodes], bx, by, bz);
    const int local = (int)(n % kBlockNodes);
    const int idx[3] = {(bx << kBlockBits) + (local >> (2 * kBlockBits)),
                        (by << kBlockBits) + ((local >> kBlockBits) & kBlockMask),
                        (bz << kBlockBits) + (local & kBlockMask)};
    for (int a = 0; a < 3; ++a) {
      const bool atLower = idx[a] < walls.thickness;
      const bool atUpper = idx[a] > grid.geo.cells[a] - walls.thickness;
      if (!atLower && !atUpper) continue;
      if (walls.mode == 0) {
        v = Vec3f{0.f, 0.f, 0.f};
      } else if (walls.mode == 1 || (atLower && v[a] < 0.f) || (atUpper && v[a] > 0.f)) {
        v[a] = 0.f;  // slip removes all normal velocity; separate only the inward part
      }
    }
  }
  node.mv = v;
}

/// The grid update of a whole substep as a per-node kernel.
struct GridUpdate {
  GridView grid;
  float dt;
  Vec3f gravity;
  WallParams walls;
  MPM_HD void operator()(size_t n) const { gridUpdateNode((uint32_t)n, grid, dt, gravity, walls); }
};

}  // namespace mpm
