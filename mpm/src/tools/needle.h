#pragma once
// A needle's tip inside the material: the resistance it meets while it opens a track.
#include "tools/blade.h"

namespace mpm {

/// The resistance of the material to a needle's tip inside it (kPartTipInside of body
/// `body`): the tip opens a track of the wire's diameter d against the fracture toughness,
/// G_c d while it advances. Particles in the half ball of radius kCuttingReach dx ahead of
/// the tip share it, each by its volume times (1 - rho^2 / r^2)^2 over that weight's
/// integral on the half ball, 16 pi r^3 / 105; so the force is G_c d where the half ball is
/// full of material, and less as the tip leaves it. Returns the force on the needle [N]
/// (the particle takes the opposite); `presence` gets the particle's share whatever the
/// tip's motion (the scene tells from it whether the tip is still in material). Withdrawing
/// (moving back along its tangent) the tip opens nothing: no force.
MPM_HD Vec3f needleTipResistance(const PartView& tip, const BodyView& body, Vec3f x, float volume, float toughness,
                                 float dx, float& presence) {
  presence = 0.f;
  const Vec3f t = tip.rotation * tip.tangent;
  const Vec3f d = x - tip.position;
  const float r = kCuttingReach * dx, rho2 = dot(d, d);
  if (dot(d, t) <= 0.f || rho2 >= r * r) return Vec3f{0.f, 0.f, 0.f};
  const float q = 1.f - rho2 / (r * r);
  presence = volume * q * q / (16.f * 3.14159265f * r * r * r / 105.f);
  const float u = dot(body.velocityAt(tip.position), t);  // the tip's own speed, as a blade's
  if (u <= 0.f) return Vec3f{0.f, 0.f, 0.f};
  return (-toughness * 2.f * tip.radius * presence * fminf(u / kCuttingSpeedScale, 1.f)) * t;
}

}  // namespace mpm
