#pragma once
/// Curves: thin wires the material slides along, for suturing (CRESSim-MPM,
/// section IV-C). A curve is not a solid: the grid nodes within its contact region keep only
/// the part of their velocity relative to the curve that runs along the curve's tangent
/// (then friction and drag on it), so a needle or a thread slides along itself through its
/// track but drags the material sideways. Particles are pushed out of the wire itself.
///
/// Two kinds:
/// - ArcDesc: a curved suture needle, moved like a kinematic shape. Its tip is sharp: it
///   presses the surface in (a blunt indenter) until the force on it reaches
///   `punctureForce`, then breaks in and opens the material ahead of it against the
///   material's Material::fractureToughness G_c (a force of G_c times the wire's diameter
///   while it advances through material), and the shaft inside the material feels Coulomb
///   friction from the material's pressure on it. Out of the material again, the tip is
///   blunt until it breaks into the next surface; deep in the material, a surface ahead of
///   it is a far one, which the blunt tip presses out before it emerges (the second peak
///   of a needle passing through tissue). Before it breaks in the tip holds the material
///   within 1.5 dx of its point: the surface dimples over a cell, not over the needle.
/// - LineSegmentsDesc: a thread, a polyline whose points are set before each advance (from
///   the links of a Bullet multibody chain: mpm_bullet/suture.h); each segment is its own
///   body and reports its own impulse.
///
/// A needle's tip and each of a thread's points move no faster than a shape may
/// (ShapeDesc: SubstepPolicy::kMaxSubsteps * cflFor(solver) * dx per second); faster is
/// refused where it is given, naming the field.
#include <cstdint>
#include <limits>
#include <vector>

#include "mpm/shapes.h"

namespace mpm {

/// A circular needle in its own frame: the wire's centre line is the arc of `radius`
/// about the frame's origin in the local x-y plane, from `startAngle` (the tail, where the
/// thread is fixed) to `endAngle` (the sharp tip), angles measured from local +x toward
/// +y. Turning the needle about its local z axis at angular velocity w > 0 moves it along
/// itself, tip first.
struct ArcDesc {
  float radius = 0.012f;       ///< [m] of the arc
  float startAngle = 0.f;      ///< [rad] the tail
  float endAngle = 3.1415927f; ///< [rad] the tip; startAngle < endAngle < startAngle + 2 pi
  float wireRadius = 0.25e-3f; ///< [m] the wire's radius (half its diameter d)
  /// Kinetic friction mu_k between the shaft and the material: along the shaft the
  /// material's pressure p on the wire resists with mu_k p pi d per unit length inside it.
  float friction = 0.2f;
  /// [N] the force the tip must press on the surface with before it breaks in (needle and
  /// tissue: 0.1-1 N for 3-0 to 0 needles in skin and liver); 0: it breaks in at first touch.
  float punctureForce = 0.f;
  Pose pose;
  Vec3f linearVelocity{0.f, 0.f, 0.f};   ///< of the frame's origin [m/s]
  Vec3f angularVelocity{0.f, 0.f, 0.f};  ///< [rad/s], world frame
};

/// A thread: the polyline through `points` (at least two), `radius` thick. Its segments
/// are bodies of their own: kinematic (linearDensity 0: they move as the caller says) or,
/// with a linear density, dynamic within a step (each segment's velocity responds to the
/// material substep by substep, as a dynamic shape's does, so a thread lighter than the
/// material it touches settles instead of oscillating; its impulse then says what it
/// took).
struct LineSegmentsDesc {
  std::vector<Vec3f> points;      ///< [m], world
  std::vector<Vec3f> velocities;  ///< [m/s], one per point; empty: at rest
  float radius = 0.125e-3f;       ///< [m]
  float friction = 0.f;           ///< mu_k of the slip along the thread
  float drag = 1.f;               ///< c_d in [0, 1] on the slip along the thread
  float linearDensity = 0.f;      ///< [kg/m]; 0: kinematic segments
  Vec3f gravity{0.f, 0.f, 0.f};   ///< [m/s^2] felt by dynamic segments within a step
};

/// Handle to a curve.
struct CurveId {
  uint32_t index = std::numeric_limits<uint32_t>::max();
  uint32_t generation = 0;
};

}  // namespace mpm
