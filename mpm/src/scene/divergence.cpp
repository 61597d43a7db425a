#include "scene/divergence.h"

#include <sstream>

#include "core/validate.h"

namespace mpm {

std::string describeParticle(const HostParticles& all, uint32_t particle, double time) {
  std::ostringstream s;
  s << "particle " << all.local[particle] << " of object " << all.object[particle]
    << " is at " << validate::show(all.x[particle]) << " with velocity "
    << validate::show(all.v[particle]) << " and volume ratio J = det F = "
    << determinant(all.F[particle]) << " at t = " << time << " s";
  return s.str();
}

void reportDivergence(const SimBackend& backend, uint32_t particle, double time) {
  HostParticles all;
  backend.download(all);
  throw SimulationDiverged(describeParticle(all, particle, time) + ": its state is not finite or it left the grid");
}

}  // namespace mpm
