#pragma once
// A thread's segments in the grid's contact: a node is in contact with the thread's
// nearest segment only, found among the segments listed near its block.
#include "contact/part_distance.h"
#include "contact/rigid_body.h"

namespace mpm {

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

}  // namespace mpm
