#pragma once
// Grid update: momentum to velocity, gravity, and the domain walls.
#include "grid/block_grid.h"

namespace mpm {

/// Domain wall behaviour as the kernel sees it.
struct WallParams {
  int enabled = 1;
  int mode = 2;       ///< static_cast<int>(WallMode): 0 sticky, 1 slip, 2 separate
  int thickness = 2;  ///< nodes from each face the wall acts on
  /// Bit a set: the lower face of axis a is a mirror (symmetry) plane, the node layer
  /// `thickness` (DomainSettings::mirrorLower); the nodes below it are ghosts.
  int mirror = 0;

  MPM_HD bool mirrored(int axis) const { return (mirror >> axis) & 1; }
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
  if (walls.enabled || walls.mirror) {
    int idx[3];
    grid.nodeCoords(n, idx);
    for (int a = 0; a < 3; ++a) {
      if (walls.mirrored(a) && idx[a] == walls.thickness) v[a] = 0.f;  // on the mirror plane
      if (!walls.enabled) continue;
      const bool atLower = idx[a] < walls.thickness && !walls.mirrored(a);
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

// Mirror planes. The scene holds the part of a symmetric body on the upper side of each
// mirror plane; its mirror images are not stored but the grid sees them. P2G of the
// stored particles puts on a ghost node (below a plane) what their images put on the
// ghost's mirror node, so folding the ghosts onto their mirror nodes gives those nodes
// exactly what the whole body gives them. A node on a plane keeps only its own share
// (the images would double its mass and tangential momentum and cancel the normal
// momentum): its velocity is the whole body's, and what it exchanges with a shape is the
// modelled part's share, so shape impulses are those of the modelled part. After the grid
// update the ghosts take their mirror nodes' velocities, reflected, for G2P.

/// Reflects the node coordinates `idx` in the mirror planes of the axes in `axes`; the
/// sign of each reflected velocity component in `sign`.
MPM_HD void reflectNode(const WallParams& walls, int axes, int idx[3], Vec3f& sign) {
  sign = Vec3f{1.f, 1.f, 1.f};
  for (int a = 0; a < 3; ++a)
    if ((axes >> a) & 1) {
      idx[a] = 2 * walls.thickness - idx[a];
      sign[a] = -1.f;
    }
}

/// A ghost's field folded onto its real node, by how the plane reflects it (Amount,
/// Vector, Moment); `plane` holds each mirrored axis' plane position.
MPM_HD void foldImage(node_image::Amount, float& node, float ghost, Vec3f, Vec3f, float) { node += ghost; }
MPM_HD void foldImage(node_image::Vector, Vec3f& node, Vec3f ghost, Vec3f sign, Vec3f, float) { node += hadamard(sign, ghost); }
MPM_HD void foldImage(node_image::Moment, Vec3f& node, Vec3f ghost, Vec3f sign, Vec3f plane, float ghostMass) {
  for (int a = 0; a < 3; ++a)  // the image of x is 2 plane - x
    node[a] += sign[a] > 0.f ? ghost[a] : 2.f * plane[a] * ghostMass - ghost[a];
}
/// A field of a node on the plane of axis a: the images cancel a Vector's normal part and
/// put a Moment's point on the plane.
MPM_HD void onPlane(node_image::Amount, float&, int, Vec3f, float) {}
MPM_HD void onPlane(node_image::Vector, Vec3f& f, int a, Vec3f, float) { f[a] = 0.f; }
MPM_HD void onPlane(node_image::Moment, Vec3f& f, int a, Vec3f plane, float mass) { f[a] = plane[a] * mass; }
/// A ghost's field for G2P after the update: a Vector takes its real node's, reflected;
/// the others are not read there.
MPM_HD void unfoldImage(node_image::Amount, float&, const float*, Vec3f) {}
MPM_HD void unfoldImage(node_image::Moment, Vec3f&, const Vec3f*, Vec3f) {}
MPM_HD void unfoldImage(node_image::Vector, Vec3f& ghost, const Vec3f* real, Vec3f sign) {
  ghost = real ? hadamard(sign, *real) : Vec3f{0.f, 0.f, 0.f};
}

/// Folds the ghost images of node `n` onto it (after P2G, before the grid update): every
/// ghost is read and emptied by exactly one real node, so nodes run in parallel.
struct MirrorFold {
  GridView grid;
  WallParams walls;
  /// The material centroids (mx, touch) are those an earlier P2G scattered and this fold
  /// already folded (PB-MPM's later cycles, ParticleGridSystem::scatter's keepCentroids):
  /// they stay as they are. Folded again, each cycle added a ghost's image term
  /// 2 plane m_ghost to its real node's mx once more (the ghost's mx emptied, its mass
  /// scattered anew): a quarter model on planes off the origin took 43 % of its share of a
  /// pressing sphere's impulse on PB-MPM (test_walls).
  bool centroidsKept = false;
  MPM_HD void operator()(size_t n) const {
    int idx[3];
    grid.nodeCoords((uint32_t)n, idx);
    int above = 0;  // mirrored axes on which the node lies above the plane
    for (int a = 0; a < 3; ++a) {
      if (!walls.mirrored(a)) continue;
      if (idx[a] < walls.thickness) return;  // a ghost: its real node folds it
      if (idx[a] > walls.thickness) above |= 1 << a;
    }
    GridNode& node = grid.nodes[n];
    const Vec3f keptMx = node.mx;
    const float keptTouch = node.touch;
    const Vec3f planes{plane(0), plane(1), plane(2)};
    for (int axes = above; axes; axes = (axes - 1) & above) {  // every non-empty subset
      int g[3] = {idx[0], idx[1], idx[2]};
      Vec3f sign;
      reflectNode(walls, axes, g, sign);
      GridNode* ghost = grid.find(g[0], g[1], g[2]);
      if (!ghost || ghost->mass == 0.f) continue;
      const float ghostMass = ghost->mass;
#define MPM_FOLD(type, name, image) foldImage(image{}, node.name, ghost->name, sign, planes, ghostMass);
      MPM_GRID_NODE_FIELDS(MPM_FOLD)
#undef MPM_FOLD
      *ghost = GridNode{};
    }
    for (int a = 0; a < 3; ++a)
      if (walls.mirrored(a) && idx[a] == walls.thickness) {
#define MPM_ON_PLANE(type, name, image) onPlane(image{}, node.name, a, planes, node.mass);
        MPM_GRID_NODE_FIELDS(MPM_ON_PLANE)
#undef MPM_ON_PLANE
      }
    if (centroidsKept) {
      node.mx = keptMx;
      node.touch = keptTouch;
    }
  }
  MPM_HD float plane(int a) const { return grid.geo.lower[a] + (float)walls.thickness * grid.geo.dx; }
};

/// Gives ghost node `n` its mirror node's velocity (mv) and old velocity (dmv), reflected
/// (after the grid update and contact, before G2P).
struct MirrorUnfold {
  GridView grid;
  WallParams walls;
  MPM_HD void operator()(size_t n) const {
    int idx[3];
    grid.nodeCoords((uint32_t)n, idx);
    int below = 0;
    for (int a = 0; a < 3; ++a)
      if (walls.mirrored(a) && idx[a] < walls.thickness) below |= 1 << a;
    if (!below) return;
    Vec3f sign;
    reflectNode(walls, below, idx, sign);
    const GridNode* real = grid.find(idx[0], idx[1], idx[2]);
    GridNode& node = grid.nodes[n];
#define MPM_UNFOLD(type, name, image) unfoldImage(image{}, node.name, real ? &real->name : nullptr, sign);
    MPM_GRID_NODE_FIELDS(MPM_UNFOLD)
#undef MPM_UNFOLD
  }
};

/// The node kernel of a P2G that runs no grid update in its pass (Exec::particleToGrid).
struct NoNodeUpdate {
  MPM_HD void operator()(size_t) const {}
};

/// The grid update of a whole substep as a per-node kernel.
struct GridUpdate {
  GridView grid;
  float dt;
  Vec3f gravity;
  WallParams walls;
  MPM_HD void operator()(size_t n) const { gridUpdateNode((uint32_t)n, grid, dt, gravity, walls); }
};

}  // namespace mpm
