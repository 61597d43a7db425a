#pragma once
// CpuExec::Binning's grid contact: the parts near each active block (findNearParts and
// its boxes), the blocks that need material centroids, the contact pass over the listed
// blocks, and the runs of thread segments it reads.

#include <algorithm>
#include <cmath>
#include <vector>

#include "backend/cpu/cpu_exec.h"

namespace mpm {

/// The parts near each active block, for the contact passes and G2P of this substep
/// (after binning and placing the parts): those whose bounds meet the block's nodes
/// grown by kNearBelow cells below and kNearAbove above (nearBox), in part order, as
/// one list per block (nearStart_, nearParts_), and G2P's shorter one of the parts
/// whose push-out boxes meet it (pushStart_, pushParts_).
///
/// Why: with every part tried everywhere, 100 small spheres on 8000 particles cost 2.6x
/// a substep without them: G2P tried each part's bounds for every particle,
/// the contact passes each part for every block, and summed nBlocks x nBodies momenta.
/// Built here once per substep, by part over the blocks its bounds reach (one block
/// lookup each), or over the active blocks for a part reaching more blocks than are
/// active (a ground plane). Each list keeps the part order, so what each node and
/// particle sees, in which order, is what it saw when every part was tried.
inline void CpuExec::Binning::findNearParts(const PartView* parts, int nParts, bool selectCentroids) {
  const size_t nActive = active_.size();
  nearPairs_.clear();
  for (int p = 0; p < nParts; ++p) {
    const PartView& part = parts[p];
    // the blocks whose box may meet the part's bounds, with a slack for the rounding (a
    // hundredth of a cell, more far from the grid's corner); the exact test decides.
    // A block of slack either side had made it 4^3 blocks for a small sphere, not 2^3.
    int first[3], last[3];
    long long range = 1;
    bool finite = true;  // bounds of NaN meet every box (mayTouch): tried on all blocks
    for (int a = 0; a < 3; ++a) {
      finite = finite && std::isfinite(part.boundsLower[a]) && std::isfinite(part.boundsUpper[a]);
      const float lo = (part.boundsLower[a] - geo_.lower[a]) * geo_.invDx, hi = (part.boundsUpper[a] - geo_.lower[a]) * geo_.invDx;
      // a block b's box spans nodes kBlockSize b - kNearBelow to kBlockSize b + kBlockSize - 1 + kNearAbove
      const float slack = 0.01f + 1e-5f * (std::fabs(lo) + std::fabs(hi));
      const float f = std::floor((lo - (float)(kBlockSize - 1 + kNearAbove) - slack) / (float)kBlockSize);
      const float l = std::floor((hi + (float)kNearBelow + slack) / (float)kBlockSize);
      first[a] = (int)std::max(0.f, std::min(f, (float)geo_.blocks[a]));
      last[a] = (int)std::max(-1.f, std::min(l, (float)geo_.blocks[a] - 1.f));
      range *= std::max(0, last[a] - first[a] + 1);
    }
    if (!finite || range > (long long)nActive) {
      for (size_t slot = 0; slot < nActive; ++slot) {
        int bx, by, bz;
        geo_.blockCoords(active_[slot], bx, by, bz);
        addNear(part, p, (uint32_t)slot, bx, by, bz);
      }
      continue;
    }
    for (int bx = first[0]; bx <= last[0]; ++bx)
      for (int by = first[1]; by <= last[1]; ++by)
        for (int bz = first[2]; bz <= last[2]; ++bz) {
          const int32_t slot = blockSlot_[geo_.blockIndex(bx, by, bz)];
          if (slot >= 0) addNear(part, p, (uint32_t)slot, bx, by, bz);
        }
  }
  // by block, stable: each block's parts stay in part order
  nearStart_.assign(nActive + 1, 0u);
  pushStart_.assign(nActive + 1, 0u);
  for (const NearPair& q : nearPairs_) {
    ++nearStart_[q.slot + 1];
    pushStart_[q.slot + 1] += q.push;
  }
  for (size_t slot = 0; slot < nActive; ++slot) {
    nearStart_[slot + 1] += nearStart_[slot];
    pushStart_[slot + 1] += pushStart_[slot];
  }
  listed_.clear();
  for (size_t slot = 0; slot < nActive; ++slot)
    if (nearStart_[slot + 1] > nearStart_[slot]) listed_.push_back((uint32_t)slot);
  nearParts_.resize(nearPairs_.size());
  pushParts_.resize(pushStart_[nActive]);
  cursor_.assign(nearStart_.begin(), nearStart_.end() - 1);
  pushCursor_.assign(pushStart_.begin(), pushStart_.end() - 1);
  for (const NearPair& q : nearPairs_) {
    nearParts_[cursor_[q.slot]++] = q.part;
    if (q.push) pushParts_[pushCursor_[q.slot]++] = NearPart{q.part, parts[q.part].pushLower, parts[q.part].pushUpper};
  }
  nearListed_ = true;
  contactsFound_ = false;  // the parts were placed anew
  centroidsSelected_ = selectCentroids;
  if (selectCentroids) selectCentroidBlocks();
}

/// The box of active block `block`'s list: its nodes grown by kNearBelow cells below
/// and kNearAbove above [m].
inline void CpuExec::Binning::nearBox(uint32_t block, Vec3f& lo, Vec3f& hi) const {
  int bx, by, bz;
  geo_.blockCoords(block, bx, by, bz);
  nearBox(bx, by, bz, lo, hi);
}

/// The same, of the block at block coordinates (bx, by, bz).
inline void CpuExec::Binning::nearBox(int bx, int by, int bz, Vec3f& lo, Vec3f& hi) const {
  Vec3f first, last;
  nodeBox(bx, by, bz, first, last);
  lo = first - ((float)kNearBelow * geo_.dx) * Vec3f{1.f, 1.f, 1.f};
  hi = first + ((float)(kBlockSize - 1 + kNearAbove) * geo_.dx) * Vec3f{1.f, 1.f, 1.f};
}

/// Lists part p for active slot `slot` (its block at bx, by, bz) if its bounds meet
/// the slot's box.
inline void CpuExec::Binning::addNear(const PartView& part, int p, uint32_t slot, int bx, int by, int bz) {
  Vec3f lo, hi;
  nearBox(bx, by, bz, lo, hi);
  if (!part.mayTouch(lo, hi)) return;
  Vec3f nodesLo, nodesHi;
  nodeBox(bx, by, bz, nodesLo, nodesHi);
  nearPairs_.push_back({slot, p, part.mayPush(lo, hi), part.mayTouch(nodesLo, nodesHi)});
}

/// The box of the nodes of the block at block coordinates (bx, by, bz) [m] (the contact
/// pass's bound on them).
inline void CpuExec::Binning::nodeBox(int bx, int by, int bz, Vec3f& lo, Vec3f& hi) const {
  lo = geo_.lower + geo_.dx * Vec3f{(float)(bx << kBlockBits), (float)(by << kBlockBits), (float)(bz << kBlockBits)};
  hi = lo + (geo_.dx * (kBlockSize - 1)) * Vec3f{1.f, 1.f, 1.f};
}

/// G2P's list for occupied block `block` (active too); none before findNearParts.
inline NearParts CpuExec::Binning::nearParts(uint32_t block) const {
  NearParts near;
  if (!nearListed_) return near;
  const int32_t slot = blockSlot_[block];
  static const NearPart kNone{};  // an empty list is still a list
  near.parts = pushParts_.empty() ? &kNone : pushParts_.data() + pushStart_[slot];
  near.count = (int)(pushStart_[slot + 1] - pushStart_[slot]);
  nearBox(block, near.lower, near.upper);
  return near;
}

/// The blocks whose nodes need their material centroids this substep (centroidSlot_)
/// and the occupied blocks whose tiles reach them (centroidRank_): the only nodes whose
/// centroid (mx, touch) anything reads are the contact pass's, in the active blocks
/// whose nodes' box meets a listed part's bounds (contactPass, the same test). P2G sums
/// the centroids there alone.
///
/// Why: the centroid is a second sum as large as the momentum's (w m x_p and w m touch_p
/// for every stencil node) and was the largest cost of 100 small spheres on the top face
/// of a box of 17576 particles (P2G 1.2x the plain scene's), though it is read only in
/// the blocks along the spheres.
inline void CpuExec::Binning::selectCentroidBlocks() {
  centroidSlot_.assign(active_.size(), 0);
  for (const NearPair& q : nearPairs_) centroidSlot_[q.slot] |= q.nodes;
  centroidRank_.assign(occupied_.size(), 0);
  for (size_t j = 0; j < occupied_.size(); ++j) {
    int c[3];
    geo_.blockCoords(occupied_[j], c[0], c[1], c[2]);
    for (int d = 0; d < 8 && !centroidRank_[j]; ++d) {  // the tile reaches the blocks d above (d in {0, 1}^3)
      const int x = c[0] + (d & 1), y = c[1] + ((d >> 1) & 1), z = c[2] + ((d >> 2) & 1);
      if (x >= geo_.blocks[0] || y >= geo_.blocks[1] || z >= geo_.blocks[2]) continue;
      const int32_t slot = blockSlot_[geo_.blockIndex(x, y, z)];
      centroidRank_[j] = slot >= 0 && centroidSlot_[slot];
    }
  }
}

/// Grid contact with rigid parts, block by block: each part near the block
/// (findNearParts) is tested against the block's bounds once, and only then against
/// its nodes. Each block sums its momentum exchange per body on its own, one sum per
/// run of the body's parts in its list (a body's parts are consecutive); the blocks'
/// sums are added in slot order, so the result does not depend on the thread count.
/// Only bodies near a block have a sum there: a block adds nothing to the others
/// (nothing but +0, which leaves a sum as it was). `out` is zeroed first; with no parts
/// (none in reach) that is all.
///
/// The nodes in contact with each listed part, and where (nodeContactGeometry), are
/// found in the first pass after the material was scattered and kept for the passes
/// that follow until the particles are binned or scattered again (contactAt_,
/// contactsBy_): only the velocities change between them. A dynamic body has four passes a substep (three
/// measuring), PB-MPM's ten cycles forty; each had looked up every node's distances
/// again (2 distances for a node near a part). The same arithmetic in the same order:
/// the same bits.
inline void CpuExec::Binning::contactPass(const PartView* parts, int nParts, const BodyView* bodies, int nBodies,
                                          ContactSums* out, int pass, ThreadTeam& pool, int threads) {
  for (int b = 0; b < nBodies; ++b) out[b] = ContactSums{};
  if (nParts == 0) return;
  if (!nearListed_) findNearParts(parts, nParts, false);
  const GridView grid = gridView();
  const size_t nActive = active_.size();
  blockSums_.resize(nearParts_.size());
  const bool find = !contactsFound_;
  if (find) {
    findSegmentRuns(parts, nParts, bodies);
    contactAt_.resize(nearParts_.size());
    if ((int)contactsBy_.size() < threads) contactsBy_.resize(threads);
    if ((int)candidatesBy_.size() < threads) candidatesBy_.resize(threads, std::vector<NodeCandidate>(kBlockNodes));
    if ((int)segmentsBy_.size() < threads) segmentsBy_.resize(threads);
    for (auto& c : contactsBy_) c.clear();
  }
  const auto block = [&](uint32_t slot, int t) {
    const uint32_t begin = nearStart_[slot], end = nearStart_[slot + 1];
    if (begin == end) return;
    int bx, by, bz;
    geo_.blockCoords(active_[slot], bx, by, bz);
    const int o[3] = {bx << kBlockBits, by << kBlockBits, bz << kBlockBits};
    Vec3f lo, hi;
    nodeBox(bx, by, bz, lo, hi);
    GridNode* nodes = grid.nodes + slot * kBlockNodes;
    // The block's nodes that take contact at all, with where their material is: asked
    // once for all the parts near the block (under 100 small spheres a block has about
    // ten). Contact changes only velocities, never these.
    NodeCandidate* candidates = find ? candidatesBy_[t].data() : nullptr;
    int nCandidates = -1;  // not yet gathered
    NearSegments near;  // a thread's segments that may be nearer to a node (nearerSegment)
    near.runFirst = runFirst_.data();
    near.runLast = runLast_.data();
    uint32_t run = begin;  // the sum of the current body's run
    for (uint32_t k = begin; k < end; ++k) {
      const int p = nearParts_[k];
      if (k == begin || parts[p].body != parts[nearParts_[k - 1]].body) {
        run = k;
        blockSums_[run] = ContactSums{};
      }
      ContactRun& at = contactAt_[k];
      if (find) {
        std::vector<NodeContact>& mine = contactsBy_[t];
        at = ContactRun{(uint32_t)mine.size(), (uint8_t)t, 0};
        if (!parts[p].mayTouch(lo, hi)) continue;
        if (nCandidates < 0) {
          nCandidates = 0;
          for (int n = 0; n < kBlockNodes; ++n) {
            const GridNode& node = nodes[n];
            const Vec3f x = geo_.lower + geo_.dx * Vec3f{(float)(o[0] + (n >> (2 * kBlockBits))),
                                                         (float)(o[1] + ((n >> kBlockBits) & kBlockMask)),
                                                         (float)(o[2] + (n & kBlockMask))};
            if (!takesContact(node, x, geo_)) continue;
            candidates[nCandidates++] = NodeCandidate{x, (1.f / node.mass) * node.mx,
                                                      materialTouches(node) ? geo_.dx : 0.f, (uint8_t)n, {}};
          }
          std::vector<int>& segments = segmentsBy_[t];
          segments.resize(end - begin);
          near.parts = segments.data();
          near.count = segmentsWithin(parts, nearParts_.data() + begin, (int)(end - begin), segment_.data(), lo, hi,
                                      segmentBand_, segments.data());
          near.reach = segmentReach_;
        }
        NodeContact g;
        for (int c = 0; c < nCandidates; ++c) {
          NodeCandidate& q = candidates[c];
          if (!parts[p].mayTouch(q.x, q.x)) continue;  // as the CUDA pass: beyond the part's reach
          near.nearest = &q.nearest;
          if (!nodeContactGeometry(q.x, q.xbar, q.touchingCell, parts, nParts, p, bodies, g, &near)) continue;
          g.node = q.node;
          mine.push_back(g);
        }
        at.count = (uint8_t)(mine.size() - at.start);  // at most kBlockNodes (64)
      }
      // the measuring pass asks only dynamic bodies (contactNodePart)
      const BodyView& body = bodies[parts[p].body];
      if (pass == 0 && !body.dynamic) continue;
      const NodeContact* contacts = contactsBy_[at.thread].data() + at.start;
      for (int c = 0; c < at.count; ++c) {
        GridNode& node = nodes[contacts[c].node];
        applyNodeContact(contacts[c], node.mass, node.mv, parts[p], body, blockSums_[run], pass);
      }
    }
  };
  // Only the blocks with parts near: they hold all the work (a slab on a ground plane:
  // its bottom layer). Each thread takes those among the active slots whose nodes it
  // summed in P2G (particleToGrid splits the slots so): their nodes are in its core's
  // cache, and the list entries it writes (contactAt_, blockSums_) lie together. Under
  // 100 spheres on 2 threads, blocks handed out one at a time took 54 + 50 us for what
  // one thread did in 59 (neighbouring entries to both threads in turn, nodes from the
  // other core's cache); split by list entries, 36 + 48 us and a pass of 54-59 us; so,
  // 47-53 us. The cost: a scene whose contact lies in one thread's slots leaves the
  // other idle, as P2G's sums do. A replay of a few thousand recorded contacts is
  // shorter than waking a thread (PB-MPM's box on the slab: ~1500 contacts, forty
  // passes a substep).
  const uint32_t nListed = (uint32_t)listed_.size();
  size_t recorded = 0;
  if (!find)
    for (const auto& c : contactsBy_) recorded += c.size();
  const bool parallel = nListed >= kMinParallelBlocks && (find || recorded >= (size_t)kMinParallel);
  pool.run(parallel ? threads : 1, [&](int t, int nt) {
    // the listed blocks among the slots P2G's sums gave this thread
    const auto from = [&](int k) -> uint32_t {
      const uint32_t slot = (uint32_t)(nActive * (size_t)k / (size_t)nt);
      return (uint32_t)(std::lower_bound(listed_.begin(), listed_.end(), slot) - listed_.begin());
    };
    for (uint32_t s = from(t), sEnd = from(t + 1); s < sEnd; ++s) block(listed_[s], t);
  });
  contactsFound_ = true;
  for (size_t slot = 0; slot < nActive; ++slot)
    for (uint32_t k = nearStart_[slot]; k < nearStart_[slot + 1]; ++k) {
      const int b = parts[nearParts_[k]].body;
      if (k > nearStart_[slot] && b == parts[nearParts_[k - 1]].body) continue;  // within the run
      const float* src = &blockSums_[k].impulse[0];
      float* dst = &out[b].impulse[0];
      for (int f = 0; f < kContactSumFloats; ++f) dst[f] += src[f];
    }
}

/// The runs of thread segments among the parts (runFirst_, runLast_: per segment its
/// run's first and last part, isThreadSegment), which parts are segments (segment_), their
/// widest band (segmentBand_) and how near a segment off a block's segmentsWithin list
/// can lie to its nodes at the least (segmentReach_, NearSegments::reach: the least bounds
/// growth, and that band), for nearerSegment's lists.
inline void CpuExec::Binning::findSegmentRuns(const PartView* parts, int nParts, const BodyView* bodies) {
  runFirst_.resize((size_t)nParts);
  runLast_.resize((size_t)nParts);
  segment_.resize((size_t)nParts);
  segmentReach_ = INFINITY;
  segmentBand_ = 0.f;
  for (int p = 0; p < nParts; ++p) {
    const bool segment = isThreadSegment(parts, nParts, p, bodies);
    segment_[p] = segment;
    runFirst_[p] = segment && isThreadSegment(parts, nParts, p - 1, bodies) ? runFirst_[p - 1] : p;
    if (!segment) continue;
    segmentReach_ = std::min(segmentReach_, parts[p].boundsGrowth);
    segmentBand_ = std::max(segmentBand_, std::max(bodies[parts[p].body].band, parts[p].band));
  }
  segmentReach_ = std::min(segmentReach_, segmentBand_);
  for (int p = nParts - 1; p >= 0; --p)
    runLast_[p] = isThreadSegment(parts, nParts, p, bodies) && isThreadSegment(parts, nParts, p + 1, bodies)
                      ? runLast_[p + 1] : p;
}

/// Whether any part's bounds (grown by its contact reach) meet the box of the active
/// blocks: if none does, no node or particle can touch a shape this substep.
inline bool CpuExec::Binning::partsReach(const PartView* parts, int nParts) const {
  if (active_.empty() || nParts == 0) return false;
  int lo[3] = {1 << 30, 1 << 30, 1 << 30}, hi[3] = {-1, -1, -1};
  for (uint32_t b : active_) {
    int c[3];
    geo_.blockCoords(b, c[0], c[1], c[2]);
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], c[a]);
      hi[a] = std::max(hi[a], c[a]);
    }
  }
  // from the first node of the lowest blocks to the last node of the highest, as the
  // contact pass bounds each block
  const Vec3f boxLo = geo_.lower + (geo_.dx * kBlockSize) * Vec3f{(float)lo[0], (float)lo[1], (float)lo[2]};
  const Vec3f boxHi = geo_.lower + geo_.dx * Vec3f{(float)(hi[0] * kBlockSize + kBlockSize - 1),
                                                   (float)(hi[1] * kBlockSize + kBlockSize - 1),
                                                   (float)(hi[2] * kBlockSize + kBlockSize - 1)};
  for (int p = 0; p < nParts; ++p)
    if (parts[p].mayTouch(boxLo, boxHi)) return true;
  return false;
}

}  // namespace mpm
