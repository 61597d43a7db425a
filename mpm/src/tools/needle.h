#pragma once
// A needle in the material: a cheap bound on its wire's distance, the shaft's friction on
// the nodes along the wire and the resistance its tip meets while it opens a track.
#include "tools/blade.h"

namespace mpm {

/// A lower bound of a needle's arc's distance at x (kPartArc) without the angle of x about
/// it (atan2f, then sinf and cosf: most of the distance's cost): the distance to the tube
/// round the whole circle, which holds the half-circle wire, less a slack for the rounding
/// of both. The needle's bounds are the box round its whole circle, so most points they
/// hold are far from the wire (a needle in a suturing scene's tissue: a fifth of its
/// particles and nodes are inside).
MPM_HD float arcLowerDistance(const PartView& q, Vec3f x) {
  const Vec3f p = transpose(q.rotation) * (x - q.position);
  const float across = sqrtf(p.x * p.x + p.y * p.y) - q.arcRadius;
  const float d = sqrtf(across * across + p.z * p.z);
  const float slack = 1e-5f * (fabsf(x.x) + fabsf(x.y) + fabsf(x.z) + fabsf(p.x) + fabsf(p.y) + fabsf(p.z) +
                               q.arcRadius + q.radius);
  return d - q.radius - slack;
}

/// A needle's shaft friction on a node near its wire: the slip along the wire, relative to
/// the wire, loses up to dt frictionRate w (never more than it has: Coulomb never reverses
/// it). Acting on the grid's velocity it is implicit, however light the node.
MPM_HD Vec3f needleShaftFriction(Vec3f v, Vec3f vRigid, Vec3f t, float rho, const PartView& part, float dt) {
  const float R = part.frictionReach;
  if (!(part.frictionRate > 0.f) || rho >= R) return v;
  const float q = 1.f - rho * rho / (R * R);
  const float slip = dot(v - vRigid, t);
  const float lose = fminf(fabsf(slip), dt * part.frictionRate * q * q);
  return v - (slip > 0.f ? lose : -lose) * t;
}

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
