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

void reportDivergence(const SimBackend& backend, uint32_t particle, double time, SolverType solver) {
  HostParticles all;
  backend.download(all);
  throw SimulationDiverged(describeParticle(all, particle, time) +
                           (solver == SolverType::PbMpm
                                ? ": its state is not finite, it left the grid, or its volume ratio left [0.5, 2] (PB-MPM's "
                                  "constraint holds it at 1)"
                                : ": its state is not finite or it left the grid"));
}

}  // namespace mpm
