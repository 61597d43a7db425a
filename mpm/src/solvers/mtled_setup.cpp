// MTLED preprocessing on the host (Joldes et al., section 2.1, steps 3-4; sections 2.3-2.5,
// 3.3): support domains of the n nearest nodes, MLS shape-function derivatives, lumped
// masses, removal of nodes in fewer than two support domains, the critical time step. Eigen
// (double precision) for the small moment-matrix solves; runs once per change of the nodes.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <sstream>

#include "core/validate.h"
#include "solvers/mtled.h"

namespace mpm {

namespace {

/// Nearest-node queries over a set of nodes, bucketed in a uniform grid of cells about one
/// node spacing wide.
class NodeBuckets {
 public:
  NodeBuckets(const std::vector<Vec3f>& X, const std::vector<uint32_t>& nodes) : X_(X) {
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::max()), hi = -lo;
    for (uint32_t i : nodes)
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], (double)X[i][a]);
        hi[a] = std::max(hi[a], (double)X[i][a]);
      }
    const Eigen::Vector3d size = (hi - lo).cwiseMax(1e-9);
    // a cell per node on average (about the node spacing), but never a table much larger
    // than the node count
    cell_ = std::max(std::cbrt(size.prod() / std::max<size_t>(nodes.size(), 1)), size.maxCoeff() / 256.0);
    lower_ = lo;
    for (int a = 0; a < 3; ++a) dims_[a] = (int)(size[a] / cell_) + 1;
    start_.assign((size_t)dims_[0] * dims_[1] * dims_[2] + 1, 0);
    for (uint32_t i : nodes) start_[cellOf(X[i]) + 1]++;
    for (size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
    entries_.resize(nodes.size());
    std::vector<uint32_t> cursor(start_.begin(), start_.end() - 1);
    for (uint32_t i : nodes) entries_[cursor[cellOf(X[i])]++] = i;
  }

  /// The k nodes nearest to q (all, if fewer), nearest first (ties by node index, so the
  /// result does not depend on the order of the search).
  void nearest(Vec3f q, int k, std::vector<std::pair<double, uint32_t>>& out) const {
    out.clear();
    int c[3];
    for (int a = 0; a < 3; ++a) c[a] = (int)std::floor((q[a] - lower_[a]) / cell_);
    const int maxRing = std::max({dims_[0], dims_[1], dims_[2]}) +
                        std::max({std::abs(c[0]), std::abs(c[1]), std::abs(c[2])}) + 1;
    for (int r = 0; r <= maxRing; ++r) {
      for (int i = c[0] - r; i <= c[0] + r; ++i)
        for (int j = c[1] - r; j <= c[1] + r; ++j)
          for (int l = c[2] - r; l <= c[2] + r; ++l) {
            if (std::max({std::abs(i - c[0]), std::abs(j - c[1]), std::abs(l - c[2])}) != r) continue;
            if (i < 0 || j < 0 || l < 0 || i >= dims_[0] || j >= dims_[1] || l >= dims_[2]) continue;
            const size_t cell = ((size_t)i * dims_[1] + j) * dims_[2] + l;
            for (uint32_t e = start_[cell]; e < start_[cell + 1]; ++e) {
              const uint32_t n = entries_[e];
              const Vec3f d = X_[n] - q;
              out.push_back({(double)d.x * d.x + (double)d.y * d.y + (double)d.z * d.z, n});
            }
          }
      if ((int)out.size() < k) continue;
      std::partial_sort(out.begin(), out.begin() + k, out.end());
      out.resize(k);
      // every node in a farther ring is at least r cells away
      const double reach = r * cell_;
      if (out.back().first <= reach * reach) return;
    }
    std::sort(out.begin(), out.end());  // fewer than k nodes in all: all of them
  }

 private:
  size_t cellOf(Vec3f x) const {
    int c[3];
    for (int a = 0; a < 3; ++a) c[a] = std::min(dims_[a] - 1, std::max(0, (int)((x[a] - lower_[a]) / cell_)));
    return ((size_t)c[0] * dims_[1] + c[1]) * dims_[2] + c[2];
  }

  const std::vector<Vec3f>& X_;
  Eigen::Vector3d lower_;
  double cell_ = 1;
  int dims_[3] = {1, 1, 1};
  std::vector<uint32_t> start_, entries_;
};

