#pragma once
// The incline of the contact and Bullet tests, defined once: a box ramp tilted by theta
// about z whose top face passes through (x0, y0) and descends along +x, with outward
// normal n = (sin, cos, 0) and downhill direction s = (cos, -sin, 0). The API samples
// axis-aligned boxes only, so the tissue is a parallelogram of vertical columns one
// particle wide, each starting half a particle spacing above the face: the whole bottom
// touches from the start. Neighbouring columns share grid nodes and move as one block.
// Closed form: a = g (sin theta - mu cos theta) if tan theta > mu, else rest.
#include <cmath>
#include <vector>

#include "body_sums.h"
#include "mpm/scene.h"

namespace mpm::test {

struct Incline {
  double theta;                                ///< tilt [rad]
  static constexpr double kX0 = -0.2, kY0 = 0.35;  ///< a point of the ramp's top face [m]
  static constexpr float kRampHalf[3] = {0.6f, 0.05f, 0.15f};  ///< ramp box half extents [m]
  static constexpr float kDx = 0.01f, kSpacing = 0.005f;  ///< grid cell; particle spacing (8 per cell)

  double c() const { return std::cos(theta); }
  double s() const { return std::sin(theta); }

  /// The domain and grid around the ramp, keeping the rest of `st` (solver, gravity).
  void configure(SceneSettings& st) const {
    st.domain.lower = {-0.35f, 0.f, -0.1f};
    st.domain.upper = {0.35f, 0.5f, 0.1f};
    st.dx = kDx;
  }
  /// Centre of the ramp box (rotated by -theta about z).
  Vec3f rampCentre() const {
    return {(float)(kX0 - kRampHalf[1] * s()), (float)(kY0 - kRampHalf[1] * c()), 0.f};
  }
  /// 16 columns of 8 particles: 8 cm along x, 4 cm tall, 5 cm deep.
  std::vector<ParticleObjectId> addTissue(Scene& scene, const Material& material) const {
    const int columns = 16, layers = 8;
    const double h = kSpacing;
    std::vector<ParticleObjectId> ids;
    for (int i = 0; i < columns; ++i) {
      ParticleObjectDesc d;
      const double x = kX0 + (i - 0.5 * (columns - 1)) * h;
      const double face = kY0 - std::tan(theta) * (x - kX0);
      d.halfExtents = {0.5f * (float)h, 0.5f * layers * (float)h, 0.025f};
      d.center = {(float)x, (float)(face + 0.5 * h / c() + 0.5 * (layers - 1) * h), 0.f};
      d.material = material;
      ids.push_back(scene.addParticleObject(d));
    }
    return ids;
  }
  /// Component along the downhill direction s.
  double along(const double v[3]) const { return v[0] * c() - v[1] * s(); }
  /// The tissue's centre-of-mass velocity along s.
  double slopeSpeed(const BodySum& b) const {
    const double v[3] = {b.momentum[0] / b.mass, b.momentum[1] / b.mass, b.momentum[2] / b.mass};
    return along(v);
  }
};

/// Least-squares slope of samples v(t).
struct LineFit {
  double n = 0, sT = 0, sV = 0, sTT = 0, sTV = 0;
  void add(double t, double v) { n += 1, sT += t, sV += v, sTT += t * t, sTV += t * v; }
  double slope() const { return (n * sTV - sT * sV) / (n * sTT - sT * sT); }
};

}  // namespace mpm::test
