#pragma once
/// The settings structs' fields as one list: each field's name (as validation spells it),
/// a reference to it, and its role. Checkpoints compare and store settings through it, and
/// scene files, the C API and Python are meant to read and write them through it rather
/// than restate every field.
///
///   mpm::forEachField(settings, [](const char* name, auto& value, mpm::FieldRole role) { ... });
///
/// A field added to a settings struct must be added here (the size checks below fail
/// until it is).
#include <type_traits>

#include "mpm/settings.h"

namespace mpm {

/// Model: fixed for a scene's life; it defines the physics, so a checkpoint only loads into
/// a scene whose model fields are equal. Execution: where and how fast it runs, and the
/// run-time policies that watch it (the energy check, recovery from a diverged advance),
/// which change no step that runs to its end; may differ.
enum class FieldRole { Model, Execution };

/// Calls v(name, field, role) for every field of SceneSettings, in declaration order; a
/// fixed-size array is visited element by element ("...mirrorLower[0]"). S is
/// SceneSettings or const SceneSettings.
template <class S, class Visitor, std::enable_if_t<std::is_same_v<std::remove_const_t<S>, SceneSettings>, int> = 0>
void forEachField(S& s, Visitor&& v) {
  constexpr FieldRole M = FieldRole::Model, E = FieldRole::Execution;
  v("SceneSettings.domain.lower", s.domain.lower, M);
  v("SceneSettings.domain.upper", s.domain.upper, M);
  v("SceneSettings.domain.walls", s.domain.walls, M);
  v("SceneSettings.domain.wallMode", s.domain.wallMode, M);
  v("SceneSettings.domain.wallThickness", s.domain.wallThickness, M);
  v("SceneSettings.domain.mirrorLower[0]", s.domain.mirrorLower[0], M);
  v("SceneSettings.domain.mirrorLower[1]", s.domain.mirrorLower[1], M);
  v("SceneSettings.domain.mirrorLower[2]", s.domain.mirrorLower[2], M);
  v("SceneSettings.dx", s.dx, M);
  v("SceneSettings.gravity", s.gravity, M);
  v("SceneSettings.solver", s.solver, M);
  v("SceneSettings.standardMpm.flipBlend", s.standardMpm.flipBlend, M);
  v("SceneSettings.pbMpm.iterations", s.pbMpm.iterations, M);
  v("SceneSettings.pbMpm.relaxation", s.pbMpm.relaxation, M);
  v("SceneSettings.pbMpm.rigidity", s.pbMpm.rigidity, M);
  v("SceneSettings.mtled.supportNodes", s.mtled.supportNodes, M);
  v("SceneSettings.mtled.supportScale", s.mtled.supportScale, M);
  v("SceneSettings.mtled.integrationCellsPerSpacing", s.mtled.integrationCellsPerSpacing, M);
  v("SceneSettings.mtled.smoothedStrain", s.mtled.smoothedStrain, M);
  v("SceneSettings.mtled.timeStepSafety", s.mtled.timeStepSafety, M);
  v("SceneSettings.substeps.cflNumber", s.substeps.cflNumber, M);
  v("SceneSettings.substeps.fixedSubsteps", s.substeps.fixedSubsteps, M);
  v("SceneSettings.energyCheck.enabled", s.energyCheck.enabled, E);
  v("SceneSettings.energyCheck.tolerance", s.energyCheck.tolerance, E);
  v("SceneSettings.energyCheck.noiseSpeed", s.energyCheck.noiseSpeed, E);
  v("SceneSettings.divergenceCheck.enabled", s.divergenceCheck.enabled, E);
  v("SceneSettings.divergenceCheck.maxCellsPerSubstep", s.divergenceCheck.maxCellsPerSubstep, E);
  v("SceneSettings.recovery.enabled", s.recovery.enabled, E);
  v("SceneSettings.recovery.maxHalvings", s.recovery.maxHalvings, E);
  v("SceneSettings.backend", s.backend, E);
  v("SceneSettings.cpuThreads", s.cpuThreads, E);
}


// A field added to a settings struct without its line above changes the struct's size
// (unless it fits in padding): these fail, pointing here.
namespace settings_layout {
struct Domain { Vec3f lower, upper; bool walls; WallMode wallMode; int wallThickness; bool mirrorLower[3]; };
struct Pb { int iterations; float relaxation, rigidity; };
struct Mtled { int supportNodes; float supportScale, integrationCellsPerSpacing; bool smoothedStrain; float timeStepSafety; };
struct Substeps { float cflNumber; int fixedSubsteps; };
struct Energy { bool enabled; float tolerance, noiseSpeed; };
struct Diverge { bool enabled; float maxCellsPerSubstep; };
struct Recover { bool enabled; int maxHalvings; };
struct Scene {
  DomainSettings domain; float dx; Vec3f gravity; SolverType solver; StandardMpmSettings standardMpm;
  PbMpmSettings pbMpm; MtledSettings mtled; SubstepPolicy substeps; EnergyCheck energyCheck; DivergenceCheck divergenceCheck; Recovery recovery;
  Backend backend;
  int cpuThreads;
};
}  // namespace settings_layout
static_assert(sizeof(DomainSettings) == sizeof(settings_layout::Domain), "DomainSettings changed: update forEachField");
static_assert(sizeof(StandardMpmSettings) == sizeof(float), "StandardMpmSettings changed: update forEachField");
static_assert(sizeof(PbMpmSettings) == sizeof(settings_layout::Pb), "PbMpmSettings changed: update forEachField");
static_assert(sizeof(MtledSettings) == sizeof(settings_layout::Mtled), "MtledSettings changed: update forEachField");
static_assert(sizeof(SubstepPolicy) == sizeof(settings_layout::Substeps), "SubstepPolicy changed: update forEachField");
static_assert(sizeof(EnergyCheck) == sizeof(settings_layout::Energy), "EnergyCheck changed: update forEachField");
static_assert(sizeof(DivergenceCheck) == sizeof(settings_layout::Diverge), "DivergenceCheck changed: update forEachField");
static_assert(sizeof(Recovery) == sizeof(settings_layout::Recover), "Recovery changed: update forEachField");
static_assert(sizeof(SceneSettings) == sizeof(settings_layout::Scene), "SceneSettings changed: update forEachField");

}  // namespace mpm
