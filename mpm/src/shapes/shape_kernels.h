#pragma once
// Rigid shapes as the kernels see them: bodies (rigid motion, mass, contact model) and
// parts (one primitive each, placed in a body). Grid contact follows DESIGN section 5 /
// seed 000 eqs. 17-18; the momentum it removes from the grid goes to the body.
#include "mpm/math.h"
#include "mpm/sdf_grid.h"
#include "core/symmetric3.h"
#include "shapes/sdf_primitives.h"

namespace mpm {

/// kContactCurve: a curve's (mpm/curves.h): within the contact region only the slip along
/// the curve's tangent survives (curveVelocity).
enum : int { kContactFrictional = 0, kContactSticky = 1, kContactBonded = 2, kContactCurve = 3 };
/// kPartBlade: a quad slicer's faces (sdfBladeFaces); its box is faceLower/faceUpper like a
/// Box's, with the edge at faceLower.y and `radius` the spine's (tools/blade.h).
/// kPartCurvedBlade: a mesh slicer's faces, its sided distance sampled like a Mesh part's
/// (buildBladeGrid), `bladeHalf` thick each side; the spine's axis runs from faceLower to
/// faceUpper, `radius` its radius.
/// kPartArc: a needle's wire, the arc arcRadius about the part's origin in its x-y plane
/// from arcStart to arcEnd, `radius` thick. kPartTip: its sharp tip while outside the
/// material, a blunt sphere of `radius` at the part's origin; kPartTipInside: the tip
/// inside, no surface (it opens the material: needleTipResistance). A thread's segment is a
/// kPartCapsule of a kContactCurve body. `tangent` (part frame): the tip's and the
/// segment's direction.
enum : int { kPartPlane = 0, kPartBox, kPartSphere, kPartCapsule, kPartCylinder, kPartMesh, kPartBlade, kPartCurvedBlade,
             kPartArc, kPartTip, kPartTipInside };

/// Whether a part is a slicer's blade (it cuts what it passes).
MPM_HD bool isBlade(int type) { return type == kPartBlade || type == kPartCurvedBlade; }

/// Whether boxes a and b meet (touching faces meet); a NaN bound meets everything, so a part
/// placed at NaN is tried everywhere rather than skipped.
MPM_HD bool boxesMeet(Vec3f aLo, Vec3f aHi, Vec3f bLo, Vec3f bHi) {
  return !(aHi.x < bLo.x || aLo.x > bHi.x || aHi.y < bLo.y || aLo.y > bHi.y || aHi.z < bLo.z || aLo.z > bHi.z);
}

/// The squared distance between boxes a and b (0 where they meet; a NaN bound counts as
/// meeting, as in boxesMeet).
MPM_HD float squaredGap(Vec3f aLo, Vec3f aHi, Vec3f bLo, Vec3f bHi) {
  float d2 = 0.f;
  for (int a = 0; a < 3; ++a) {
    const float below = bLo[a] - aHi[a], above = aLo[a] - bHi[a];
    const float d = below > 0.f ? below : (above > 0.f ? above : 0.f);  // NaN: 0
    d2 += d * d;
  }
  return d2;
}

/// Rigid motion and contact model of one shape.
struct BodyView {
  Vec3f com;            ///< centre of mass, world [m]
  Mat3f rotation;       ///< shape frame -> world
  Vec3f linearVelocity; ///< of the centre of mass [m/s]
  Vec3f angularVelocity;///< world [rad/s]
  Vec3f shapeOrigin;    ///< world position of the shape frame's origin [m]
  int mode = kContactFrictional;
  float friction = 0.f, drag = 1.f, band = 0.f;
  int dynamic = 0;      ///< 1: velocity responds to the grid within the step
  float mass = 0.f;     ///< [kg] (dynamic)
  Vec3f inertia;        ///< principal moments in the shape frame [kg m^2] (dynamic)
  Vec3f gravity;        ///< acceleration between substeps [m/s^2] (dynamic)
  Vec3f comLocal;       ///< centre of mass in the shape frame [m]
  Vec3f v0, w0;         ///< velocities at the start of the substep (implicit update)
  float substepDt = 0.f;///< [s] the time this exchange stands for (the substep, or PB-MPM's share of it): a needle's shaft friction acts over it
  /// Motion since the shapes were uploaded: the centre of mass's displacement, and the
  /// rotation as R(t) R(upload)^T - I. Kept apart from the pose (small numbers, exactly 0
  /// for a body at rest), they place the parts (placePart) without the float rounding of a
  /// pose far from the domain (a static ground's centre 50 m below: 4e-6 m). Summed in
  /// double, once per body per substep, so their rounding does not grow with the number of
  /// substeps whatever the lever (a float turn loses ulp(turn) x 50 m a substep).
  double travel[3] = {0, 0, 0};
  double turn[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  /// Mass and inertia about the centre of mass (xx, yy, zz, xy, xz, yz) of the nodes the
  /// first measuring pass of the substep found in contact; negative mass: not measured yet
  /// (predictBodyVelocity)
  float contactMass = -1.f;
  float contactInertia[6] = {0.f, 0.f, 0.f, 0.f, 0.f, 0.f};

  MPM_HD Vec3f velocityAt(Vec3f x) const { return linearVelocity + cross(angularVelocity, x - com); }
};

/// One primitive of a body, with its world placement and bounds for the broad phase.
///
/// Anchored: a part's frame has its origin at an anchor, a point of the part near the
/// simulation domain chosen on the host in double (a box's point nearest the domain centre,
/// a plane's foot of the perpendicular from it, a capsule's or cylinder's axis point nearest
/// it), and its geometry is given relative to that anchor. The kernels then subtract small
/// numbers near the domain: Bullet's ground, a box of half-extents 50 m centred 50 m below,
/// measured about its centre had local coordinates of 50 m near its top face (float
/// spacing 4e-6 m). Its placement follows the body from the pose it had at upload by the
/// body's travel and turn since (BodyView), so a body at rest keeps it exactly.
struct PartView {
  int type = kPartBox;
  int body = 0;
  /// Box: its faces along each axis, relative to the anchor. Capsule, cylinder: the ends
  /// of the axis segment at [axis] (the other components unused).
  Vec3f faceLower, faceUpper;
  float radius = 0.f;
  int axis = 1;
  const float* sdfValues = nullptr;  ///< (Mesh) grid values in Exec memory
  int sdfDims[3] = {0, 0, 0};
  Vec3f sdfLower;
  float sdfCell = 0.f;
  Mat3f rotation;        ///< part frame -> world, this substep
  Vec3f position;        ///< part frame origin (the anchor), world, this substep
  Vec3f boundsLower, boundsUpper;  ///< world AABB grown by the contact band and a cell
  /// The box outside which a particle can neither be pushed out of the part nor touch it
  /// (pushOutOfParts): an analytic part's own AABB grown by the particles' touch distance,
  /// within boundsLower/Upper (placePart).
  Vec3f pushLower, pushUpper;
  Mat3f uploadRotation;  ///< part frame -> world when the shapes were uploaded
  Vec3f uploadPosition;  ///< anchor, world, when the shapes were uploaded
  Vec3f lever;           ///< anchor - the body's centre of mass, world, at upload
  Vec3f localLower, localUpper;  ///< the part's bounds in its own frame (planes: large)
  /// Contact band of a part whose half-thickness is under 0.75 dx on the grid solvers,
  /// making it that thick to the grid [m]. A thinner rod (a needle, a thread link, a
  /// grasper jaw) can lie between node layers with no node inside it or within reach (from
  /// a cell-centred rod the nodes below are 0.71 dx away): a capsule of radius 0.2 dx sank
  /// 4.5 cells into soft tissue under its own weight, and still did with a 0.5 dx minimum.
  /// The cost: material rests on it as on a part of half-thickness 0.75 dx.
  float band = 0.f;
  float bladeHalf = 0.f;  ///< kPartCurvedBlade: the faces' half-thickness to the grid [m]
  float arcRadius = 0.f, arcStart = 0.f, arcEnd = 0.f;  ///< kPartArc [m, rad, rad]
  Vec3f tangent{1.f, 0.f, 0.f};  ///< kPartTip, kPartTipInside, a thread's capsule (part frame)
  /// kPartArc: the shaft's friction, as the most its slip along the wire may lose per second
  /// at a node on the centre line [m/s^2] (weighted (1 - rho^2 / R^2)^2 with rho the node's
  /// distance from the centre line, R = frictionReach [m]; needleShaftFriction)
  float frictionRate = 0.f, frictionReach = 0.f;
  /// How far the bounds reach beyond the part's own box (placePart: the grid's margin and
  /// the band) [m]: a point outside the bounds lies at least this far from an analytic part.
  float boundsGrowth = 0.f;

