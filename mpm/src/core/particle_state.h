#pragma once
// Dynamic particle state as a structure of arrays. The fields are listed once, in
// MPM_PARTICLE_FIELDS, so allocation, permutation (sorting by grid block), appending,
// removal and host/device copies are all generated from the one list.
#include <cstdint>

#include "mpm/math.h"

namespace mpm {

// X(type, name): one array per field, one element per particle.
#define MPM_PARTICLE_FIELDS(X)                                              \
  X(Vec3f, x)          /* position [m] */                                    \
  X(Vec3f, v)          /* velocity [m/s] */                                  \
  X(Mat3f, C)          /* APIC affine velocity field [1/s] */                \
  X(Mat3f, F)          /* deformation gradient */                            \
  X(float, mass)       /* [kg] */                                            \
  X(float, volume0)    /* rest volume [m^3] */                               \
  X(uint32_t, object)  /* slot of the owning ParticleObject (its material) */ \
  X(uint32_t, local)   /* index within the object, stable across sorting */ \
  X(float, touch)      /* 1 if it ended its last substep touching a shape */

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
