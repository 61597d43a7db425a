// MTLED preprocessing on the host (seed 004 section 2.1, steps 3-4; sections 2.3-2.5, 3.3):
// support domains of the n nearest nodes, MLS shape-function derivatives, lumped masses,
// removal of nodes in fewer than two support domains, the critical time step. Eigen
// (double precision) for the small moment-matrix solves; runs once per change of the nodes.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
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

  /// The k nodes nearest to q, nearest first (ties by node index, so the result does not
  /// depend on the order of the search).
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

/// Derivatives d phi_i / dx at x0 of the MLS shape functions (eqs. 7-8, 18-25) with the
/// linear basis p = (1, x, y, z), over the given support nodes. Coordinates are taken
/// relative to x0 and scaled by the farthest node's distance s, so the moment matrix is
/// of order one whatever the units.
void mlsGradients(Vec3f x0, const std::vector<Vec3f>& X, const std::vector<std::pair<double, uint32_t>>& support,
                  double alpha, Vec3f* gradients) {
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
  const Eigen::FullPivLU<Eigen::Matrix4d> lu(A);
  if (lu.rcond() < 1e-9) {
    std::ostringstream m;
    m << "MTLED: the moment matrix of the integration point at " << validate::show(x0)
      << " is singular (its " << n << " support nodes are nearly coplanar); use more support nodes";
    throw Error(m.str());
  }
  const Eigen::Vector4d gamma = lu.solve(Eigen::Vector4d(1, 0, 0, 0));  // A^-1 p(x0)
  for (int i = 0; i < n; ++i) gradients[i] = Vec3f{0.f, 0.f, 0.f};
  for (int k = 0; k < 3; ++k) {
    // d gamma / d x_k = A^-1 (d p / d x_k - dA_k gamma)
    const Eigen::Vector4d dgamma = lu.solve(Eigen::Vector4d::Unit(k + 1) - dA[k] * gamma);
    for (int i = 0; i < n; ++i)
      gradients[i][k] = (float)((w[i] * dgamma.dot(p[i]) + dw[i][k] * gamma.dot(p[i])) / s);
  }
}

}  // namespace

IntegrationCells integrationCells(const std::function<bool(Vec3f)>& inside, Vec3f lo, Vec3f hi, float cellSize) {
  constexpr int kSamples = 4;  // per axis and cell
  int n[3];
  Vec3f h;
  for (int a = 0; a < 3; ++a) {
    n[a] = std::max(1, (int)std::lround((hi[a] - lo[a]) / cellSize));
    h[a] = (hi[a] - lo[a]) / n[a];
  }
  IntegrationCells out;
  const float cellVolume = h.x * h.y * h.z;
  for (int i = 0; i < n[0]; ++i)
    for (int j = 0; j < n[1]; ++j)
      for (int k = 0; k < n[2]; ++k) {
        Vec3f sum{0.f, 0.f, 0.f};
        int count = 0;
        for (int si = 0; si < kSamples; ++si)
          for (int sj = 0; sj < kSamples; ++sj)
            for (int sk = 0; sk < kSamples; ++sk) {
              const Vec3f x{lo.x + (i + (si + 0.5f) / kSamples) * h.x, lo.y + (j + (sj + 0.5f) / kSamples) * h.y,
                            lo.z + (k + (sk + 0.5f) / kSamples) * h.z};
              if (!inside(x)) continue;
              sum += x;
              count++;
            }
        if (count == 0) continue;
        out.points.push_back((1.f / count) * sum);
        out.volumes.push_back(cellVolume * count / (kSamples * kSamples * kSamples));
      }
  return out;
}

