#pragma once
// What the signed distance grids of mesh_sdf.cpp ask of a mesh, in double precision: the
// point of a triangle nearest a sample (Ericson), a triangle's solid angle (van Oosterom &
// Strackee), and TriangleBvh, the bounding volume hierarchy over the triangles that answers
// nearest-triangle and winding-number queries (mesh_sdf.cpp: the costs).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <utility>
#include <vector>

#include "mpm/sdf_grid.h"

namespace mpm::mesh_distance {

constexpr double kPi = 3.14159265358979323846;
constexpr uint32_t kNoNode = 0xffffffffu;
constexpr uint32_t kLeafTriangles = 4;

// ------------------------------------------------------------------ double-precision helpers
// distances and solid angles are accumulated in double: a winding number sums hundreds of
// solid angles that must cancel to an integer, and float loses that for points near the mesh
struct Vec3d {
  double x = 0, y = 0, z = 0;
  double operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
};
inline Vec3d operator+(Vec3d a, Vec3d b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3d operator-(Vec3d a, Vec3d b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3d operator*(double s, Vec3d a) { return {s * a.x, s * a.y, s * a.z}; }
inline double dot(Vec3d a, Vec3d b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3d cross(Vec3d a, Vec3d b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline double norm(Vec3d a) { return std::sqrt(dot(a, a)); }
inline Vec3d toDouble(Vec3f v) { return {v.x, v.y, v.z}; }


struct Box3d {
  Vec3d lo{+std::numeric_limits<double>::infinity(), +std::numeric_limits<double>::infinity(),
           +std::numeric_limits<double>::infinity()};
  Vec3d hi{-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
           -std::numeric_limits<double>::infinity()};
  void grow(Vec3d p) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  void grow(const Box3d& b) { grow(b.lo); grow(b.hi); }
  int longestAxis() const {
    const Vec3d e = hi - lo;
    return e.x >= e.y && e.x >= e.z ? 0 : (e.y >= e.z ? 1 : 2);
  }
  double distanceSquared(Vec3d p) const {
    // at most one of the two terms per axis is positive
    const double dx = std::max(lo.x - p.x, 0.0) + std::max(p.x - hi.x, 0.0);
    const double dy = std::max(lo.y - p.y, 0.0) + std::max(p.y - hi.y, 0.0);
    const double dz = std::max(lo.z - p.z, 0.0) + std::max(p.z - hi.z, 0.0);
    return dx * dx + dy * dy + dz * dz;
  }
  bool containsWithSlack(Vec3d p, double slack) const {
    return p.x >= lo.x - slack && p.x <= hi.x + slack && p.y >= lo.y - slack && p.y <= hi.y + slack &&
           p.z >= lo.z - slack && p.z <= hi.z + slack;
  }
};

/// A triangle with what the distance query reuses: edges, their dot products, unit normal.
struct Triangle {
  Vec3d a, b, c;
  Vec3d ab, ac, unitNormal;  // unitNormal = 0 for a degenerate (zero-area) triangle
  double abab = 0, abac = 0, acac = 0;
  Triangle() = default;
  Triangle(Vec3d a_, Vec3d b_, Vec3d c_) : a(a_), b(b_), c(c_), ab(b_ - a_), ac(c_ - a_) {
    abab = dot(ab, ab);
    abac = dot(ab, ac);
    acac = dot(ac, ac);
    const Vec3d normal = cross(ab, ac);
    const double length = norm(normal);
    unitNormal = length > 0 ? (1.0 / length) * normal : Vec3d{};
  }
};

inline Vec3d nearestOnSegment(Vec3d p, Vec3d s, Vec3d e) {
  const Vec3d d = e - s;
  const double len2 = dot(d, d);
  const double t = len2 > 0 ? std::clamp(dot(p - s, d) / len2, 0.0, 1.0) : 0.0;
  return s + t * d;
}

/// The point of triangle t nearest p and its feature (0 the face, 1 + e the edge e: ab, bc,
/// ca; 4 + v the vertex v: a, b, c): Ericson's closest point on a triangle (Real-Time
/// Collision Detection, 5.1.5), classifying p against the Voronoi regions of the vertices,
/// then the edges, else the face. All six of Ericson's dot products follow from ab.ap and
/// ac.ap and the triangle's precomputed ab.ab, ab.ac, ac.ac.
inline Vec3d closestOnTriangle(Vec3d p, const Triangle& t, int& feature) {
  const Vec3d ap = p - t.a;
  const double d1 = dot(t.ab, ap), d2 = dot(t.ac, ap);
  if (d1 <= 0 && d2 <= 0) return feature = 4, t.a;
  const double d3 = d1 - t.abab, d4 = d2 - t.abac;  // ab.bp, ac.bp
  if (d3 >= 0 && d4 <= d3) return feature = 5, t.b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return feature = 1, t.a + (d1 / (d1 - d3)) * t.ab;
  const double d5 = d1 - t.abac, d6 = d2 - t.acac;  // ab.cp, ac.cp
  if (d6 >= 0 && d5 <= d6) return feature = 6, t.c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return feature = 3, t.a + (d2 / (d2 - d6)) * t.ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return feature = 2, t.b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (t.c - t.b);
  feature = 0;
  if (va + vb + vc > 0 && dot(t.unitNormal, t.unitNormal) > 0) {
    const double denom = 1.0 / (va + vb + vc);
    return t.a + (vb * denom) * t.ab + (vc * denom) * t.ac;
  }
  // a degenerate triangle that slipped past the edge tests: nearest of its edges
  Vec3d best = t.a;
  double bestD2 = std::numeric_limits<double>::infinity();
  for (const auto& edge : {std::make_pair(t.a, t.b), std::make_pair(t.b, t.c), std::make_pair(t.c, t.a)}) {
    const Vec3d q = nearestOnSegment(p, edge.first, edge.second);
    if (dot(p - q, p - q) < bestD2) bestD2 = dot(p - q, p - q), best = q;
  }
  return best;
}

/// Squared distance from p to the triangle (closestOnTriangle).
inline double triangleDistanceSquared(Vec3d p, const Triangle& t) {
  int feature;
  const Vec3d d = p - closestOnTriangle(p, t, feature);
  return dot(d, d);
}

/// Signed solid angle of triangle abc seen from p (van Oosterom & Strackee 1983), positive
/// when p is behind a counter-clockwise (outward-facing) triangle, i.e. inside the mesh.
inline double solidAngle(Vec3d p, Vec3d a, Vec3d b, Vec3d c) {
  const Vec3d ra = a - p, rb = b - p, rc = c - p;
  const double la = norm(ra), lb = norm(rb), lc = norm(rc);
  const double numerator = dot(ra, cross(rb, rc));
  const double denominator = la * lb * lc + dot(ra, rb) * lc + dot(rb, rc) * la + dot(rc, ra) * lb;
  return 2.0 * std::atan2(numerator, denominator);
}

/// Bounding volume hierarchy over a mesh's triangles, answering nearest-triangle and
/// winding-number queries. Every node covers a contiguous range of triangles in node order.
class TriangleBvh {
 public:
  TriangleBvh(const std::vector<Vec3d>& vertices, const std::vector<uint32_t>& indices)
      : vertices_(vertices), indices_(indices) {
    const uint32_t n = static_cast<uint32_t>(indices.size() / 3);
    order_.resize(n);
    std::vector<Vec3d> centroids(n);
    std::vector<Box3d> boxes(n);
    for (uint32_t t = 0; t < n; ++t) {
      order_[t] = t;
      for (int corner = 0; corner < 3; ++corner) boxes[t].grow(vertex(t, corner));
      centroids[t] = (1.0 / 3.0) * (vertex(t, 0) + vertex(t, 1) + vertex(t, 2));
    }
    nodes_.reserve(2 * (n / kLeafTriangles + 1));
    build(0, n, centroids, boxes);
    // triangles in node order, so a leaf reads one contiguous block
    triangles_.resize(n);
    // a degenerate triangle's zero normal gives a plane bound of 0, which never rejects
    for (uint32_t s = 0; s < n; ++s)
      triangles_[s] = Triangle(vertex(order_[s], 0), vertex(order_[s], 1), vertex(order_[s], 2));
    for (Node& node : nodes_) {
      buildClosure(node);
      boundingSphere(node);
      boundingSlab(node);
    }
  }

  /// Squared distance from p to the mesh. `slot` (a position in node order) is the nearest
  /// triangle of a previous query, used as the first bound; it returns this query's nearest.
  double distanceSquared(Vec3d p, uint32_t& slot) const {
    double best = std::numeric_limits<double>::infinity();
    if (slot < triangles_.size()) best = triangleDistanceSquared(p, slot);
    // (node, squared distance to its box) pairs: a node's bound is computed once, by its parent
    struct Pending {
      uint32_t node;
      double bound;
    };
    Pending stack[128];
    int top = 0;
    stack[top++] = {0, lowerBound(nodes_[0], p)};
    while (top > 0) {
      const Pending pending = stack[--top];
      if (pending.bound >= best) continue;
      const Node& node = nodes_[pending.node];
      if (node.left == kNoNode) {
        for (uint32_t s = node.first; s < node.first + node.count; ++s) {
          // the distance to the triangle's plane is a lower bound, and nearly exact for
          // the many almost equidistant faces seen from deep inside a round mesh
          const Triangle& t = triangles_[s];
          const double plane = dot(p - t.a, t.unitNormal);
          if (plane * plane >= best) continue;
          const double d2 = triangleDistanceSquared(p, s);
          if (d2 < best) {
            best = d2;
            slot = s;
          }
        }
        continue;
      }
      const double dl = lowerBound(nodes_[node.left], p);
      const double dr = lowerBound(nodes_[node.right], p);
      // nearer child on top of the stack: it usually tightens the bound for the other
      if (dl <= dr) {
        if (dr < best) stack[top++] = {node.right, dr};
        if (dl < best) stack[top++] = {node.left, dl};
      } else {
        if (dl < best) stack[top++] = {node.left, dl};
        if (dr < best) stack[top++] = {node.right, dr};
      }
    }
    return best;
  }

  /// Generalized winding number of the mesh about p: 1 inside a closed outward mesh, 0
  /// outside, fractional near the holes of an open one.
  double windingNumber(Vec3d p) const {
    double sum = 0;
    uint32_t stack[128];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& node = nodes_[stack[--top]];
      // p outside the box or outside the bounding sphere of the node's vertices: outside a
      // convex region that holds the triangles and the closing fan
      const Vec3d fromCentre = p - node.sphereCentre;
      const bool outside = !node.box.containsWithSlack(p, boxSlack_) ||
                           dot(fromCentre, fromCentre) > node.sphereRadiusSquared;
      if (outside && node.closureCount < node.count) {
        // the node's triangles and the fan closing their boundary make a closed surface
        // inside that region, whose winding number about p is 0: the triangles' solid
        // angle is minus the fan's. Fan triangles (apex, b, a) close each boundary edge a->b.
        if (node.closureCount == 0) continue;
        const Vec3d apex = vertices_[closure_[node.closureFirst][0]];
        for (uint32_t e = node.closureFirst; e < node.closureFirst + node.closureCount; ++e)
          sum += solidAngle(p, apex, vertices_[closure_[e][0]], vertices_[closure_[e][1]]);
        continue;
      }
      if (outside || node.left == kNoNode) {
        for (uint32_t s = node.first; s < node.first + node.count; ++s)
          sum += solidAngle(p, triangles_[s].a, triangles_[s].b, triangles_[s].c);
        continue;
      }
      stack[top++] = node.left;
      stack[top++] = node.right;
    }
    return sum / (4.0 * kPi);
  }

 private:
  struct Node {
    Box3d box;
    Vec3d sphereCentre;  // a sphere holding every vertex of the node's triangles
    double sphereRadiusSquared = 0;
    // the triangles lie in the slab slabLow <= slabNormal . x <= slabHigh; for a patch of
    // a curved surface this is far tighter than the box (seen from deep inside a round mesh
    // every face is nearly equally far and only such a bound prunes them)
    Vec3d slabNormal;
    double slabLow = 0, slabHigh = 0;
    uint32_t first = 0, count = 0;             // triangles [first, first + count) in node order
    uint32_t left = kNoNode, right = kNoNode;  // children, kNoNode for a leaf
    uint32_t closureFirst = 0, closureCount = 0;  // boundary edges in closure_
  };
  Vec3d vertex(uint32_t triangle, int corner) const { return vertices_[indices_[3 * triangle + corner]]; }

  double triangleDistanceSquared(Vec3d p, uint32_t slot) const {
    return mesh_distance::triangleDistanceSquared(p, triangles_[slot]);
  }

  uint32_t build(uint32_t first, uint32_t count, const std::vector<Vec3d>& centroids,
                 const std::vector<Box3d>& boxes) {
    const uint32_t index = static_cast<uint32_t>(nodes_.size());
    nodes_.emplace_back();
    Box3d box, centroidBox;
    for (uint32_t s = first; s < first + count; ++s) {
      box.grow(boxes[order_[s]]);
      centroidBox.grow(centroids[order_[s]]);
    }
    nodes_[index].box = box;
    nodes_[index].first = first;
    nodes_[index].count = count;
    if (index == 0) boxSlack_ = 1e-9 * norm(box.hi - box.lo);
    if (count <= kLeafTriangles) return index;
    // median split on the longest axis of the centroids: balanced, so depth <= log2(n) + 1
    const int axis = centroidBox.longestAxis();
    const uint32_t half = count / 2;
    std::nth_element(order_.begin() + first, order_.begin() + first + half, order_.begin() + first + count,
                     [&](uint32_t a, uint32_t b) { return centroids[a][axis] < centroids[b][axis]; });
    const uint32_t left = build(first, half, centroids, boxes);
    const uint32_t right = build(first + half, count - half, centroids, boxes);
    nodes_[index].left = left;
    nodes_[index].right = right;
    return index;
  }

  // Squared distance from p to the node's box or its slab, whichever is farther: no
  // triangle of the node is nearer.
  static double lowerBound(const Node& node, Vec3d p) {
    const double along = dot(p, node.slabNormal);
    const double slab = std::max(node.slabLow - along, 0.0) + std::max(along - node.slabHigh, 0.0);
    return std::max(node.box.distanceSquared(p), slab * slab);
  }

  // Along the area-weighted mean normal of the node's triangles (none, i.e. a zero normal
  // and an empty bound, when they cancel out).
  void boundingSlab(Node& node) const {
    Vec3d sum;
    for (uint32_t s = node.first; s < node.first + node.count; ++s) {
      const Triangle& t = triangles_[s];
      sum = sum + cross(t.b - t.a, t.c - t.a);
    }
    const double length = norm(sum);
    if (!(length > 0)) return;
    node.slabNormal = (1.0 / length) * sum;
    node.slabLow = std::numeric_limits<double>::infinity();
    node.slabHigh = -std::numeric_limits<double>::infinity();
    for (uint32_t s = node.first; s < node.first + node.count; ++s)
      for (const Vec3d& v : {triangles_[s].a, triangles_[s].b, triangles_[s].c}) {
        node.slabLow = std::min(node.slabLow, dot(v, node.slabNormal));
        node.slabHigh = std::max(node.slabHigh, dot(v, node.slabNormal));
      }
    // rounding of the dot products: pad like the box
    node.slabLow -= 2 * boxSlack_;
    node.slabHigh += 2 * boxSlack_;
  }

  // Centred on the box, through the farthest vertex, padded like the box.
  void boundingSphere(Node& node) const {
    node.sphereCentre = 0.5 * (node.box.lo + node.box.hi);
    double radius2 = 0;
    for (uint32_t s = node.first; s < node.first + node.count; ++s)
      for (const Vec3d& v : {triangles_[s].a, triangles_[s].b, triangles_[s].c}) {
        const Vec3d d = v - node.sphereCentre;
        radius2 = std::max(radius2, dot(d, d));
      }
    const double radius = std::sqrt(radius2) + 2 * boxSlack_;
    node.sphereRadiusSquared = radius * radius;
  }

  // The node's boundary as a chain: every directed edge of its triangles, an edge a->b
  // cancelling one b->a. What remains (with multiplicity) closes into loops.
  void buildClosure(Node& node) {
    std::vector<std::pair<uint64_t, int>> edges;
    edges.reserve(3 * node.count);
    for (uint32_t s = node.first; s < node.first + node.count; ++s) {
      const uint32_t t = order_[s];
      for (int e = 0; e < 3; ++e) {
        const uint32_t a = indices_[3 * t + e], b = indices_[3 * t + (e + 1) % 3];
        if (a == b) continue;
        const uint64_t key = (uint64_t(std::min(a, b)) << 32) | std::max(a, b);
        edges.emplace_back(key, a < b ? 1 : -1);
      }
    }
    std::sort(edges.begin(), edges.end());
    node.closureFirst = static_cast<uint32_t>(closure_.size());
    for (size_t i = 0; i < edges.size();) {
      int net = 0;
      size_t j = i;
      for (; j < edges.size() && edges[j].first == edges[i].first; ++j) net += edges[j].second;
      const uint32_t lo = uint32_t(edges[i].first >> 32), hi = uint32_t(edges[i].first & 0xffffffffu);
      for (int m = 0; m < std::abs(net); ++m)
        closure_.push_back(net > 0 ? std::array<uint32_t, 2>{lo, hi} : std::array<uint32_t, 2>{hi, lo});
      i = j;
    }
    node.closureCount = static_cast<uint32_t>(closure_.size()) - node.closureFirst;
    if (node.closureCount >= node.count) {
      // no cheaper than the triangles themselves: drop it
      closure_.resize(node.closureFirst);
      node.closureCount = std::numeric_limits<uint32_t>::max();
    }
  }

  const std::vector<Vec3d>& vertices_;
  const std::vector<uint32_t>& indices_;
  std::vector<uint32_t> order_;
  std::vector<Triangle> triangles_;
  std::vector<Node> nodes_;
  std::vector<std::array<uint32_t, 2>> closure_;
  double boxSlack_ = 0;
};

}  // namespace mpm::mesh_distance
