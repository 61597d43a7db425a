#pragma once
// The stages the explicit solvers compose around the transfers: P2G with or without the
// material centroid, the G2P kernel given its parts, and the explicit substep itself.
#include "core/substep.h"

namespace mpm {

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

}  // namespace mpm
