#include "scene/divergence.h"

#include <cmath>
#include <sstream>

#include "core/validate.h"
#include "solvers/solver_list.h"
#include "transfer/particle_check.h"

namespace mpm {

std::string describeParticle(const HostParticles& all, uint32_t particle, double time) {
  std::ostringstream s;
  s << "particle " << all.local[particle] << " of object " << all.object[particle]
    << " is at " << validate::show(all.x[particle]) << " with velocity "
    << validate::show(all.v[particle]) << " and volume ratio J = det F = "
    << determinant(all.F[particle]) << " at t = " << time << " s";
  return s.str();
}

namespace {

bool finiteState(const HostParticles& all, size_t i) {
  return isFinite(stateSum(&all.x[i].x, &all.v[i].x, &all.F[i].m[0][0]));
}

}  // namespace

void checkParticles(const SimBackend& backend, const StepCheck& check, const SceneSettings& settings,
                    const GridGeometry& geo, float substepDt, double time) {
  const DivergenceCheck& d = settings.divergenceCheck;
  const bool grid = !solverTraits(settings.solver).meshless;  // MTLED's nodes: no stencil, no F of their own
  const float reach = d.maxCellsPerSubstep * settings.dx;
  const bool tooFast = d.enabled && grid && check.peakSpeed2 * substepDt * substepDt > reach * reach;
  if (check.firstBadParticle == 0xffffffffu && !tooFast) return;
  HostParticles all;
  backend.download(all);
  for (size_t i = 0; i < all.size(); ++i) {
    const char* cause = nullptr;
    if (!finiteState(all, i))
      cause = "its state is not finite";
    else if (grid && !geo.stencilInside(all.x[i]))
      cause = "it left the grid";
    else if (grid && d.enabled && !volumeRatioSound(&all.F[i].m[0][0]))
      cause = "its volume ratio is outside (kMinVolumeRatio, kMaxVolumeRatio) = (0.01, 100): the material "
              "collapsed or blew up (SceneSettings.divergenceCheck)";
    if (cause)
      throw SimulationDiverged(describeParticle(all, (uint32_t)i, time) + ": " + cause);
  }
  if (!grid && d.enabled)  // MTLED flagged a node whose integration point's F is out of bounds
    throw SimulationDiverged(describeParticle(all, check.firstBadParticle, time) +
                             ": its volume ratio, or that of an integration point whose strain depends on it, is "
                             "outside (kMinVolumeRatio, kMaxVolumeRatio) = (0.01, 100): the material collapsed or "
                             "blew up (SceneSettings.divergenceCheck)");
  if (!tooFast) return;  // the kernels flagged only what the disabled volume check holds
  size_t fastest = 0;
  for (size_t i = 1; i < all.size(); ++i)
    if (dot(all.v[i], all.v[i]) > dot(all.v[fastest], all.v[fastest])) fastest = i;
  const float peak = std::sqrt(check.peakSpeed2);
  std::ostringstream why;
  why << ": a particle moved " << peak * substepDt / settings.dx << " cells in one substep (" << peak
      << " m/s for " << substepDt << " s; this particle is the fastest now), more than "
      << "SceneSettings.divergenceCheck.maxCellsPerSubstep = " << d.maxCellsPerSubstep
      << ": the substep is too long for the motion (fixedSubsteps or cflNumber, or a shape driving the material)";
  throw SimulationDiverged(describeParticle(all, (uint32_t)fastest, time) + why.str());
}

}  // namespace mpm