MtledModel buildMtledModel(const MtledSettings& settings, const std::vector<Vec3f>& X,
                           const std::vector<uint32_t>& nodeObject, const std::vector<Vec3f>& points,
                           const std::vector<float>& volumes, const std::vector<uint32_t>& pointObject,
                           const std::vector<MaterialParams>& materials) {
  const int n = settings.supportNodes;
  const size_t nNodes = X.size(), nPoints = points.size();
  MtledModel m;
  m.supportNodes = n;
  m.criticalTimeStep = std::numeric_limits<float>::infinity();
  uint32_t objects = 0;
  for (uint32_t o : nodeObject) objects = std::max(objects, o + 1);
  for (uint32_t o : pointObject) objects = std::max(objects, o + 1);

  // support domains; nodes in fewer than two of them are dropped and the search redone
  // (section 3.2), since a node held by one point alone has unbalanced forces
  std::vector<uint8_t> kept(nNodes, 1);
  std::vector<std::pair<double, uint32_t>> near;
  std::vector<int> domains(nNodes);
  m.support.assign(nPoints * n, 0);
  for (;;) {
    std::fill(domains.begin(), domains.end(), 0);
    for (uint32_t o = 0; o < objects; ++o) {
      std::vector<uint32_t> nodes;  // the object's kept nodes: objects never share a support
      for (uint32_t i = 0; i < nNodes; ++i)
        if (nodeObject[i] == o && kept[i]) nodes.push_back(i);
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
        buckets.nearest(points[p], n, near);
        for (int k = 0; k < n; ++k) {
          m.support[p * n + k] = near[k].second;
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

  // shape-function derivatives, lumped masses (section 2.5) and the critical step (eq. 37)
  m.shapeGradients.resize(nPoints * n);
  m.volumes = volumes;
  m.pointObject = pointObject;
  m.nodeMass.assign(nNodes, 0.f);
  m.nodeVolume.assign(nNodes, 0.f);
  std::vector<std::pair<double, uint32_t>> support(n);
  for (size_t p = 0; p < nPoints; ++p) {
    for (int k = 0; k < n; ++k) {
      const uint32_t i = m.support[p * n + k];
      const Vec3f d = X[i] - points[p];
      support[k] = {(double)dot(d, d), i};
    }
    // the farthest node sets the support radius (the search returns nearest first)
    mlsGradients(points[p], X, support, settings.supportScale, &m.shapeGradients[p * n]);
    const MaterialParams& mat = materials[pointObject[p]];
    double g = 0;  // sum of the squared derivatives
    for (int k = 0; k < n; ++k) {
      const uint32_t i = m.support[p * n + k];
      m.nodeMass[i] += mat.density * volumes[p] / n;
      m.nodeVolume[i] += volumes[p] / n;
      g += dot(m.shapeGradients[p * n + k], m.shapeGradients[p * n + k]);
    }
    // eq. 37 reads 2 / sqrt(g c); only 2 / (c sqrt(g)) is a time (g is in 1/m^2, c in m/s)
    const double dt = 2.0 / (pWaveSpeed(mat) * std::sqrt(g));
    m.criticalTimeStep = std::min(m.criticalTimeStep, (float)dt);
  }

  // dropped nodes follow the nearest kept node of their object
  m.carrier.resize(nNodes);
  for (uint32_t o = 0; o < objects; ++o) {
    std::vector<uint32_t> nodes;
    bool anyDropped = false;
    for (uint32_t i = 0; i < nNodes; ++i) {
      if (nodeObject[i] != o) continue;
      if (kept[i]) nodes.push_back(i);
      else anyDropped = true;
    }
    for (uint32_t i = 0; i < nNodes; ++i)
      if (nodeObject[i] == o) m.carrier[i] = i;
    if (!anyDropped) continue;
    if (nodes.empty()) throw Error("MTLED: an object has nodes but no integration points inside it");
    const NodeBuckets buckets(X, nodes);
    for (uint32_t i = 0; i < nNodes; ++i) {
      if (nodeObject[i] != o || kept[i]) continue;
      buckets.nearest(X[i], 1, near);
      m.carrier[i] = near[0].second;
      m.nodeMass[i] = 0.f;
      m.droppedNodes++;
    }
  }

  // incidence lists for the per-node force gather, in point order
  m.forceStart.assign(nNodes + 1, 0);
  for (uint32_t i : m.support) m.forceStart[i + 1]++;
  for (size_t i = 0; i < nNodes; ++i) m.forceStart[i + 1] += m.forceStart[i];
  m.forceTerms.resize(m.support.size());
  std::vector<uint32_t> cursor(m.forceStart.begin(), m.forceStart.end() - 1);
  for (size_t t = 0; t < m.support.size(); ++t) m.forceTerms[cursor[m.support[t]]++] = (uint32_t)t;
  return m;
}

}  // namespace mpm
