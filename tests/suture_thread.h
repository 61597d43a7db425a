#pragma once
// What the suture tests share (test_suture_thread, test_thread_coupling,
// test_suturing_bullet): the thread's tick and iterations, a test thread, a watch on its
// links and pins over a run (the thread-in-tissue tests' grid and blocks: wound_gap.h).
#include <BulletDynamics/Featherstone/btMultiBody.h>
#include <btBulletDynamicsCommon.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "mpm/scene.h"
#include "mpm_bullet/suture.h"
#include "wound_gap.h"

namespace mpm::test {

inline bool finite(const btVector3& v) { return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z()); }

constexpr float kThreadTick = 1.f / 960;  // the thread's tick and solver iterations (suture.h)
constexpr int kThreadIterations = 50;

/// A 6 cm, 30-segment thread (1e-4 kg/m) from `start` along `direction`.
inline bullet::SutureThreadDesc testThread(const btVector3& start, const btVector3& direction, float damping) {
  bullet::SutureThreadDesc d;
  d.length = 0.06f;
  d.segments = 30;
  d.radius = 0.15e-3f;
  d.linearDensity = 1e-4f;
  d.damping = damping;
  d.start = start;
  d.direction = direction;
  d.collisionMask = 0;  // no self-contact: the energy is the chain's alone
  return d;
}

/// Kinetic plus potential energy (gravity along -y) of a multibody.
inline double multiBodyEnergy(const btMultiBody* mb, float g) {
  const int n = mb->getNumLinks() + 1;
  btAlignedObjectArray<btVector3> omega, vel;
  omega.resize(n);
  vel.resize(n);
  mb->compTreeLinkVelocities(&omega[0], &vel[0]);  // each in its link's frame, base first
  double e = 0;
  for (int s = 0; s < n; ++s) {
    const double m = s == 0 ? mb->getBaseMass() : mb->getLink(s - 1).m_mass;
    const btVector3 I = s == 0 ? mb->getBaseInertia() : mb->getLink(s - 1).m_inertiaLocal;
    const btVector3& w = omega[s];
    e += 0.5 * m * vel[s].length2() + 0.5 * (I.x() * w.x() * w.x() + I.y() * w.y() * w.y() + I.z() * w.z() * w.z());
    e += m * g * bullet::threadSegmentTransform(mb, s).getOrigin().y();
  }
  return e;
}

/// Worst deviations of a thread over a run: |consecutive points - L| / L, joint gap / L
/// (the end of segment s - 1 against the start of segment s, from their transforms), pin
/// gap / L.
struct ThreadWatch {
  double length = 0, joint = 0, pin = 0;
  bool finite = true;
  void check(const btMultiBody* thread, const bullet::SutureThreadDesc& d) {
    const float L = d.length / d.segments;
    const std::vector<btVector3> p = bullet::threadPoints(thread);
    for (const btVector3& q : p) finite = finite && test::finite(q);
    for (size_t i = 1; i < p.size(); ++i)
      length = std::max(length, (double)(std::fabs((p[i] - p[i - 1]).length() - L) / L));
    for (int s = 1; s < d.segments; ++s) {
      const btVector3 end = bullet::threadSegmentTransform(thread, s - 1) * btVector3(L / 2, 0, 0);
      const btVector3 start = bullet::threadSegmentTransform(thread, s) * btVector3(-L / 2, 0, 0);
      joint = std::max(joint, (double)((end - start).length() / L));
    }
    pin = std::max(pin, (double)((p[0] - d.start).length() / L));
  }
};

}  // namespace mpm::test
