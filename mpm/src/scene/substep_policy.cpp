#include "scene/substep_policy.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "core/validate.h"
#include "solvers/solver_list.h"

namespace mpm {

float SubstepBounds::maxSubstep() const {
  float wave = 0.f;
  if (solverTraits(settings.solver).elasticCfl)
    for (size_t i = 0; i < objects.size(); ++i)
      if (objects.alive(i)) wave = std::max(wave, pWaveSpeed(objects[i].material));
  // a moving shape pushes material along at its own speed
  float shapeSpeed = 0.f;
  for (size_t i = 0; i < shapes.size(); ++i)
    if (shapes.alive(i)) shapeSpeed = std::max(shapeSpeed, norm(shapes[i].state.linearVelocity));
  for (size_t i = 0; i < slicers.size(); ++i)
    if (slicers.alive(i)) shapeSpeed = std::max(shapeSpeed, norm(slicers[i].state.linearVelocity));
  for (size_t i = 0; i < curves.size(); ++i) {
    if (!curves.alive(i)) continue;
    const CurveRecord& c = curves[i];
    if (c.needle)  // its tip is the fastest point of it
      shapeSpeed = std::max(shapeSpeed, norm(c.state.linearVelocity) + norm(c.state.angularVelocity) * c.arc.radius);
    for (const Vec3f& v : c.thread.velocities) shapeSpeed = std::max(shapeSpeed, norm(v));
  }
  const float speed = wave + std::max(maxParticleSpeed, shapeSpeed);
  float dtMax = backend.stableTimeStep();
  if (speed > 0.f) dtMax = std::min(dtMax, settings.substeps.cflFor(settings.solver) * settings.dx / speed);
  return dtMax;
}

int SubstepBounds::substepCount(float dt) const {
  if (settings.substeps.fixedSubsteps > 0) return settings.substeps.fixedSubsteps;
  const float dtMax = maxSubstep();
  if (dtMax == std::numeric_limits<float>::infinity()) return 1;
  const float n = dt / dtMax;  // NaN or infinite for a zero or NaN bound: refused
  if (!(n <= kMaxSubsteps)) refuseSubsteps(dt, dtMax);
  return std::max(1, (int)std::ceil(n - 1e-5f));
}

void SubstepBounds::refuseSubsteps(float dt, float dtMax) const {
  std::ostringstream s;
  s.precision(3);
  s << "needs " << (double)dt / dtMax << " substeps of at most " << dtMax << " s, more than the limit of "
    << kMaxSubsteps << " an advance takes:";
  size_t stiffest = objects.size();
  for (size_t i = 0; i < objects.size(); ++i)
    if (objects.alive(i) && (stiffest == objects.size() ||
                             pWaveSpeed(objects[i].material) > pWaveSpeed(objects[stiffest].material)))
      stiffest = i;
  if (stiffest < objects.size())
    s << " object " << stiffest << "'s material (youngsModulus = " << validate::show(objects[stiffest].youngsModulus)
      << " Pa, density = " << objects[stiffest].material.density << " kg/m^3) carries elastic waves at "
      << pWaveSpeed(objects[stiffest].material) << " m/s;";
  const float own = backend.stableTimeStep();
  if (own < std::numeric_limits<float>::infinity()) s << " the solver's own stable step is " << own << " s;";
  s << " the fastest particle moves at " << maxParticleSpeed << " m/s (SceneSettings.substeps.cflNumber = "
    << settings.substeps.cflNumber;
  if (settings.substeps.cflNumber == 0.f) s << ", the solver's default " << settings.substeps.cflFor(settings.solver);
  s << ", dx = " << settings.dx
    << " m). Use a softer material or a larger dx, or advance by less at a time";
  throw InvalidArgument("Scene::advance dt", validate::show(dt), s.str());
}

SubstepParams substepParams(const SceneSettings& settings, float dt) {
  SubstepParams p;
  p.dt = dt;
  p.gravity = settings.gravity;
  p.walls.enabled = settings.domain.walls ? 1 : 0;
  p.walls.mode = static_cast<int>(settings.domain.wallMode);
  p.walls.thickness = settings.domain.wallThickness;
  for (int a = 0; a < 3; ++a) p.walls.mirror |= settings.domain.mirrorLower[a] ? 1 << a : 0;
  p.solver.flipBlend = settings.standardMpm.flipBlend;
  p.solver.iterations = settings.pbMpm.iterations;
  p.solver.relaxation = settings.pbMpm.relaxation;
  p.solver.rigidity = settings.pbMpm.rigidity;
  return p;
}

}  // namespace mpm
