#pragma once
// Several particle objects taken as one body (tissue sampled as columns or pieces): the
// sums the contact and coupling tests compare with closed forms.
#include <vector>

#include "mpm/scene.h"

namespace mpm::test {

/// Mass, centre of mass and momentum of several particle objects taken as one body.
struct BodySum {
  double mass = 0, com[3] = {0, 0, 0}, momentum[3] = {0, 0, 0};
};

inline BodySum sumOf(const Scene& scene, const std::vector<ParticleObjectId>& ids) {
  BodySum b;
  for (const ParticleObjectId id : ids) {
    const ObjectSummary s = scene.summary(id);
    b.mass += s.mass;
    for (int a = 0; a < 3; ++a) {
      b.com[a] += s.mass * s.centerOfMass[a];
      b.momentum[a] += s.momentum[a];
    }
  }
  for (int a = 0; a < 3; ++a) b.com[a] /= b.mass;
  return b;
}

}  // namespace mpm::test