/// Quartic spline weight of eq. 7 and its derivative in q = distance / r.
double quarticWeight(double q) { return q >= 1 ? 0 : 1 - 6 * q * q + 8 * q * q * q - 3 * q * q * q * q; }
double quarticWeightSlope(double q) { return q >= 1 ? 0 : -12 * q + 24 * q * q - 12 * q * q * q; }

/// Whether a moment matrix (symmetric, of order one) can be inverted: its eigenvalues, not
/// the LU's condition estimate, which exactly coplanar nodes fool.
template <class Matrix>
bool wellConditioned(const Matrix& A) {
  const Eigen::SelfAdjointEigenSolver<Matrix> eigen(A, Eigen::EigenvaluesOnly);
  const auto& lambda = eigen.eigenvalues();  // ascending
  return lambda(0) >= 1e-9 * lambda(lambda.size() - 1);
}

/// Values phi_i (if `values`) and derivatives d phi_i / dx (if `gradients`) at x0 of the
/// MLS shape functions (eqs. 7-8, 18-25) with the linear basis p = (1, x, y, z), over the
/// given support nodes, nearest first. Coordinates are taken relative to x0 and scaled by
/// the farthest node's distance s, so the moment matrix is of order one whatever the units.
/// False (nothing written) if the moment matrix is singular: the nodes are coplanar.
bool mlsShapeFunctions(Vec3f x0, const std::vector<Vec3f>& X, const std::vector<std::pair<double, uint32_t>>& support,
                       double alpha, double* values, Eigen::Vector3d* gradients) {
  const int n = (int)support.size();
  const double s = std::sqrt(support.back().first);
  if (!(s > 0)) throw Error("MTLED: an integration point's support nodes all coincide with it");
  std::vector<Eigen::Vector4d> p(n);
  std::vector<double> w(n);
  std::vector<Eigen::Vector3d> dw(n);
  Eigen::Matrix4d A = Eigen::Matrix4d::Zero();
  Eigen::Matrix4d dA[3] = {Eigen::Matrix4d::Zero(), Eigen::Matrix4d::Zero(), Eigen::Matrix4d::Zero()};
  for (int i = 0; i < n; ++i) {
    const Vec3f d = X[support[i].second] - x0;
    const Eigen::Vector3d xi = Eigen::Vector3d(d.x, d.y, d.z) / s;
    p[i] << 1, xi;
    const double dist = xi.norm(), q = dist / alpha;  // r = alpha * s (eq. 8)
    w[i] = quarticWeight(q);
    // d W / d x at x0: W'(q) dq/dx, dq/dx = (x0 - x_i) / (|x0 - x_i| r)
    dw[i] = dist > 0 ? Eigen::Vector3d(quarticWeightSlope(q) * -xi / (dist * alpha)) : Eigen::Vector3d::Zero();
    A += w[i] * p[i] * p[i].transpose();
    for (int k = 0; k < 3; ++k) dA[k] += dw[i][k] * p[i] * p[i].transpose();
  }
  if (!wellConditioned(A)) return false;
  const Eigen::FullPivLU<Eigen::Matrix4d> lu(A);
  const Eigen::Vector4d gamma = lu.solve(Eigen::Vector4d(1, 0, 0, 0));  // A^-1 p(x0)
  if (values)
    for (int i = 0; i < n; ++i) values[i] = w[i] * gamma.dot(p[i]);
  if (!gradients) return true;
  for (int k = 0; k < 3; ++k) {
    // d gamma / d x_k = A^-1 (d p / d x_k - dA_k gamma)
    const Eigen::Vector4d dgamma = lu.solve(Eigen::Vector4d::Unit(k + 1) - dA[k] * gamma);
    for (int i = 0; i < n; ++i) gradients[i][k] = (w[i] * dgamma.dot(p[i]) + dw[i][k] * gamma.dot(p[i])) / s;
  }
  return true;
}

/// The error for a point whose moment matrix stays singular.
Error singular(Vec3f x, size_t nodes) {
  std::ostringstream m;
  m << "MTLED: the moment matrix at " << validate::show(x) << " is singular (its " << nodes
    << " support nodes are nearly coplanar); use more support nodes";
  return Error(m.str());
}

