#pragma once
// Particles pushed back out of the parts they ended inside, and whether they touch one.
#include "shapes/part_view.h"
#include "tools/needle.h"

namespace mpm {

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
/// of a substep), or, for a particle that `touched` a shape, within the part's glue reach.
/// Returns whether x moved.
MPM_HD bool pushOutOfPart(Vec3f& x, const PartView& part, float volume0, bool touched, bool& touch) {
  if (part.type == kPartArc) {  // surely outside the wire and beyond touch: neither (withinTouch is monotone)
    const float lower = arcLowerDistance(part, x);
    if (lower > 0.f && !withinTouch(lower, volume0)) return false;
  }
  Vec3f n;
  const float phi = part.distance(x, n);
  bool beyond = false;
  // past a needle's arc ends the tip decides (a blunt tip pushes, one inside opens)
  if (phi < 0.f && part.type == kPartArc) part.curveTangent(x, beyond);
  touch = touch || withinTouch(phi, volume0) || (touched && phi < part.glueReach);
  if (!(phi < 0.f && !beyond)) return false;
  x -= phi * n;
  return true;
}

/// Pushes a particle that ended inside a part back to its surface, the parts in order.
/// Returns whether it touches a part: lies within touchDistance(volume0) of one, or
/// `touched` one at the end of its last substep and lies within a Bonded part's glue reach
/// (PartView::glueReach). So material that touched a grip stays glued to it while it is
/// within a cell of it, and its nodes stay held (kGluedReach): glued material drifts from
/// the face under tension (the nodes beyond the held layer pull on it), and with touch
/// alone a block pulled by a Bonded plate went free once its glued particles had drifted
/// past touchDistance (force plateau from 14 % strain, none from 26 %, E A s expected).
/// The flag does not say which shape was touched: material resting on another shape within
/// a cell of a Bonded one counts as glued to it too (one float per particle, no more).
///
/// Only the parts whose push-out box holds x (mayPush): outside it a part neither pushes
/// nor touches x. With `near`, only its parts while x lies in its box: every other part's
/// push-out box misses the box, so mayPush fails for them and skipping them changes
/// nothing. Once x is outside the box (it moved there, or a push took it there) the parts
/// after the last one visited are all tried, so the result is the full loop's, bit for bit.
MPM_HD bool pushOutOfParts(Vec3f& x, const PartView* parts, int nParts, float volume0, const NearParts& near,
                           bool touched) {
  bool touch = false;
  int next = 0;  // the first part not yet visited
  if (near.parts && near.holds(x)) {
    int k = 0;
    for (; k < near.count; ++k) {
      const NearPart& q = near.parts[k];
      if (!q.mayPush(x)) continue;
      next = q.index + 1;
      if (pushOutOfPart(x, parts[q.index], volume0, touched, touch) && !near.holds(x)) break;
    }
    if (k == near.count) return touch;
  }
  for (int i = next; i < nParts; ++i)
    if (parts[i].mayPush(x, x)) pushOutOfPart(x, parts[i], volume0, touched, touch);
  return touch;
}

}  // namespace mpm
