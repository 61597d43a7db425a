#pragma once
// Particle fields as a structure of arrays. The fields are listed once, split by role
// (MuJoCo's mjModel / mjData): model fields are fixed for a particle's life, state fields
// change every substep. Allocation, permutation (sorting by grid block), appending,
// removal, host/device copies, the rollback of a failed advance and checkpoints are all
// generated from MPM_PARTICLE_FIELDS, the two lists together. The rollback copies the
// model fields too when the sort at the start of an advance moves particles (it permutes
// them with the state); with every particle in block order already, the state alone.
#include <cstdint>

#include "mpm/math.h"

namespace mpm {

/// Where a blade has cut past a particle (transfer/cut.h): the blade's plane as the
/// particle sees it, carried with the material. Grid nodes across it are not the
/// particle's. All zero: never cut.
struct CutPlane {
  Vec3f normal;        ///< unit, from the plane toward the particle's side
  float offset = 0.f;  ///< the particle's distance from the plane [m]
};

// X(type, name): one array per field, one element per particle.
#define MPM_PARTICLE_MODEL_FIELDS(X)                                        \
  X(float, mass)       /* [kg] */                                            \
  X(float, volume0)    /* rest volume [m^3] */                               \
  X(uint32_t, object)  /* slot of the owning ParticleObject (its material) */ \
  X(uint32_t, local)   /* index within the object, stable across sorting */
#define MPM_PARTICLE_STATE_FIELDS(X)                        \
  X(Vec3f, x)          /* position [m] */                    \
  X(Vec3f, v)          /* velocity [m/s] */                  \
  X(Mat3f, C)          /* APIC affine velocity field [1/s] */ \
  X(Mat3f, F)          /* deformation gradient */            \
  X(float, touch)      /* 1 if it ended its last substep touching a shape */ \
  X(CutPlane, cut)     /* the cut it lies beside, if a blade has passed it */
#define MPM_PARTICLE_FIELDS(X) MPM_PARTICLE_STATE_FIELDS(X) MPM_PARTICLE_MODEL_FIELDS(X)

/// Non-owning view of the particle arrays, passed to kernels by value.
struct ParticleView {
#define MPM_DECLARE_FIELD(type, name) type* name = nullptr;
  MPM_PARTICLE_FIELDS(MPM_DECLARE_FIELD)
#undef MPM_DECLARE_FIELD
  uint32_t count = 0;
};

/// Bytes of state per particle (sum of all fields).
constexpr size_t kParticleStateBytes = 0
#define MPM_FIELD_BYTES(type, name) +sizeof(type)
    MPM_PARTICLE_FIELDS(MPM_FIELD_BYTES)
#undef MPM_FIELD_BYTES
    ;

}  // namespace mpm
