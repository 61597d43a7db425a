#include "scene/particle_seeding.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <utility>

#include "core/validate.h"
#include "solvers/solver_list.h"

namespace mpm {

namespace {

MaterialParams materialParams(const Material& m) {
  MaterialParams p;
  p.model = m.model == MaterialModel::NeoHookeanDecoupled ? kNeoHookeanDecoupled : kFixedCorotated;
  const float E = m.youngsModulus, nu = m.poissonRatio;
  p.mu = E / (2.f * (1.f + nu));
  p.lambda = E * nu / ((1.f + nu) * (1.f - 2.f * nu));
  p.bulk = p.lambda + 2.f * p.mu / 3.f;
  p.density = m.density;
  p.toughness = m.fractureToughness;
  return p;
}

Mat3f skew(Vec3f w) {
  Mat3f m;
  m.m[0][1] = -w.z; m.m[0][2] = w.y;
  m.m[1][0] = w.z;  m.m[1][2] = -w.x;
  m.m[2][0] = -w.y; m.m[2][1] = w.x;
  return m;
}

/// Most particles a scene holds: 11 GB of particle state (kParticleStateBytes each) on
/// the device and as much again on the host while they are made; their indices are 32-bit.
constexpr double kMaxParticles = 1e8;

/// The field that sets an object's particle spacing, and its value.
std::pair<std::string, std::string> spacingField(const ParticleObjectDesc& d) {
  if (d.particleSpacing > 0.f) return {"ParticleObjectDesc.particleSpacing", validate::show(d.particleSpacing)};
  return {"ParticleObjectDesc.particlesPerCellAxis", std::to_string(d.particlesPerCellAxis)};
}

/// Refuses, before any particle is made, an object whose lattice of spacing h over its
/// bounds `size` (and, meshless, its integration cells) would pass kMaxParticles.
void checkParticleBudget(const ParticleObjectDesc& d, float h, Vec3f size, bool meshless,
                         const SceneSettings& settings, const SimBackend& backend) {
  double lattice = 1;
  for (int a = 0; a < 3; ++a) lattice *= std::round((double)size[a] / h) + (meshless ? 1 : 0);
  const double cells = meshless ? lattice * std::pow((double)settings.mtled.integrationCellsPerSpacing, 3) : 0;
  const double total = (double)backend.particleCount() + std::max(lattice, cells);
  if (total <= kMaxParticles) return;
  std::ostringstream why;
  why.precision(3);
  why << "gives a particle spacing of " << h << " m: about " << lattice << " particles in the object's bounds";
  if (meshless) why << " and " << cells << " integration cells";
  why << ", " << lattice * kParticleStateBytes / 1e9 << " GB of particle state; a scene holds at most "
      << kMaxParticles << " (it has " << backend.particleCount() << ")";
  const auto [field, value] = spacingField(d);
  throw InvalidArgument(field, value, why.str());
}

}  // namespace

std::vector<MaterialParams> materialTable(const ObjectTable& objects) {
  std::vector<MaterialParams> table(objects.size());
  for (size_t i = 0; i < objects.size(); ++i) table[i] = objects[i].material;
  return table;
}

SeededObject seedParticleObject(const ParticleObjectDesc& d, const ObjectTable& objects,
                                const SceneSettings& settings, const GridGeometry& geo, const SimBackend& backend) {
  validate::particleObjectDesc(d);
  const float h = d.particleSpacing > 0.f ? d.particleSpacing : settings.dx / d.particlesPerCellAxis;
  if (h > settings.dx)
    throw InvalidArgument("ParticleObjectDesc.particleSpacing", validate::show(h),
                          "must not exceed the cell size dx = " + validate::show(settings.dx) +
                              " (fewer than one particle per cell leaves holes in the grid)");
  // lattice over the object's bounds, relative to its centre
  Vec3f lo, hi;
  if (d.primitive == PrimitiveType::Box) {
    lo = -d.halfExtents;
    hi = d.halfExtents;
  } else if (d.primitive == PrimitiveType::Sphere) {
    lo = {-d.radius, -d.radius, -d.radius};
    hi = {d.radius, d.radius, d.radius};
  } else if (d.primitive == PrimitiveType::Cylinder) {
    lo = {-d.radius, -d.halfExtents.y, -d.radius};
    hi = {d.radius, d.halfExtents.y, d.radius};
  } else {
    lo = d.mesh->lower;
    hi = d.mesh->upper();
  }
  // the object's material, relative to its centre (a box fills its bounds)
  const auto inObject = [&d](Vec3f r) {
    switch (d.primitive) {
      case PrimitiveType::Sphere: return dot(r, r) <= d.radius * d.radius;
      case PrimitiveType::Cylinder: return r.x * r.x + r.z * r.z <= d.radius * d.radius;
      case PrimitiveType::Mesh: return d.mesh->sample(r) < 0.f;
      case PrimitiveType::Box: break;
    }
    return true;
  };
  // MPM particles sit at the centres of lattice cells of spacing h; meshless nodes on the
  // cells' corners, so the outermost ones lie on the bounds (the faces where boundary
  // conditions act), the spacing stretched to fit the bounds exactly
  const bool meshless = solverTraits(settings.solver).meshless;
  checkParticleBudget(d, h, hi - lo, meshless, settings, backend);
  int n[3];
  Vec3f step;
  for (int a = 0; a < 3; ++a) {
    n[a] = (int)std::lround((hi[a] - lo[a]) / h);
    if (n[a] < 1)
      throw InvalidArgument(d.primitive == PrimitiveType::Box ? "ParticleObjectDesc.halfExtents"
                                                              : "ParticleObjectDesc.radius",
                            validate::show(0.5f * (hi[a] - lo[a])),
                            "is smaller than half the particle spacing " + validate::show(h));
    step[a] = meshless ? (hi[a] - lo[a]) / n[a] : h;
    if (meshless) n[a] += 1;
  }
  // the slot the new object will take (not claimed until every check has passed)
  const uint32_t slot = objects.nextSlot();

  SeededObject o;
  HostParticles& add = o.particles;
  const MaterialParams mat = materialParams(d.material);
  const float vol = h * h * h;
  const float lowWall = settings.domain.walls ? (float)settings.domain.wallThickness : 0.f;
  float maxSpeed = 0.f;
  for (int i = 0; i < n[0]; ++i)
    for (int j = 0; j < n[1]; ++j)
      for (int k = 0; k < n[2]; ++k) {
        // lattice centred in the bounds, so a box of whole spacings is filled exactly
        const Vec3f r{0.5f * (lo.x + hi.x) + (i + 0.5f - 0.5f * n[0]) * step.x,
                      0.5f * (lo.y + hi.y) + (j + 0.5f - 0.5f * n[1]) * step.y,
                      0.5f * (lo.z + hi.z) + (k + 0.5f - 0.5f * n[2]) * step.z};
        // a node on a curved surface may miss it by rounding: keep it
        if (!inObject(r) && !(meshless && inObject((1.f - 1e-5f) * r))) continue;
        const Vec3f x = d.center + r;
        bool inDomain = geo.stencilInside(x);
        for (int a = 0; a < 3 && inDomain; ++a) {
          const float g = (x[a] - geo.lower[a]) * geo.invDx;
          const float low = settings.domain.mirrorLower[a] ? (float)settings.domain.wallThickness : lowWall;
          inDomain = g >= low && g <= geo.cells[a] - lowWall;
        }
        if (!inDomain)
          throw InvalidArgument(
              "ParticleObjectDesc.center", validate::show(d.center),
              "puts a particle at " + validate::show(x) +
                  " outside the domain interior (domain minus walls and the B-spline stencil)");
        const Vec3f v = d.velocity + cross(d.angularVelocity, r);
        maxSpeed = std::max(maxSpeed, norm(v));
        add.x.push_back(x);
        add.v.push_back(v);
        add.C.push_back(skew(d.angularVelocity));  // velocity gradient of the rigid motion
        add.F.push_back(Mat3f::identity());
        add.mass.push_back(d.material.density * vol);
        add.volume0.push_back(vol);
        add.object.push_back(slot);
        add.local.push_back((uint32_t)add.x.size() - 1);
        add.touch.push_back(0.f);
        add.cut.push_back(CutPlane{});
      }
  if (add.size() == 0)
    throw InvalidArgument(d.primitive == PrimitiveType::Mesh ? "ParticleObjectDesc.mesh" : "ParticleObjectDesc.radius",
                          d.primitive == PrimitiveType::Mesh ? "grid" : validate::show(d.radius),
                          "holds no particle at spacing " + validate::show(h));
  if (meshless) {
    const float cellSize = h / settings.mtled.integrationCellsPerSpacing;
    o.cells = integrationCells([&](Vec3f x) { return inObject(x - d.center); }, d.center + lo, d.center + hi, cellSize);
    // the solver's model of the object (MTLED: support domains, moment matrices) is
    // checked now, so its errors come from here and not from the next advance
    std::vector<MaterialParams> table = materialTable(objects);
    table.resize(std::max<size_t>(table.size(), slot + 1));
    table[slot] = mat;
    try {
      backend.checkObject(slot, add, o.cells, table);
    } catch (const Error& e) {
      const auto [field, value] = spacingField(d);
      throw InvalidArgument(field, value, std::string("cannot be modelled: ") + e.what());
    }
  }
  o.record.particles = add.size();
  o.record.material = mat;
  o.record.youngsModulus = d.material.youngsModulus;
  o.record.maxInitialSpeed = maxSpeed;
  return o;
}

}  // namespace mpm