  /// The sided distance of a curved blade at p (part frame) and the unit normal toward p's
  /// side; false where no blade is beside p (buildBladeGrid's kNoBlade within reach).
  MPM_HD bool curvedBladeAt(Vec3f p, float& sided, Vec3f& n) const {
    Vec3f g;
    sided = sdfGridSample(sdfValues, sdfDims, sdfLower, sdfCell, p, g);
    const float len = norm(g);
    if (!(sided < 1e-10f * kNoBlade) || !(len > 1e-12f)) return false;
    n = (sided >= 0.f ? 1.f / len : -1.f / len) * g;
    return true;
  }

  /// Whether distance() is a true Euclidean signed distance, so it changes by no more than
  /// the point moves (|phi(a) - phi(b)| <= |a - b|): the analytic solids. Not sampled
  /// grids (a mesh's trilinear samples), blades or arcs with their kNoSurface regions.
  MPM_HD bool lipschitzDistance() const {
    return type == kPartPlane || type == kPartSphere || type == kPartCapsule || type == kPartCylinder ||
           type == kPartBox || type == kPartTip;
  }
  /// Signed distance [m] and outward unit normal (world) at world point x.
  MPM_HD float distance(Vec3f x, Vec3f& n) const {
    // A sphere (a tip) looks the same in every frame and a plane's distance is along one
    // axis: taken in the world frame, without the two turns into the part's frame and out
    // (most of a small sphere's cost: under 100 spheres the distance was a tenth of the
    // substep). The same values up to rounding.
    if (type == kPartSphere || type == kPartTip) return sdfSphere(x - position, radius, n);
    if (type == kPartPlane) {
      n = rotation.column(1);  // sdfPlane's normal, +y of the part's frame
      return dot(n, x - position);
    }
    const Vec3f p = transpose(rotation) * (x - position);
    Vec3f nl;
    float d;
    switch (type) {
      case kPartCapsule: d = sdfCapsule(p, radius, faceLower[axis], faceUpper[axis], axis, nl); break;
      case kPartCylinder: d = sdfCylinder(p, radius, faceLower[axis], faceUpper[axis], axis, nl); break;
      case kPartMesh: {
        d = sdfGridSample(sdfValues, sdfDims, sdfLower, sdfCell, p, nl);
        const float len = norm(nl);
        nl = len > 1e-12f ? (1.f / len) * nl : Vec3f{0.f, 1.f, 0.f};
        break;
      }
      case kPartBlade: d = sdfBladeFaces(p, faceLower, faceUpper, nl); break;
      case kPartArc: {
        Vec3f t;
        bool beyond;
        d = arcLineDistance(p, arcRadius, arcStart, arcEnd, nl, t, beyond) - radius;
        break;
      }
      case kPartTipInside: d = kNoSurface; nl = Vec3f{0.f, 1.f, 0.f}; break;
      case kPartCurvedBlade: {
        float sided;
        d = curvedBladeAt(p, sided, nl) ? fabsf(sided) - bladeHalf : kNoSurface;
        if (d == kNoSurface) nl = Vec3f{0.f, 1.f, 0.f};
        break;
      }
      case kPartBox:
      default: d = sdfBoxFaces(p, faceLower, faceUpper, nl); break;
    }
    n = rotation * nl;
    return d;
  }
  /// A curve part's unit tangent (world) at the point nearest x; `beyond`: x lies past the
  /// end of a needle's arc (its nearest point is an end).
  MPM_HD Vec3f curveTangent(Vec3f x, bool& beyond) const {
    beyond = false;
    if (type != kPartArc) return rotation * tangent;
    const Vec3f p = transpose(rotation) * (x - position);
    Vec3f n, t;
    arcLineDistance(p, arcRadius, arcStart, arcEnd, n, t, beyond);
    return rotation * t;
  }
  MPM_HD bool mayTouch(Vec3f lo, Vec3f hi) const { return boxesMeet(lo, hi, boundsLower, boundsUpper); }
  /// Whether a particle in the box lo..hi may be pushed out of the part or touch it
  /// (pushLower/Upper; a particle at x: mayPush(x, x)).
  MPM_HD bool mayPush(Vec3f lo, Vec3f hi) const { return boxesMeet(lo, hi, pushLower, pushUpper); }
};

/// Velocity of a grid node after contact with a body (seed 000 eqs. 17-18, DESIGN 5).
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

/// Velocity of a grid node in a curve's contact region (seed 000 section IV-C): of its
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

/// Momentum a node exchanges with a body, accumulated per body: the impulse on the
/// body, its moment about the body's centre of mass, and the mass and inertia of the
/// nodes in contact (the "effective mass" of the implicit velocity update).
struct ContactSums {
  float impulse[3];
  float angular[3];
  float mass;
  float inertia[6];  ///< xx, yy, zz, xy, xz, yz about the body's centre of mass
};
constexpr int kContactSumFloats = 13;

MPM_HD void addContact(ContactSums& s, Vec3f dp, Vec3f r, float m) {
  const Vec3f h = cross(r, dp);
  s.impulse[0] += dp.x; s.impulse[1] += dp.y; s.impulse[2] += dp.z;
  s.angular[0] += h.x; s.angular[1] += h.y; s.angular[2] += h.z;
  s.mass += m;
  s.inertia[0] += m * (r.y * r.y + r.z * r.z);
  s.inertia[1] += m * (r.x * r.x + r.z * r.z);
  s.inertia[2] += m * (r.x * r.x + r.y * r.y);
  s.inertia[3] -= m * r.x * r.y;
  s.inertia[4] -= m * r.x * r.z;
  s.inertia[5] -= m * r.y * r.z;
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
/// the glued particles slid inward with the necking material below (the seed 004 cylinder
/// pulled 20 % had its top face 3 mm narrower than the plate, H/dx = 14) and the force fell
/// 4-6 % short of MTLED's, no better on finer grids.
constexpr float kGluedReach = 1.f;

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

/// Whether part `q`'s distance at x (PartView::distance) is surely greater than `phi`,
/// without taking it: a part with a Euclidean distance lies inside its push-out box, so its
/// distance at x is at least x's distance to that box; the slack covers the rounding of
/// both (of the part's box, placed in floats, and of its distance). A needle's arc: its
/// circle's tube (arcLowerDistance).
MPM_HD bool surelyFartherThan(const PartView& q, Vec3f x, float phi) {
  if (q.type == kPartArc) return arcLowerDistance(q, x) > phi;
  if (!q.lipschitzDistance()) return false;
  const float d2 = squaredGap(x, x, q.pushLower, q.pushUpper);  // NaN bounds: 0, never skipped
  if (!(d2 > 0.f)) return false;  // x in the box: the part may be nearer than anything
  const float box = sqrtf(d2);
  const float slack = 1e-5f * (fabsf(x.x) + fabsf(x.y) + fabsf(x.z) + fabsf(phi) + box);
  return box - slack > phi;
}

/// The thread segments (`segment[q]`) among the parts listed near a block of nodes
/// (`listed`, `count` of them) whose push-out boxes lie within `band` of the nodes' box
/// lo..hi (plus a rounding slack), in list order, into `out`; returns how many. A node asks
/// for a nearer segment only when it is within a segment's band, so a segment farther from
/// it than the widest band cannot be nearer (nearerSegment, NearSegments::reach). Under a
/// thread lying in rows the blocks' lists held about 40 segments a walk.
MPM_HD int segmentsWithin(const PartView* parts, const int* listed, int count, const uint8_t* segment, Vec3f lo,
                          Vec3f hi, float band, int* out) {
  const float slack =
      1e-5f * (fabsf(lo.x) + fabsf(lo.y) + fabsf(lo.z) + fabsf(hi.x) + fabsf(hi.y) + fabsf(hi.z) + band);
  const float within = band + slack;
  int n = 0;
  for (int k = 0; k < count; ++k) {
    const int q = listed[k];
    // NaN bounds: a gap of 0, kept
    if (segment[q] && squaredGap(lo, hi, parts[q].pushLower, parts[q].pushUpper) < within * within) out[n++] = q;
  }
  return n;
}

/// A node's nearest segment of a thread (the first of equally near ones), once found
/// (nearerSegment): `run` is the thread's first part, -1 before.
struct NearestSegment {
  int run = -1, part = -1;
};

/// The parts near a block of grid nodes, for nearerSegment: the thread segments listed near
/// the block (in part order; segmentsWithin), per part the first and last part of its run
/// of thread segments (isThreadSegment, consecutive), `reach`: no segment off the list lies
/// nearer to a node of the block than this [m] (the least boundsGrowth of the segments, and
/// the widest band with segmentsWithin), and the node's nearest segment as far as found
/// (null: not kept).
struct NearSegments {
  const int* parts = nullptr;
  int count = 0;
  const int* runFirst = nullptr;
  const int* runLast = nullptr;
  float reach = 0.f;
  NearestSegment* nearest = nullptr;
};

/// Whether part `q` is a thread's segment (a thread's segments are consecutive capsule
/// parts of kContactCurve bodies).
MPM_HD bool isThreadSegment(const PartView* parts, int nParts, int q, const BodyView* bodies) {
  return q >= 0 && q < nParts && parts[q].type == kPartCapsule && bodies[parts[q].body].mode == kContactCurve;
}

/// Whether a node is nearer to another segment of the same thread than to segment part `p`:
/// the thread is one curve, so a node is in contact with its nearest segment only. Shared,
/// each light segment's implicit exchange counted the node's mass as its own and the
/// others' together overshot (30 segments of 2 mm at 1 g/m moving +-2 cm/s alternately:
/// velocity changes of 0.62 m/s in one 1/960 s advance). Every segment of the thread is
/// asked, not only the neighbours: the band (1.5 dx, kThreadReach) is wider than a segment,
/// so where the thread bends a node lies within the bands of segments two or more apart,
/// and with only the neighbours asked both took it (a thread drawn sideways through tissue,
/// its lead segment turned: points at 2.5 m/s).
///
/// A segment whose push-out box lies farther from the node than the node's own distance is
/// not asked (surelyFartherThan): along a 100-link thread most are, and asking each had made
/// the distance a fifth of a suturing scene's time.
///
/// `near` (the CPU's contact pass; null: none): the segments listed near the node's block.
/// A segment off the block's list has bounds that miss the node, so it lies farther than
/// their growth from it, and one listed but left out lies farther than the widest band
/// (segmentsWithin): with the node's own distance below both (NearSegments::reach, less a
/// rounding slack), only the listed segments are asked, and the nearest of them is the
/// thread's nearest segment, kept for the node's other segments (p is nearer than every
/// other exactly when it is the first of the nearest). On a 100-link thread lying on a box
/// every band node had tried all 99 other segments' boxes (surelyFartherThan alone was 13 %
/// of the run), for each of the 2-3 segments whose band holds it.
/// `own`: part p's distance at x.
MPM_HD bool nearerSegment(Vec3f x, const PartView* parts, int nParts, int p, const BodyView* bodies, float own,
                          const NearSegments* near = nullptr) {
  if (!isThreadSegment(parts, nParts, p, bodies)) return false;
  Vec3f n;
  if (near && own < near->reach - 1e-5f * (fabsf(x.x) + fabsf(x.y) + fabsf(x.z) + fabsf(own) + near->reach)) {
    const int first = near->runFirst[p], last = near->runLast[p];  // p's thread: the segments about p
    if (near->nearest && near->nearest->run == first) return near->nearest->part != p;
    int best = p;
    float bestDistance = own;
    for (int k = 0; k < near->count; ++k) {
      const int q = near->parts[k];
      if (q == p || q < first || q > last || surelyFartherThan(parts[q], x, bestDistance)) continue;
      const float d = parts[q].distance(x, n);
      if (q < best ? d <= bestDistance : d < bestDistance) {  // a tie: the earlier segment
        best = q;
        bestDistance = d;
      }
    }
    if (near->nearest) *near->nearest = NearestSegment{first, best};
    return best != p;
  }
  for (int q = p - 1; isThreadSegment(parts, nParts, q, bodies); --q)
    if (!surelyFartherThan(parts[q], x, own) && parts[q].distance(x, n) <= own) return true;  // a tie: the earlier
  for (int q = p + 1; isThreadSegment(parts, nParts, q, bodies); ++q)
    if (!surelyFartherThan(parts[q], x, own) && parts[q].distance(x, n) < own) return true;
  return false;
}

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

/// A particle touches a shape when its centre is within this of the surface: its own half
/// spacing (a particle resting on a surface sits half a spacing from it), with a quarter
/// more so that one resting there still touches while it vibrates.
MPM_HD float touchDistance(float volume0) { return 0.625f * cbrtf(volume0); }

/// phi < touchDistance(volume0), with the cube root taken only where the cubes cannot tell:
/// touchDistance^3 = 0.625^3 volume0 up to cbrtf's and the products' rounding (a few 1e-7),
/// so outside a band of 1e-4 about it the cubes give the same answer. cbrtf for every
/// particle a part's bounds hold was 2 % of the embedding scene's substep (2 threads).
MPM_HD bool withinTouch(float phi, float volume0) {
  // the cubes below stay normal floats: volumes of particles, distances in the domain
  if (!(volume0 > 1e-30f && volume0 < 1e30f && phi < 1e10f)) return phi < touchDistance(volume0);
  if (phi <= 0.f) return true;  // touchDistance > 0
  const float cube = phi * phi * phi, bound = 0.244140625f * volume0;  // 0.625^3, exact
  if (cube > 1.0001f * bound) return false;
  if (cube < 0.9999f * bound) return true;
  return phi < touchDistance(volume0);
}

/// A part in a NearParts list: its index and a copy of its push-out box (PartView::
/// pushLower, pushUpper), so a scan of the list reads 28 bytes a part, not a PartView's 296.
struct NearPart {
  int index;
  Vec3f lower, upper;

  /// PartView::mayPush on the copy (the same floats, the same answer).
  MPM_HD bool mayPush(Vec3f x) const { return boxesMeet(x, x, lower, upper); }
};

/// The parts that can reach a box of space, for the particles in it (CpuExec::Binning,
/// findNearParts: the parts in reach of a grid block's particles), in increasing index
/// order. `parts` null: no such list, every part is a candidate.
struct NearParts {
  const NearPart* parts = nullptr;
  int count = 0;
  Vec3f lower, upper;  ///< the box [m]

  MPM_HD bool holds(Vec3f x) const {
    return x.x >= lower.x && x.x <= upper.x && x.y >= lower.y && x.y <= upper.y && x.z >= lower.z && x.z <= upper.z;
  }
};

/// One part's push-out (pushOutOfParts), once its bounds meet x; `touch` set when x lies
/// within touchDistance of it (withinTouch, asked only then: cbrtf for every particle was 3 %
/// of a substep). Returns whether x moved.
MPM_HD bool pushOutOfPart(Vec3f& x, const PartView& part, float volume0, bool& touch) {
  if (part.type == kPartArc) {  // surely outside the wire and beyond touch: neither (withinTouch is monotone)
    const float lower = arcLowerDistance(part, x);
    if (lower > 0.f && !withinTouch(lower, volume0)) return false;
  }
  Vec3f n;
  const float phi = part.distance(x, n);
  bool beyond = false;
  // past a needle's arc ends the tip decides (a blunt tip pushes, one inside opens)
  if (phi < 0.f && part.type == kPartArc) part.curveTangent(x, beyond);
  touch = touch || withinTouch(phi, volume0);
  if (!(phi < 0.f && !beyond)) return false;
  x -= phi * n;
  return true;
}

/// Pushes a particle that ended inside a part back to its surface, the parts in order.
/// Returns whether it touches a part: lies within touchDistance(volume0) of one.
///
/// Only the parts whose push-out box holds x (mayPush): outside it a part neither pushes
/// nor touches x. With `near`, only its parts while x lies in its box: every other part's
/// push-out box misses the box, so mayPush fails for them and skipping them changes
/// nothing. Once x is outside the box (it moved there, or a push took it there) the parts
/// after the last one visited are all tried, so the result is the full loop's, bit for bit.
MPM_HD bool pushOutOfParts(Vec3f& x, const PartView* parts, int nParts, float volume0, const NearParts& near) {
  bool touch = false;
  int next = 0;  // the first part not yet visited
  if (near.parts && near.holds(x)) {
    int k = 0;
    for (; k < near.count; ++k) {
      const NearPart& q = near.parts[k];
      if (!q.mayPush(x)) continue;
      next = q.index + 1;
      if (pushOutOfPart(x, parts[q.index], volume0, touch) && !near.holds(x)) break;
    }
    if (k == near.count) return touch;
  }
  for (int i = next; i < nParts; ++i)
    if (parts[i].mayPush(x, x)) pushOutOfPart(x, parts[i], volume0, touch);
  return touch;
}

/// World inertia tensor of a body as xx, yy, zz, xy, xz, yz.
MPM_HD void worldInertia(const BodyView& b, float out[6]) {
  const Mat3f& R = b.rotation;
  Mat3f I;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      I.m[i][j] = R.m[i][0] * b.inertia.x * R.m[j][0] + R.m[i][1] * b.inertia.y * R.m[j][1] +
                  R.m[i][2] * b.inertia.z * R.m[j][2];
  out[0] = I.m[0][0]; out[1] = I.m[1][1]; out[2] = I.m[2][2];
  out[3] = I.m[0][1]; out[4] = I.m[0][2]; out[5] = I.m[1][2];
}

/// exp([w dt]x) - I (Rodrigues), the change of a rotation over dt; false (and E untouched)
/// when the angle is negligible.
MPM_HD bool rotationChange(Vec3f w, float dt, Mat3f& E) {
  const float angle = norm(w) * dt;
  if (angle < 1e-12f) return false;
  const Vec3f k = (1.f / norm(w)) * w;
  // 1 - cos as 2 sin^2(angle / 2): cosf of a small angle rounds to 1 (below 3e-4 rad), which
  // dropped the second-order term of every substep's rotation (a face 50 m from the centre
  // of mass drifted 5e-7 m in 200 substeps at 0.01 rad/s)
  const float s = sinf(angle), h = sinf(0.5f * angle), oneMinusCos = 2.f * h * h;
  Mat3f K;
  K.m[0][1] = -k.z; K.m[0][2] = k.y; K.m[1][0] = k.z; K.m[1][2] = -k.x; K.m[2][0] = -k.y; K.m[2][1] = k.x;
  E = s * K + oneMinusCos * (K * K);
  return true;
}

/// R <- exp([w dt]x) R (Rodrigues), integrating a body's orientation inside a step.
MPM_HD Mat3f rotateBy(const Mat3f& R, Vec3f w, float dt) {
  Mat3f E;
  if (!rotationChange(w, dt, E)) return R;
  return (Mat3f::identity() + E) * R;
}

}  // namespace mpm

namespace mpm {

/// Implicit velocity prediction of a dynamic body from pass 0: the body and the nodes it
/// touches move on together, V' = V + J / (M + M_c), w' = w + (I + I_c)^-1 H. With the
/// nodes then projected against V', a body lighter than the tissue it touches receives
/// M / (M + M_c) of the momentum an immovable body would: no overshoot, no oscillation.
/// Repeated, pass 0 measuring against the last prediction, it is a chord step on the
/// body's momentum balance M (V - v0) = J(V), J(V) what the nodes give a body moving at V:
/// V += (J(V) - M (V - v0)) / (M + M_c), with the M_c (and I_c) of the first pass. Not
/// Newton's M_c(V): nodes that move with a predicted body do not approach it, M_c(V) falls
/// toward zero and the step throws the body back toward v0 (with two Newton steps 0.2 g
/// capsules fell through a 6-cell block on standard MPM; the first pass's contact mass,
/// the largest, does not overshoot).
MPM_HD void predictBodyVelocity(BodyView& b, const ContactSums& s) {
  if (!b.dynamic) return;
  if (b.contactMass < 0.f) {
    b.contactMass = s.mass;
    for (int k = 0; k < 6; ++k) b.contactInertia[k] = s.inertia[k];
  }
  const Vec3f J{s.impulse[0], s.impulse[1], s.impulse[2]};
  b.linearVelocity =
      b.linearVelocity + (1.f / (b.mass + b.contactMass)) * (J - b.mass * (b.linearVelocity - b.v0));
  if (b.mode == kContactCurve) return;  // a thread's segment does not turn in the scene (settleBodyVelocity)
  float I[6];
  worldInertia(b, I);
  const Vec3f H = Vec3f{s.angular[0], s.angular[1], s.angular[2]} - symmetricTimes(I, b.angularVelocity - b.w0);
  for (int k = 0; k < 6; ++k) I[k] += b.contactInertia[k];
  b.angularVelocity = b.angularVelocity + inverseSymmetric(I) * H;
}

/// Steps of the prediction per substep (predictBodyVelocity). One is exact while the nodes
/// touching the body stay the same, but contact cannot pull: nodes that approached the
/// immovable body of pass 0 and separate from the predicted one give nothing in pass 1,
/// and a body much lighter than those nodes then settles far from its prediction (a 0.2 g
/// capsule dropped on a 30 kPa block, standard MPM, M_c / M = 6.5: predicted w -0.30 rad/s,
/// settled 18 rad/s; in another substep V predicted near rest, settled +0.75 m/s). Such
/// kicks spun it to 138 rad/s and threw it 2.7 cells up; on PB-MPM (ten exchanges a
/// substep) one stood on its end and blew the tissue up (J = -17 at 2.3 s). Measured in
/// ThinCapsules (0.2 g capsules of radius 0.2 / 0.4 / 0.6 dx, bottom above the block's
/// top): one step, standard MPM -6.1 (fell through) / -0.17 / -0.26 dx, PB-MPM 0.6 dx
/// -0.38 dx; two: 0.36 / 0.16 / -0.24 dx; three: 0.36 / 0.16 / -0.04 dx, PB-MPM -0.04 dx.
constexpr int kBodyPredictionSteps = 3;

/// Before the contact passes: the substep's length `dt`, a dynamic body's gravity for it (none for `gravityDt` 0),
/// then the velocities its exchange starts from (v0, w0). Gravity must come before the
/// contact so the contact can take it back; added after, a resting body would step
/// g dt^2 into the tissue every substep (measured: 3.4 mm/s of steady sinking).
MPM_HD void startBodyExchange(BodyView& b, float dt, float gravityDt) {
  b.substepDt = dt;
  if (!b.dynamic) return;
  b.linearVelocity += gravityDt * b.gravity;
  b.v0 = b.linearVelocity;
  b.w0 = b.angularVelocity;
  b.contactMass = -1.f;
}

/// After pass 1: the body's velocity from the momentum it actually received (so total
/// momentum is conserved exactly). Returns the angular impulse the body took.
///
/// A thread's segment (a dynamic kContactCurve body) is not turned by the material inside
/// the scene, and takes no angular impulse from it: its turn is its chain's (Bullet's
/// joints, set before each advance from its points' velocities); the material acts on the
/// chain through each segment's linear impulse, so a bend along the thread is resisted
/// segment by segment. Measured: the angular impulse of the unturning segment, I_c / I
/// times what the segment can take (hundreds: 2.5 mm at 0.05 g/m is 6.5e-14 against ~3e-11
/// kg m^2 of nodes), handed to its Bullet link whipped the chain at 8 m/s within 3 ticks
/// (a thread pinned to a holder drawn sideways through tissue); turning the segment in the
/// scene, predicted or settled (w0 + I^-1 H), made its linear exchange blow up within a
/// tick (1e3 m/s: the nodes' answer to a turn is not the one the prediction assumes); the
/// implicit share I (I + I_c)^-1 H given every substep drove the links 1.4 times faster
/// than the block dragging them. The angular impulse the material got from a segment is
/// angular momentum not conserved; linear momentum is, exactly.
MPM_HD Vec3f settleBodyVelocity(BodyView& b, const ContactSums& s) {
  const Vec3f H{s.angular[0], s.angular[1], s.angular[2]};
  if (!b.dynamic) return H;
  b.linearVelocity = b.v0 + (1.f / b.mass) * Vec3f{s.impulse[0], s.impulse[1], s.impulse[2]};
  if (b.mode == kContactCurve) return Vec3f{0.f, 0.f, 0.f};
  float I[6];
  worldInertia(b, I);
  b.angularVelocity = b.w0 + inverseSymmetric(I) * H;
  return H;
}

/// At the end of a substep: the body's pose advanced by dt at its velocity.
MPM_HD void moveBody(BodyView& b, float dt) {
  b.com += dt * b.linearVelocity;
  for (int i = 0; i < 3; ++i) b.travel[i] += (double)dt * (double)b.linearVelocity[i];
  Mat3f E;
  if (rotationChange(b.angularVelocity, dt, E)) {
    b.rotation = (Mat3f::identity() + E) * b.rotation;
    double next[3][3];  // (I + E)(I + turn) - I
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        double v = b.turn[i][j] + (double)E.m[i][j];
        for (int k = 0; k < 3; ++k) v += (double)E.m[i][k] * b.turn[k][j];
        next[i][j] = v;
      }
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) b.turn[i][j] = next[i][j];
  }
  b.shapeOrigin = b.com - b.rotation * b.comLocal;
}

/// World placement and bounds of a part: its placement at upload moved with its body since
/// (a point fixed in the body goes to x0 + travel + turn (x0 - com0)). Small numbers near
/// the domain, exact for a body at rest. `margin`: the grid's reach beyond the bounds;
/// `touchReach`: the largest touchDistance of the particles (infinite: none known).
MPM_HD void placePart(PartView& p, const BodyView& b, float margin, float touchReach) {
  Mat3f turn;
  Vec3f move;
  for (int i = 0; i < 3; ++i) {
    double m = b.travel[i];
    for (int k = 0; k < 3; ++k) {
      m += b.turn[i][k] * (double)p.lever[k];
      turn.m[i][k] = (float)b.turn[i][k];
    }
    move[i] = (float)m;
  }
  p.rotation = p.uploadRotation + turn * p.uploadRotation;
  p.position = p.uploadPosition + move;
  Vec3f lo{3.4e38f, 3.4e38f, 3.4e38f}, hi{-3.4e38f, -3.4e38f, -3.4e38f};
  for (int c = 0; c < 8; ++c) {
    const Vec3f corner{(c & 1) ? p.localUpper.x : p.localLower.x, (c & 2) ? p.localUpper.y : p.localLower.y,
                       (c & 4) ? p.localUpper.z : p.localLower.z};
    const Vec3f w = p.position + p.rotation * corner;
    for (int a = 0; a < 3; ++a) {  // fminf / fmaxf (a NaN corner is skipped), inline: not a libm call each
      lo[a] = w[a] < lo[a] ? w[a] : lo[a];
      hi[a] = w[a] > hi[a] ? w[a] : hi[a];
    }
  }
  const float grow = margin + fmaxf(fmaxf(b.band, p.band), 0.f);
  p.boundsLower = lo - Vec3f{grow, grow, grow};
  p.boundsUpper = hi + Vec3f{grow, grow, grow};
  p.boundsGrowth = grow;
  // A particle sees an analytic part's own surface (its distance, not the grid's band), so
  // it is pushed or touches only within touchReach of the part's own box; the slack covers
  // the rounding of the box and of the distance (a few float spacings of the coordinates
  // and extents involved). The grid's bounds had been used: under 100 small spheres each
  // top particle was tried against about twelve, a third of what the spheres cost G2P.
  // Never beyond the grid's bounds, which the blocks' part lists are made from.
  float push = grow;
  if (p.lipschitzDistance()) {
    float scale = fmaxf(fmaxf(fabsf(p.position.x), fabsf(p.position.y)), fabsf(p.position.z));
    if (p.type != kPartPlane)  // a plane's extents are unbounded: its distance is along its normal
      for (int a = 0; a < 3; ++a) scale = fmaxf(scale, fmaxf(fabsf(p.localLower[a]), fabsf(p.localUpper[a])));
    push = fminf(grow, 1.001f * touchReach + 1e-5f * scale);
  }
  p.pushLower = lo - Vec3f{push, push, push};
  p.pushUpper = hi + Vec3f{push, push, push};
}

}  // namespace mpm
