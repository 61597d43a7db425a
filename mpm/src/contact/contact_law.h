#pragma once
// Grid contact with rigid parts (Ou and Tavakoli, CRESSim-MPM, eqs. 17-18 and, for curves,
// section IV-C): which nodes a part holds and the velocity it leaves them; the momentum it
// removes from the grid goes to the part's body (contact/rigid_body.h).
#include "contact/rigid_body.h"
#include "tools/needle.h"
#include "tools/thread.h"

namespace mpm {

/// Velocity of a grid node after contact with a body (Ou and Tavakoli, CRESSim-MPM,
/// eqs. 17-18).
/// `phi`, `n`: the node's signed distance and outward normal. Returns v unchanged when
/// the node is outside the contact band or separating (unless bonded).
MPM_HD Vec3f contactVelocity(Vec3f v, Vec3f vRigid, Vec3f n, const BodyView& b) {
  if (b.mode == kContactBonded) return vRigid;
  const Vec3f vrel = v - vRigid;
  const float vn = dot(vrel, n);
  if (vn >= 0.f) return v;  // separating
  if (b.mode == kContactSticky) return vRigid;
  const Vec3f vt = vrel - vn * n;
  const float vtLen = norm(vt);
  // Coulomb: friction only ever slows the slip, by mu_k |v_n|, never reverses it
  const float keep = vtLen > 1e-20f ? fmaxf(1.f - b.friction * fabsf(vn) / vtLen, 0.f) : 0.f;
  return vRigid + (b.drag * keep) * vt;
}

/// Velocity of a grid node in a curve's contact region (Ou and Tavakoli, CRESSim-MPM,
/// section IV-C): of its
/// velocity relative to the curve only the part along the tangent t survives, then Coulomb
/// friction (mu_k times the removed part) and drag on it; so a needle or a thread slides
/// along itself but drags the material sideways, whichever way it moves.
MPM_HD Vec3f curveVelocity(Vec3f v, Vec3f vRigid, Vec3f t, const BodyView& b) {
  const Vec3f vrel = v - vRigid;
  const Vec3f along = dot(vrel, t) * t;
  const float alongLen = norm(along), across = norm(vrel - along);
  const float keep = alongLen > 1e-20f ? fmaxf(1.f - b.friction * across / alongLen, 0.f) : 0.f;
  return vRigid + (b.drag * keep) * along;
}

/// Whether `point`, on part `p`'s surface, lies on or inside another part of the same body:
/// that face is inside a compound (two boxes meeting at a seam), not a surface of it.
/// A body's parts are consecutive in `parts`.
MPM_HD bool onSiblingPart(const PartView* parts, int nParts, int p, Vec3f point) {
  Vec3f n;
  for (int q = p - 1; q >= 0 && parts[q].body == parts[p].body; --q)
    if (parts[q].distance(point, n) <= 0.f) return true;
  for (int q = p + 1; q < nParts && parts[q].body == parts[p].body; ++q)
    if (parts[q].distance(point, n) <= 0.f) return true;
  return false;
}

/// How far outside a part a node whose material touches it (grid/block_grid.h,
/// materialTouches) is still in contact with it, in cells.
///
/// Resting material: with only the nodes inside a shape in contact, the first node layer
/// outside its surface is free while material rests on it. When that layer lies less than
/// about half a cell above the surface, no particle lies between it and the surface to hold
/// it up: the material above pushes it into the shape, the particles are pushed out again,
/// and their deformation gradients keep the compression (a 20 kPa slab on a plane 1e-6 m
/// below a node layer shortened 5.5 times the uniaxial value, 1.06 times with the plane
/// 1e-6 m above). Holding the nodes up to 0.65 dx outside keeps the slab within 0.91-1.10
/// of it wherever the surface falls (0.5 dx: up to 1.21, at the half-cell offset).
constexpr float kRestingReach = 0.65f;
/// Glued material (Bonded): a node whose material is glued to the part moves with it while
/// it lies within a cell; the 30 % touching share, not this distance, ends the contact (on
/// a lattice at rest the share falls below 30 % at 0.69 dx). With the resting reach a node
/// pulled away from a bonded plate went free at 0.65 dx while its material was still glued:
/// the glued particles slid inward with the necking material below (the compressed cylinder of Horton et al.'s MTLED
/// pulled 20 % had its top face 3 mm narrower than the plate, H/dx = 14) and the force fell
/// 4-6 % short of MTLED's, no better on finer grids.
constexpr float kGluedReach = 1.f;

/// Where a grid node meets a part, as far as positions decide it: the node, its material
/// (its mass, x-bar, touching share) and the part as placed for the substep. Only the
/// velocities change from one contact pass to the next (a dynamic body's measuring passes,
/// PB-MPM's cycles), so the CPU finds these once and applies them in every pass
/// (CpuExec::Binning::contactPass); contactNodePart does both for one node.
struct NodeContact {
  Vec3f n;       ///< the contact normal; a curve's tangent
  Vec3f c;       ///< the surface point along the normal: the rigid velocity and lever are taken there
  float rho;     ///< a curve's part: the node's distance from its centre line
  bool inBand;   ///< a curve's part: within its contact region (else only the shaft friction reaches it)
  bool beyond;   ///< a curve's part: past a needle's arc ends
  uint8_t node;  ///< CPU: the node within its block
};

/// Whether a grid node at `x` is in contact with part `p` (a curve's part: within its
/// contact region or its shaft friction's reach), and if so where (`g`).
///
/// Rigid parts, which side: a node's own signed distance cannot tell which side of a shape
/// thinner than a cell its material is on (a node on a half-cell plate's mid-plane, or none
/// inside it at all, would let material through or push it the wrong way). So the node also
/// looks from where its material is, x-bar = sum w m x_p / m. When the node and its material
/// lie on opposite sides of the shape (their normals disagree), the node is in contact if it
/// lies behind the tangent plane seen from x-bar, phi(x-bar) + n(x-bar) . (x - x-bar) <
/// band, and the normal is the one seen from x-bar. Otherwise the node's own distance
/// decides: the tangent-plane bound alone would reach nodes beside a shape's edges and hold
/// material off it. `touchingCell`: the cell size dx when the node's material touches a
/// shape (grid/block_grid.h, materialTouches), else 0; such a node is in contact up to
/// kRestingReach (kGluedReach when bonded) cells outside the part even when the body's band
/// is smaller.
///
/// Curves (kContactCurve): a node in contact with the thread's nearest segment only
/// (nearerSegment), within the curve's contact region (the band about a thin wire's centre
/// line: 0.75 dx for a needle, 1.5 dx for a thread, shapes/shape_builder.h) or a needle's
/// shaft friction's reach; past a needle's arc ends no friction (the tip's resistance is the
/// particles', needleTipResistance).
MPM_HD bool nodeContactGeometry(Vec3f x, Vec3f xbar, float touchingCell, const PartView* parts, int nParts, int p,
                                const BodyView* bodies, NodeContact& g, const NearSegments* near = nullptr) {
  const PartView& part = parts[p];
  const BodyView& b = bodies[part.body];
  Vec3f n;
  if (b.mode == kContactCurve) {
    // Most nodes within a thread segment's bounds (the grid's margin beyond the band) are
    // beyond the band: one whose distance to the segment's push-out box surely exceeds the
    // band and the shaft friction's reach is out without its distance (on a 100-link thread
    // lying on a box, four in five of the nodes asked; a needle's arc by its circle's tube).
    if (surelyFartherThan(part, x, fmaxf(fmaxf(b.band, part.band), part.frictionReach - part.radius))) return false;
    const float phi = part.distance(x, n);
    g.inBand = phi < fmaxf(b.band, part.band);
    g.rho = phi + part.radius;  // from the centre line
    if (!g.inBand && !(g.rho < part.frictionReach)) return false;
    if (nearerSegment(x, parts, nParts, p, bodies, phi, near)) return false;
    g.n = part.curveTangent(x, g.beyond);
    g.c = x - phi * n;  // the wire's surface
    return true;
  }
  Vec3f nBar;
  const float phiNode = part.distance(x, n);
  const float reach = (b.mode == kContactBonded ? kGluedReach : kRestingReach) * touchingCell;
  const float threshold = fmaxf(fmaxf(b.band, part.band), reach);
  if (part.lipschitzDistance()) {
    // Most nodes a part's bounds reach are far from it. The phi below is phiNode or
    // phiSide >= phiBar - |x - xbar| >= phiNode - 2 |x - xbar| (a Euclidean distance moves
    // no faster than its point), so a node that far beyond the threshold is out of contact
    // without looking from its material (a second distance, half of this function's time).
    // The slack covers the rounding of the distances.
    const float away = norm(x - xbar);
    const float slack = 1e-5f * (fabsf(x.x) + fabsf(x.y) + fabsf(x.z) + fabsf(phiNode) + away + threshold);
    if (phiNode - 2.f * away >= threshold + slack) return false;
  }
  const float phiBar = part.distance(xbar, nBar);
  const float phiSide = phiBar + dot(nBar, x - xbar);
  const bool otherSide = dot(n, nBar) < 0.f;
  // A node on or inside the part whose nearest face is inside the compound (on another of
  // the body's parts) while its material lies outside: the material's face decides. At the
  // seam of two boxes the side faces otherwise held a slab sideways only (0.56 of its
  // uniaxial shortening over the seam).
  const bool facesElsewhere = phiNode <= 0.f && phiBar > 0.f && phiSide < phiNode &&
                              onSiblingPart(parts, nParts, p, x - phiNode * n);
  float phi = phiNode;
  if (otherSide || facesElsewhere) {
    phi = phiSide < phiNode ? phiSide : phiNode;
    n = nBar;
  }
  if (phi >= threshold) return false;
  // The node meets the body at c, the surface point along the contact normal: the rigid
  // velocity and the lever of the momentum exchanged are taken there, not at the node. A
  // round part's normals pass through its axis, so frictionless contact cannot turn it about
  // it. With the node's own position as the lever, nodes in a thin capsule's band (up to
  // 0.75 dx off its axis, normals seen from x-bar) spun capsules resting on tissue about
  // their axis: +-5 rad/s for a 2 g rigid capsule of radius 0.2 dx, +4 to +8 rad/s for a
  // chain link on PB-MPM, which rolled it off and tipped it into the tissue.
  g.n = n;
  g.c = x - phi * n;
  g.inBand = g.beyond = false;
  return true;
}

/// The contact `g` (nodeContactGeometry) of a node of mass `mass` and velocity `v` with
/// part `part` of body `b`. Pass 0 (dynamic bodies only) measures what an immovable body
/// would take from the node without changing it; pass 1 applies the contact against the
/// body's updated velocity and records the momentum exchanged. Returns true if the node
/// touched the part (and `sums`, the part's body's, grew).
MPM_HD bool applyNodeContact(const NodeContact& g, float mass, Vec3f& v, const PartView& part, const BodyView& b,
                             ContactSums& sums, int pass) {
  const Vec3f vRigid = b.velocityAt(g.c);
  Vec3f vNew;
  if (b.mode == kContactCurve) {
    vNew = g.inBand ? curveVelocity(v, vRigid, g.n, b) : v;
    if (!g.beyond) vNew = needleShaftFriction(vNew, vRigid, g.n, g.rho, part, b.substepDt);
  } else {
    vNew = contactVelocity(v, vRigid, g.n, b);
  }
  const Vec3f dp = mass * (v - vNew);
  if (dp.x == 0.f && dp.y == 0.f && dp.z == 0.f) {
    // a curve's band node already moving with it is still held by it: its mass counts in
    // the contact mass the applying pass records (Scene::segmentContactMasses)
    if (pass == 1 && g.inBand) sums.mass += mass;
    return false;
  }
  addContact(sums, dp, g.c - b.com, mass);
  if (pass == 1) v = vNew;
  return true;
}

/// Contact of one grid node with one part (nodeContactGeometry, then applyNodeContact);
/// pass 0 asks only dynamic bodies.
MPM_HD bool contactNodePart(Vec3f x, float mass, Vec3f& v, Vec3f xbar, float touchingCell, const PartView* parts, int nParts,
                            int p, const BodyView* bodies, ContactSums& sums, int pass) {
  const BodyView& b = bodies[parts[p].body];
  if (pass == 0 && !b.dynamic) return false;
  NodeContact g;
  if (!nodeContactGeometry(x, xbar, touchingCell, parts, nParts, p, bodies, g)) return false;
  return applyNodeContact(g, mass, v, parts[p], b, sums, pass);
}

}  // namespace mpm
