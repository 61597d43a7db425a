#include "core/validate.h"

#include <cmath>
#include <cstdlib>
#include <sstream>

namespace mpm::validate {

std::string show(float v) {
  // not "-nan": a NaN's sign bit means nothing, and 0 / 0 on x86 sets it
  if (std::isnan(v)) return "nan";
  // the shortest text that reads back as the same float: 0.45f prints as "0.45"
  for (int digits = 6; digits <= 9; ++digits) {
    std::ostringstream s;
    s.precision(digits);
    s << v;
    if (std::strtof(s.str().c_str(), nullptr) == v || !std::isfinite(v)) return s.str();
  }
  return std::to_string(v);
}

std::string show(Vec3f v) { return "(" + show(v.x) + ", " + show(v.y) + ", " + show(v.z) + ")"; }

void finite(std::string_view field, float v) {
  if (!std::isfinite(v)) throw InvalidArgument(std::string(field), show(v), "must be a finite number");
}
void finite(std::string_view field, Vec3f v) {
  if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
    throw InvalidArgument(std::string(field), show(v), "every component must be a finite number");
}
void positive(std::string_view field, float v) {
  finite(field, v);
  if (!(v > 0.f)) throw InvalidArgument(std::string(field), show(v), "must be > 0");
}
void positive(std::string_view field, Vec3f v) {
  finite(field, v);
  if (!(v.x > 0.f && v.y > 0.f && v.z > 0.f))
    throw InvalidArgument(std::string(field), show(v), "every component must be > 0");
}
void atLeast(const std::string& field, int v, int lo) {
  if (v < lo) throw InvalidArgument(field, std::to_string(v), "must be >= " + std::to_string(lo));
}

void enumerator(const std::string& field, int v, int count, const char* type) {
  if (v < 0 || v >= count)
    throw InvalidArgument(field, std::to_string(v),
                          std::string("is not a ") + type + " (0 .. " + std::to_string(count - 1) + ")");
}

void sceneSettings(const SceneSettings& s) {
  enumerator("SceneSettings.solver", s.solver, SolverType::Mtled, "SolverType");
  enumerator("SceneSettings.backend", s.backend, Backend::Cuda, "Backend");
  enumerator("SceneSettings.domain.wallMode", s.domain.wallMode, WallMode::Separate, "WallMode");
  finite("SceneSettings.domain.lower", s.domain.lower);
  finite("SceneSettings.domain.upper", s.domain.upper);
  positive("SceneSettings.dx", s.dx);
  const Vec3f size = s.domain.upper - s.domain.lower;
  if (!(size.x > 0.f && size.y > 0.f && size.z > 0.f))
    throw InvalidArgument("SceneSettings.domain.upper", show(s.domain.upper),
                          "must exceed domain.lower " + show(s.domain.lower) + " on every axis");
  // The grid keeps dense tables over all its 4^3-node blocks before any particle, and
  // indexes blocks with 32-bit ints: bound the total, not only each axis. The tables:
  // on the CPU the binning's count, active slot and occupied rank of each block (4 bytes
  // each, CpuExec::Binning), on the GPU its active slot (CudaExec::Binning; Auto may be
  // either: the CPU's is stated). MTLED has no grid.
  double blocks = 1;
  for (int a = 0; a < 3; ++a) {
    const double cells = std::ceil(size[a] / s.dx);
    if (cells < 4)
      throw InvalidArgument("SceneSettings.dx", show(s.dx),
                            "leaves fewer than 4 cells across the domain");
    blocks *= std::ceil((cells + 1) / 4);
  }
  constexpr double kMaxBlocks = 1 << 28;
  const bool gpu = s.backend == Backend::Cuda;
  const double bytesPerBlock = gpu ? 4 : 12;
  if (blocks > kMaxBlocks && s.solver != SolverType::Mtled) {
    std::ostringstream why;
    why.precision(3);
    why << "gives " << blocks << " grid blocks of 4^3 nodes over the domain " << show(s.domain.lower) << " - "
        << show(s.domain.upper) << ": their tables alone would take " << blocks * bytesPerBlock / 1e9
        << " GB of memory (" << bytesPerBlock << " bytes a block on the " << (gpu ? "GPU" : "CPU")
        << "), more than the limit of " << kMaxBlocks * bytesPerBlock / 1e9 << " GB (" << kMaxBlocks
        << " blocks); use a larger dx or a smaller domain";
    throw InvalidArgument("SceneSettings.dx", show(s.dx), why.str());
  }
  for (int a = 0; a < 3; ++a)
    if (std::ceil(size[a] / s.dx) > 16384)
      throw InvalidArgument("SceneSettings.dx", show(s.dx),
                            "gives more than 16384 cells along one axis of the domain");
  atLeast("SceneSettings.domain.wallThickness", s.domain.wallThickness, 1);
  for (int a = 0; a < 3; ++a)
    if (s.domain.mirrorLower[a] && s.solver == SolverType::Mtled)
      throw InvalidArgument("SceneSettings.domain.mirrorLower[" + std::to_string(a) + "]", "true",
                            "is not supported by the Mtled solver (it has no grid to mirror)");
  finite("SceneSettings.gravity", s.gravity);
  finite("SceneSettings.substeps.cflNumber", s.substeps.cflNumber);
  if (s.substeps.cflNumber < 0.f)  // 0: the solver's default
    throw InvalidArgument("SceneSettings.substeps.cflNumber", show(s.substeps.cflNumber),
                          "must be >= 0 (0: the solver's default)");
  if (s.substeps.cflNumber > 1.f)
    throw InvalidArgument("SceneSettings.substeps.cflNumber", show(s.substeps.cflNumber),
                          "must be <= 1 (explicit MPM is unstable beyond one cell per substep)");
  atLeast("SceneSettings.substeps.fixedSubsteps", s.substeps.fixedSubsteps, 0);
  if (s.substeps.fixedSubsteps > SubstepPolicy::kMaxSubsteps)
    throw InvalidArgument("SceneSettings.substeps.fixedSubsteps", std::to_string(s.substeps.fixedSubsteps),
                          "must be <= " + std::to_string(SubstepPolicy::kMaxSubsteps) +
                              ", the most substeps an advance takes");
  positive("SceneSettings.divergenceCheck.maxCellsPerSubstep", s.divergenceCheck.maxCellsPerSubstep);
  positive("SceneSettings.energyCheck.tolerance", s.energyCheck.tolerance);
  finite("SceneSettings.energyCheck.noiseSpeed", s.energyCheck.noiseSpeed);
  if (s.energyCheck.noiseSpeed < 0.f)
    throw InvalidArgument("SceneSettings.energyCheck.noiseSpeed", show(s.energyCheck.noiseSpeed), "must be >= 0");
  atLeast("SceneSettings.recovery.maxHalvings", s.recovery.maxHalvings, 1);
  if (s.recovery.maxHalvings > 20)
    throw InvalidArgument("SceneSettings.recovery.maxHalvings", std::to_string(s.recovery.maxHalvings),
                          "must be <= 20 (a million times the substeps)");
  atLeast("SceneSettings.cpuThreads", s.cpuThreads, 0);
  const float flip = s.standardMpm.flipBlend;
  if (!(flip >= 0.f && flip <= 1.f))
    throw InvalidArgument("SceneSettings.standardMpm.flipBlend", show(flip), "must lie in [0, 1]");
  const int iterations = s.pbMpm.iterations;
  if (iterations < 1 || iterations > 1000)
    throw InvalidArgument("SceneSettings.pbMpm.iterations", std::to_string(iterations), "must lie in [1, 1000]");
  const float relax = s.pbMpm.relaxation;
  if (!(relax > 0.f && relax < 2.f))
    throw InvalidArgument("SceneSettings.pbMpm.relaxation", show(relax),
                          "must lie in (0, 2) (over-relaxing beyond 2 diverges)");
  const float beta = s.pbMpm.rigidity;
  if (!(beta >= 0.f && beta <= 1.f))
    throw InvalidArgument("SceneSettings.pbMpm.rigidity", show(beta), "must lie in [0, 1]");
  mtledSettings(s.mtled);
}

void mtledSettings(const MtledSettings& m) {
  if (m.supportNodes < 4 || m.supportNodes > 32)
    throw InvalidArgument("SceneSettings.mtled.supportNodes", std::to_string(m.supportNodes),
                          "must lie in [4, 32] (the linear basis needs at least m = 4 nodes)");
  finite("SceneSettings.mtled.supportScale", m.supportScale);
  if (!(m.supportScale > 1.f && m.supportScale <= 1000.f))
    throw InvalidArgument("SceneSettings.mtled.supportScale", show(m.supportScale),
                          "must lie in (1, 1000] (alpha <= 1 gives the farthest node zero weight)");
  finite("SceneSettings.mtled.integrationCellsPerSpacing", m.integrationCellsPerSpacing);
  if (!(m.integrationCellsPerSpacing >= 1.f && m.integrationCellsPerSpacing <= 4.f))
    throw InvalidArgument("SceneSettings.mtled.integrationCellsPerSpacing", show(m.integrationCellsPerSpacing),
                          "must lie in [1, 4] (fewer integration points than nodes leaves nodes outside "
                          "the support domains)");
  finite("SceneSettings.mtled.timeStepSafety", m.timeStepSafety);
  if (!(m.timeStepSafety > 0.f && m.timeStepSafety <= 1.f))
    throw InvalidArgument("SceneSettings.mtled.timeStepSafety", show(m.timeStepSafety),
                          "must lie in (0, 1] (beyond the critical step the explicit update diverges)");
}

void material(const std::string& prefix, const Material& m) {
  enumerator(prefix + ".model", m.model, MaterialModel::NeoHookeanDecoupled, "MaterialModel");
  positive(prefix + ".youngsModulus", m.youngsModulus);
  finite(prefix + ".poissonRatio", m.poissonRatio);
  if (!(m.poissonRatio > -1.f && m.poissonRatio < 0.5f))
    throw InvalidArgument(prefix + ".poissonRatio", show(m.poissonRatio), "must lie in (-1, 0.5)");
  positive(prefix + ".density", m.density);
  finite(prefix + ".fractureToughness", m.fractureToughness);
  if (m.fractureToughness < 0.f)
    throw InvalidArgument(prefix + ".fractureToughness", show(m.fractureToughness), "must be >= 0 [J/m^2]");
}

void particleObjectDesc(const ParticleObjectDesc& d) {
  enumerator("ParticleObjectDesc.primitive", d.primitive, PrimitiveType::Mesh, "PrimitiveType");
  finite("ParticleObjectDesc.center", d.center);
  if (d.primitive == PrimitiveType::Box) positive("ParticleObjectDesc.halfExtents", d.halfExtents);
  if (d.primitive == PrimitiveType::Sphere || d.primitive == PrimitiveType::Cylinder)
    positive("ParticleObjectDesc.radius", d.radius);
  if (d.primitive == PrimitiveType::Cylinder) positive("ParticleObjectDesc.halfExtents.y", d.halfExtents.y);
  if (d.primitive == PrimitiveType::Mesh) {
    if (!d.mesh || d.mesh->values.empty())
      throw InvalidArgument("ParticleObjectDesc.mesh", "empty", "a Mesh object needs a signed distance grid");
    if (!d.mesh->signReliable)
      throw InvalidArgument("ParticleObjectDesc.mesh", "not watertight",
                            "cannot be filled with particles: inside is undefined (" + d.mesh->signWarning + ")");
  }
  atLeast("ParticleObjectDesc.particlesPerCellAxis", d.particlesPerCellAxis, 1);
  finite("ParticleObjectDesc.particleSpacing", d.particleSpacing);
  if (d.particleSpacing < 0.f)
    throw InvalidArgument("ParticleObjectDesc.particleSpacing", show(d.particleSpacing),
                          "must be > 0, or 0 to use dx / particlesPerCellAxis");
  finite("ParticleObjectDesc.velocity", d.velocity);
  finite("ParticleObjectDesc.angularVelocity", d.angularVelocity);
  material("ParticleObjectDesc.material", d.material);
}

}  // namespace mpm::validate