/// Shape-function derivatives of one node, summed over the terms that name it.
struct NodeGradients {
  std::vector<uint32_t> nodes;
  std::vector<Eigen::Vector3d> gradients;
  void clear() {
    nodes.clear();
    gradients.clear();
  }
  void add(uint32_t node, const Eigen::Vector3d& g) {
    const auto it = std::find(nodes.begin(), nodes.end(), node);
    if (it != nodes.end()) {
      gradients[it - nodes.begin()] += g;
      return;
    }
    nodes.push_back(node);
    gradients.push_back(g);
  }
};

}  // namespace

IntegrationCells integrationCells(const std::function<bool(Vec3f)>& inside, Vec3f lo, Vec3f hi, float cellSize) {
  constexpr int kVoxels = 4;  // per axis and cell
  int n[3];
  Vec3f h, voxel;
  for (int a = 0; a < 3; ++a) {
    n[a] = std::max(1, (int)std::lround((hi[a] - lo[a]) / cellSize));
    h[a] = (hi[a] - lo[a]) / n[a];
    voxel[a] = h[a] / kVoxels;
  }
  const auto voxelCentre = [&](const int g[3]) {
    return Vec3f{lo.x + (g[0] + 0.5f) * voxel.x, lo.y + (g[1] + 0.5f) * voxel.y, lo.z + (g[2] + 0.5f) * voxel.z};
  };
  const auto cellIndex = [&](const int c[3]) { return ((size_t)c[0] * n[1] + c[1]) * n[2] + c[2]; };
  const auto bit = [](const int v[3]) { return uint64_t(1) << ((v[0] * kVoxels + v[1]) * kVoxels + v[2]); };

  // the inside voxels of every cell; a point per cell that has any
  const size_t nCells = (size_t)n[0] * n[1] * n[2];
  std::vector<uint64_t> mask(nCells, 0);
  std::vector<int64_t> pointOf(nCells, -1);
  IntegrationCells out;
  const float voxelVolume = voxel.x * voxel.y * voxel.z;
  int c[3], v[3], g[3];
  for (c[0] = 0; c[0] < n[0]; ++c[0])
    for (c[1] = 0; c[1] < n[1]; ++c[1])
      for (c[2] = 0; c[2] < n[2]; ++c[2]) {
        Vec3f sum{0.f, 0.f, 0.f};
        int count = 0;
        uint64_t m = 0;
        for (v[0] = 0; v[0] < kVoxels; ++v[0])
          for (v[1] = 0; v[1] < kVoxels; ++v[1])
            for (v[2] = 0; v[2] < kVoxels; ++v[2]) {
              for (int a = 0; a < 3; ++a) g[a] = c[a] * kVoxels + v[a];
              const Vec3f x = voxelCentre(g);
              if (!inside(x)) continue;
              m |= bit(v);
              sum += x;
              count++;
            }
        if (count == 0) continue;
        mask[cellIndex(c)] = m;
        pointOf[cellIndex(c)] = (int64_t)out.points.size();
        out.points.push_back((1.f / count) * sum);
        out.volumes.push_back(voxelVolume * count);
      }

  // The surface of each cell's voxels, as quadrature points lumped so that the integral of
  // u n over it is exact for affine u (each group at the centroid of its voxel faces):
  // per cell and direction the faces on the material's surface; per pair of cells the
  // faces they share, the same point for both (so they cancel in a sum over the cells).
  struct SurfacePoint {
    size_t cell;
    Vec3f x, area;
  };
  std::vector<SurfacePoint> surface;
  for (c[0] = 0; c[0] < n[0]; ++c[0])
    for (c[1] = 0; c[1] < n[1]; ++c[1])
      for (c[2] = 0; c[2] < n[2]; ++c[2]) {
        const size_t cell = cellIndex(c);
        if (pointOf[cell] < 0) continue;
        Vec3f outerSum[3][2] = {}, sharedSum[3] = {};
        int outerCount[3][2] = {}, sharedCount[3] = {};
        for (v[0] = 0; v[0] < kVoxels; ++v[0])
          for (v[1] = 0; v[1] < kVoxels; ++v[1])
            for (v[2] = 0; v[2] < kVoxels; ++v[2]) {
              if (!(mask[cell] & bit(v))) continue;
              for (int a = 0; a < 3; ++a) g[a] = c[a] * kVoxels + v[a];
              const Vec3f x = voxelCentre(g);
              for (int a = 0; a < 3; ++a)
                for (int side = 0; side < 2; ++side) {
                  // the voxel across this face: in this cell, in the next one, or beyond the box
                  int w[3] = {v[0], v[1], v[2]}, d[3] = {c[0], c[1], c[2]};
                  w[a] += side ? 1 : -1;
                  if (w[a] < 0 || w[a] >= kVoxels) {
                    d[a] += side ? 1 : -1;
                    w[a] = (w[a] + kVoxels) % kVoxels;
                  }
                  const bool beyond = d[a] < 0 || d[a] >= n[a];
                  if (!beyond && (mask[cellIndex(d)] & bit(w))) {
                    // material across: inside the cell, or a face shared with the next cell
                    // (taken from the cell below it only)
                    if (d[a] != c[a] && side) {
                      sharedSum[a] += x;
                      sharedCount[a]++;
                    }
                    continue;
                  }
                  outerSum[a][side] += x;
                  outerCount[a][side]++;
                }
            }
        for (int a = 0; a < 3; ++a) {
          Vec3f offset{0.f, 0.f, 0.f}, normal{0.f, 0.f, 0.f};
          offset[a] = 0.5f * voxel[a];
          normal[a] = 1.f;
          const float faceArea = voxelVolume / voxel[a];
          for (int side = 0; side < 2; ++side) {
            if (outerCount[a][side] == 0) continue;
            const float sign = side ? 1.f : -1.f;
            surface.push_back({cell, (1.f / outerCount[a][side]) * outerSum[a][side] + sign * offset,
                               (sign * faceArea * outerCount[a][side]) * normal});
          }
          if (sharedCount[a] == 0) continue;
          int d[3] = {c[0], c[1], c[2]};
          d[a]++;
          const Vec3f x = (1.f / sharedCount[a]) * sharedSum[a] + offset, area = (faceArea * sharedCount[a]) * normal;
          surface.push_back({cell, x, area});
          surface.push_back({cellIndex(d), x, -1.f * area});
        }
      }
  // in point order
  out.surfaceStart.assign(out.points.size() + 1, 0);
  for (const SurfacePoint& q : surface) out.surfaceStart[pointOf[q.cell] + 1]++;
  for (size_t p = 0; p < out.points.size(); ++p) out.surfaceStart[p + 1] += out.surfaceStart[p];
  out.surfacePoints.resize(surface.size());
  out.surfaceAreas.resize(surface.size());
  std::vector<uint32_t> cursor(out.surfaceStart.begin(), out.surfaceStart.end() - 1);
  for (const SurfacePoint& q : surface) {
    const uint32_t t = cursor[pointOf[q.cell]]++;
    out.surfacePoints[t] = q.x;
    out.surfaceAreas[t] = q.area;
  }
  return out;
}

