#include "scene/energy_account.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "scene/divergence.h"
#include "solvers/solver_list.h"

namespace mpm {

namespace {

/// The particles' energy sums, and the particle holding the most energy per unit mass
/// (where a blow-up grows fastest).
struct EnergySums {
  double kinetic = 0, strain = 0, potential = 0, mass = 0;  // potential: -sum m g . x
  uint32_t hottest = 0;
};

EnergySums measureEnergy(const HostParticles& all, const SimBackend& backend, const SceneSettings& settings,
                         const ObjectTable& objects) {
  // W(F) of the particles is the stored energy only where F and E drive the forces (the
  // grid's elastic CFL solvers); MTLED holds it at its integration points; PB-MPM's is
  // not measured, so there kinetic + potential is a lower bound
  const bool strain = solverTraits(settings.solver).elasticCfl;
  EnergySums e;
  const double pointEnergy = backend.integrationPointEnergy(all);
  if (std::isfinite(pointEnergy)) e.strain = pointEnergy;
  double hottest = -1;
  for (size_t i = 0; i < all.size(); ++i) {
    const double m = all.mass[i];
    const Vec3f v = all.v[i], x = all.x[i];
    const double kinetic = 0.5 * m * dot(v, v);
    const double stored =
        strain ? (double)all.volume0[i] * strainEnergyDensity(objects[all.object[i]].material, all.F[i]) : 0.0;
    e.kinetic += kinetic;
    e.strain += stored;
    e.potential -= m * dot(settings.gravity, x);
    e.mass += m;
    const double specific = (kinetic + stored) / m;
    if (!(specific <= hottest)) {  // a NaN is the hottest of all
      hottest = specific;
      e.hottest = (uint32_t)i;
    }
  }
  return e;
}

}  // namespace

void EnergyAccount::start(const SimBackend& backend, const SceneSettings& settings, const ObjectTable& objects) {
  HostParticles all;
  backend.download(all);
  const EnergySums e = measureEnergy(all, backend, settings, objects);
  *this = EnergyAccount{};
  started = true;
  potentialStart = e.potential;
  balance.start = e.kinetic + e.strain;
}

EnergyBalance EnergyAccount::checkAdvance(const SimBackend& backend, const SceneSettings& settings,
                                          const ObjectTable& objects, const ShapeTable& shapes,
                                          const std::vector<ShapeState>& before, double time) {
  for (size_t i = 0; i < shapes.size() && i < before.size(); ++i) {
    if (!shapes.alive(i)) continue;
    const ShapeState& now = shapes[i].state;
    const ShapeImpulse& J = shapes[i].lastImpulse;  // what the material gave the shape
    const double work = -0.5 * (dot(J.linear, before[i].linearVelocity + now.linearVelocity) +
                                dot(J.angular, before[i].angularVelocity + now.angularVelocity));
    balance.work += work;
    positiveWork += std::max(work, 0.0);
  }
  HostParticles all;
  backend.download(all);
  const EnergySums e = measureEnergy(all, backend, settings, objects);
  const EnergyCheck& check = settings.energyCheck;
  EnergyBalance& b = balance;
  b.kinetic = e.kinetic;
  b.strain = e.strain;
  b.released = potentialStart - e.potential;
  mostReleased = std::max(mostReleased, b.released);
  b.supplied = b.start + positiveWork + mostReleased + 0.5 * e.mass * check.noiseSpeed * check.noiseSpeed;
  if (!(b.excess() <= check.tolerance * b.supplied)) {
    std::ostringstream s;
    s << "energy grew without a source: the particles hold " << b.kinetic + b.strain << " J (kinetic "
      << b.kinetic << ", strain " << b.strain << ") against " << b.start << " J at the start, "
      << b.work << " J of shape work and " << b.released << " J released by gravity: an excess of "
      << b.excess() << " J, above SceneSettings.energyCheck.tolerance = " << check.tolerance << " times the "
      << b.supplied << " J supplied. The most energetic per unit mass, "
      << describeParticle(all, e.hottest, time);
    throw SimulationDiverged(s.str());
  }
  return b;
}

}  // namespace mpm
