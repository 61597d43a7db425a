#include "scene/substep_policy.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "core/validate.h"
#include "solvers/solver_list.h"

namespace mpm {

namespace {
/// The fastest elastic wave of the live materials [m/s], and which object carries it.
float stiffestWave(const ObjectTable& objects, size_t* which = nullptr) {
  float wave = 0.f;
  for (size_t i = 0; i < objects.size(); ++i)
    if (objects.alive(i) && pWaveSpeed(objects[i].material) > wave) {
      wave = pWaveSpeed(objects[i].material);
      if (which) *which = i;
    }
  return wave;
}
}  // namespace

SubstepBounds::FastestShape SubstepBounds::fastestShape() const {
  FastestShape f;
  auto consider = [&f](float speed, const char* kind, size_t i, const char* field, int point) {
    if (speed > f.speed) f = {speed, kind, i, field, point};
  };
  // a moving shape pushes material along at its own speed
  for (size_t i = 0; i < shapes.size(); ++i)
    if (shapes.alive(i)) consider(norm(shapes[i].state.linearVelocity), "shape", i, "ShapeState.linearVelocity", -1);
  for (size_t i = 0; i < slicers.size(); ++i)
    if (slicers.alive(i)) consider(norm(slicers[i].state.linearVelocity), "slicer", i, "ShapeState.linearVelocity", -1);
  for (size_t i = 0; i < curves.size(); ++i) {
    if (!curves.alive(i)) continue;
    const CurveRecord& c = curves[i];
    if (c.needle) {  // its tip is the fastest point of it
      const float linear = norm(c.state.linearVelocity), turn = norm(c.state.angularVelocity) * c.arc.radius;
      consider(linear + turn, "curve", i,
               linear >= turn ? "ShapeState.linearVelocity" : "ShapeState.angularVelocity", -1);
    }
    for (size_t k = 0; k < c.thread.velocities.size(); ++k)
      consider(norm(c.thread.velocities[k]), "curve", i, "LineSegmentsDesc.velocities", (int)k);
  }
  return f;
}

float SubstepBounds::maxSubstep() const {
  const float wave = solverTraits(settings.solver).elasticCfl ? stiffestWave(objects) : 0.f;
  const float speed = wave + std::max(maxParticleSpeed, fastestShape().speed);
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
  const float wave = stiffestWave(objects, &stiffest);
  const bool elastic = solverTraits(settings.solver).elasticCfl;
  const FastestShape shape = fastestShape();
  const float own = backend.stableTimeStep();
  const bool ownBinds = own <= dtMax;
  std::string advice = "a softer material or a larger dx";
  if (ownBinds) s << " the solver's own stable step is " << own << " s;";
  if (!ownBinds && shape.kind && shape.speed >= maxParticleSpeed && !(elastic && wave > shape.speed)) {
    s << " " << shape.kind << " " << shape.index << "'s " << shape.field;
    if (shape.point >= 0) s << "[" << shape.point << "]";
    s << " moves it at " << shape.speed << " m/s;";
    advice = "a slower " + std::string(shape.kind) + " or a larger dx";
  } else if (stiffest < objects.size() && (ownBinds || (elastic && wave >= maxParticleSpeed))) {
    s << " object " << stiffest << "'s material (youngsModulus = " << validate::show(objects[stiffest].youngsModulus)
      << " Pa, density = " << objects[stiffest].material.density << " kg/m^3) carries elastic waves at " << wave
      << " m/s;";
  } else {
    s << " the fastest particle moves at " << maxParticleSpeed << " m/s;";
    advice = "a larger dx";
  }
  s << " (SceneSettings.substeps.cflNumber = " << settings.substeps.cflNumber;
  if (settings.substeps.cflNumber == 0.f) s << ", the solver's default " << settings.substeps.cflFor(settings.solver);
  s << ", dx = " << settings.dx << " m). Use " << advice << ", or advance by less at a time";
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