std::vector<Mat3f> nodeDeformationGradients(const MtledModel& m, const std::vector<Vec3f>& x,
                                            const std::vector<Vec3f>& X,
                                            const std::function<void(size_t, const Mat3f&)>& perPoint) {
  std::vector<Mat3f> F(x.size());
  std::vector<float> weight(x.size(), 0.f);
  for (size_t p = 0; p < m.volumes.size(); ++p) {
    const Mat3f Fp = kernels::pointDeformationGradient(p, x.data(), X.data(), m.termStart.data(), m.support.data(),
                                                       m.shapeGradients.data());
    if (perPoint) perPoint(p, Fp);
    for (uint32_t t = m.termStart[p]; t < m.termStart[p + 1]; ++t) {
      F[m.support[t]] = F[m.support[t]] + m.volumes[p] * Fp;
      weight[m.support[t]] += m.volumes[p];
    }
  }
  for (size_t i = 0; i < F.size(); ++i) F[i] = weight[i] > 0.f ? (1.f / weight[i]) * F[i] : Mat3f::identity();
  for (size_t i = 0; i < F.size(); ++i) F[i] = F[m.carrier[i]];  // a carrier carries itself
  return F;
}

MtledModel buildMtledModel(const MtledSettings& settings, const std::vector<Vec3f>& X,
                           const std::vector<uint32_t>& nodeObject, const IntegrationCells& cells,
                           const std::vector<uint32_t>& pointObject, const std::vector<MaterialParams>& materials) {
  const int n = settings.supportNodes;
  const size_t nNodes = X.size(), nPoints = cells.size();
  MtledModel m;
  m.supportNodes = n;
  m.criticalTimeStep = std::numeric_limits<float>::infinity();
  uint32_t objects = 0;
  for (uint32_t o : nodeObject) objects = std::max(objects, o + 1);
  for (uint32_t o : pointObject) objects = std::max(objects, o + 1);
  const auto keptNodes = [&](uint32_t o, const std::vector<uint8_t>& kept) {
    std::vector<uint32_t> nodes;  // objects never share a support
    for (uint32_t i = 0; i < nNodes; ++i)
      if (nodeObject[i] == o && kept[i]) nodes.push_back(i);
    return nodes;
  };

  // support domains: the n nearest nodes of each point; nodes in fewer than two of them
  // are dropped and the search redone (section 3.2), since a node held by one point alone
  // has unbalanced forces
  std::vector<uint8_t> kept(nNodes, 1);
  std::vector<std::pair<double, uint32_t>> near;
  std::vector<int> domains(nNodes);
  std::vector<uint32_t> domain(nPoints * n, 0);  // [point * n + k]: its support domain, nearest first
  for (;;) {
    std::fill(domains.begin(), domains.end(), 0);
    for (uint32_t o = 0; o < objects; ++o) {
      const std::vector<uint32_t> nodes = keptNodes(o, kept);
      bool anyPoint = false;
      for (size_t p = 0; p < nPoints && !anyPoint; ++p) anyPoint = pointObject[p] == o;
      if (!anyPoint) continue;
      if ((int)nodes.size() < n) {
        std::ostringstream s;
        s << "MTLED: object " << o << " keeps " << nodes.size() << " nodes, fewer than the " << n
          << " of a support domain (SceneSettings.mtled.supportNodes); use a finer particle spacing";
        throw Error(s.str());
      }
      const NodeBuckets buckets(X, nodes);
      for (size_t p = 0; p < nPoints; ++p) {
        if (pointObject[p] != o) continue;
        buckets.nearest(cells.points[p], n, near);
        for (int k = 0; k < n; ++k) {
          domain[p * n + k] = near[k].second;
          domains[near[k].second]++;
        }
      }
    }
    bool dropped = false;
    for (size_t i = 0; i < nNodes; ++i)
      if (kept[i] && domains[i] < 2) {
        kept[i] = 0;
        dropped = true;
      }
    if (!dropped) break;
  }

  // lumped masses: each point's split evenly over its support domain (section 2.5)
  m.volumes = cells.volumes;
  m.pointObject = pointObject;
  m.nodeMass.assign(nNodes, 0.f);
  m.nodeVolume.assign(nNodes, 0.f);
  for (size_t p = 0; p < nPoints; ++p)
    for (int k = 0; k < n; ++k) {
      const uint32_t i = domain[p * n + k];
      m.nodeMass[i] += materials[pointObject[p]].density * cells.volumes[p] / n;
      m.nodeVolume[i] += cells.volumes[p] / n;
    }

  // shape-function derivatives per point and the critical step (eq. 37)
  std::vector<std::unique_ptr<NodeBuckets>> buckets(objects);
  std::vector<std::vector<uint32_t>> objectNodes(objects);
  for (size_t p = 0; p < nPoints; ++p) {
    const uint32_t o = pointObject[p];
    if (buckets[o]) continue;
    objectNodes[o] = keptNodes(o, kept);
    buckets[o] = std::make_unique<NodeBuckets>(X, objectNodes[o]);
  }
  m.termStart.assign(nPoints + 1, 0);
  std::vector<std::pair<double, uint32_t>> support;
  std::vector<double> phi(4 * n);
  std::vector<Eigen::Vector3d> grad(4 * n);
  // MLS at x over the n nearest kept nodes of object o, or more where those are coplanar
  // (x beyond the outermost layer of nodes, whose nearest may all lie in it); the nodes
  // are left in `support`
  const auto shapeFunctionsAt = [&](Vec3f x, uint32_t o, double* values, Eigen::Vector3d* gradients) {
    buckets[o]->nearest(x, n, support);
    if (mlsShapeFunctions(x, X, support, settings.supportScale, values, gradients)) return;
    buckets[o]->nearest(x, 4 * n, near);
    for (size_t count = n + 1; count <= near.size(); ++count) {
      support.assign(near.begin(), near.begin() + count);
      if (mlsShapeFunctions(x, X, support, settings.supportScale, values, gradients)) return;
    }
    throw singular(x, support.size());
  };
  NodeGradients terms;
  for (size_t p = 0; p < nPoints; ++p) {
    terms.clear();
    if (settings.smoothedStrain) {
      // the average over the cell's material: (1 / V) sum over its surface of phi_i(x_q) a_q
      for (uint32_t q = cells.surfaceStart[p]; q < cells.surfaceStart[p + 1]; ++q) {
        const Vec3f a = cells.surfaceAreas[q];
        shapeFunctionsAt(cells.surfacePoints[q], pointObject[p], phi.data(), nullptr);
        for (size_t k = 0; k < support.size(); ++k)
          terms.add(support[k].second, (phi[k] / cells.volumes[p]) * Eigen::Vector3d(a.x, a.y, a.z));
      }
    } else {
      shapeFunctionsAt(cells.points[p], pointObject[p], nullptr, grad.data());
      for (size_t k = 0; k < support.size(); ++k) terms.add(support[k].second, grad[k]);
    }
    double g = 0;  // sum of the squared derivatives
    for (size_t k = 0; k < terms.nodes.size(); ++k) {
      const Eigen::Vector3d& d = terms.gradients[k];
      m.support.push_back(terms.nodes[k]);
      m.shapeGradients.push_back(Vec3f{(float)d.x(), (float)d.y(), (float)d.z()});
      g += d.squaredNorm();
    }
    m.termStart[p + 1] = (uint32_t)m.support.size();
    // eq. 37 reads 2 / sqrt(g c); only 2 / (c sqrt(g)) is a time (g is in 1/m^2, c in m/s)
    const double dt = 2.0 / (pWaveSpeed(materials[pointObject[p]]) * std::sqrt(g));
    m.criticalTimeStep = std::min(m.criticalTimeStep, (float)dt);
  }

  // dropped nodes follow the nearest kept node of their object
  m.carrier.resize(nNodes);
  for (uint32_t o = 0; o < objects; ++o) {
    const std::vector<uint32_t> nodes = keptNodes(o, kept);
    bool anyDropped = false;
    for (uint32_t i = 0; i < nNodes; ++i) {
      if (nodeObject[i] != o) continue;
      m.carrier[i] = i;
      anyDropped |= !kept[i];
    }
    if (!anyDropped) continue;
    if (nodes.empty()) throw Error("MTLED: an object has nodes but no integration points inside it");
    const NodeBuckets nodeBuckets(X, nodes);
    for (uint32_t i = 0; i < nNodes; ++i) {
      if (nodeObject[i] != o || kept[i]) continue;
      nodeBuckets.nearest(X[i], 1, near);
      m.carrier[i] = near[0].second;
      m.nodeMass[i] = 0.f;
      m.droppedNodes++;
    }
  }

  // incidence lists for the per-node force gather, in term order
  m.forceStart.assign(nNodes + 1, 0);
  for (uint32_t i : m.support) m.forceStart[i + 1]++;
  for (size_t i = 0; i < nNodes; ++i) m.forceStart[i + 1] += m.forceStart[i];
  m.forceTerms.resize(m.support.size());
  std::vector<uint32_t> cursor(m.forceStart.begin(), m.forceStart.end() - 1);
  for (size_t t = 0; t < m.support.size(); ++t) m.forceTerms[cursor[m.support[t]]++] = (uint32_t)t;
  return m;
}

}  // namespace mpm
