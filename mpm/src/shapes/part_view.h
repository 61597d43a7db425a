#pragma once
// The parts of rigid shapes as the kernels see them: one primitive each, placed in a body
// (contact/rigid_body.h), with its signed distance and the boxes of the broad phase.
#include "mpm/math.h"
#include "mpm/sdf_grid.h"
#include "shapes/sdf_primitives.h"
#include "tools/tool_distances.h"

namespace mpm {

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
  /// Its body's BodyView::glueReach (placePart), where the particles see it [m].
  float glueReach = 0.f;

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

}  // namespace mpm
