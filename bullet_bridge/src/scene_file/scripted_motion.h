#pragma once
// Scripted motion of a body: keyframes of position and rotation over time, eased between
// them. Enough for a demo's tool path: a blade lowered, drawn along and withdrawn, a needle
// turned about its axis and then pulled away. Each stretch between two keyframes is eased
// on its own (smoothstep: at rest at both ends), so a path whose stretches each change one
// thing is exactly a demo's script of ramps.
#include <LinearMath/btTransform.h>
#include <btBulletDynamicsCommon.h>

#include <optional>
#include <vector>

#include "mpm/scene.h"
#include "mpm/shapes.h"

namespace mpm::bullet::scene_file {

struct Keyframe {
  double time = 0;  ///< [s]
  Vec3f position{0.f, 0.f, 0.f};
  Vec3f axis{0.f, 0.f, 1.f};
  float angle = 0.f;  ///< [rad] about axis: turns beyond half a circle are kept between two keyframes
  std::optional<bool> smoothstep;  ///< the stretch into this keyframe; unset: the script's
};

struct Keyframes {
  std::vector<Keyframe> frames;  ///< by time; held before the first and after the last
  bool smoothstep = true;        ///< false: linear
  /// The pose at time t. Between two keyframes with the same axis the angle is
  /// interpolated (so a keyframe may turn by more than pi); otherwise the rotations are
  /// slerped.
  btTransform pose(double t) const;
  /// Velocities: the stretch's derivative at t (zero where the pose is held); between
  /// keyframes of different axes the turn by central difference over +-1 ms.
  void velocity(double t, btVector3& v, btVector3& w) const;
};

/// A kinematic body following keyframes: Bullet asks at the start of each stepSimulation
/// for the pose a tick ahead and takes the velocity from the difference.
struct KinematicScript : btMotionState {
  const Keyframes* keys = nullptr;
  const double* clock = nullptr;  ///< Bullet's time (LoadedScene::Impl::bulletTime)
  float tick = 1.f / 240;
  void getWorldTransform(btTransform& t) const override { t = keys->pose(*clock + tick); }
  void setWorldTransform(const btTransform&) override {}
};

}  // namespace mpm::bullet::scene_file
