#pragma once
// The per-particle end of every solver's G2P: push-out of the shapes, then the check that
// its state is finite and its stencil on the grid.
#include "mpm/settings.h"
#include "core/particle_state.h"
#include "core/substep.h"
#include "grid/block_grid.h"
#include "contact/push_out.h"

namespace mpm {

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

/// The end of every solver's G2P: push the particle out of the shapes it ended inside,
/// then check it (state finite, stencil on the grid) and report its speed. `near`: the
/// parts near the particle's block, from the node accessor (Nodes::nearParts; the CPU's
/// block tile has them, the GPU tries every part).
MPM_HD StepCheck finishParticle(uint32_t p, const ParticleView& P, const GridGeometry& geo, const PartView* parts,
                                int nParts, const NearParts& near) {
  StepCheck c;
  const Vec3f x = P.x[p], v = P.v[p];
  const float* F = &P.F[p].m[0][0];
  const float sum = stateSum(&x.x, &v.x, F);
  if (!isFinite(sum) || !geo.stencilInside(x) || !volumeRatioSound(F)) c.firstBadParticle = p;
  P.touch[p] = nParts && pushOutOfParts(P.x[p], parts, nParts, P.volume0[p], near, P.touch[p] > 0.f) ? 1.f : 0.f;
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

}  // namespace mpm
