#pragma once
// The top and bottom particle layers of a column of material under its own weight, for the
// self-weight tests: which particles they are (by their heights at the start), their mean
// heights, and the uniaxial-stress shortening between them.
#include <algorithm>
#include <cmath>
#include <vector>

#include "mpm/math.h"

namespace mpm::test {

struct ColumnLayers {
  std::vector<size_t> top, bottom;
  float yMin = 1e9f, yMax = -1e9f;  ///< the layers' heights at the start [m]

  /// The layers among the particles within `halfWidth` of the vertical axis through the
  /// origin (in x and z).
  explicit ColumnLayers(const std::vector<Vec3f>& x, float halfWidth = 1e30f) {
    for (const Vec3f& p : x) {
      yMin = std::min(yMin, p.y);
      yMax = std::max(yMax, p.y);
    }
    for (size_t i = 0; i < x.size(); ++i) {
      if (std::fabs(x[i].x) > halfWidth || std::fabs(x[i].z) > halfWidth) continue;
      if (x[i].y > yMax - 1e-4f) top.push_back(i);
      if (x[i].y < yMin + 1e-4f) bottom.push_back(i);
    }
  }
  static double meanHeight(const std::vector<Vec3f>& x, const std::vector<size_t>& layer) {
    double s = 0;
    for (size_t i : layer) s += x[i].y;
    return s / layer.size();
  }
  double length(const std::vector<Vec3f>& x) const { return meanHeight(x, top) - meanHeight(x, bottom); }
  /// Static shortening between the layers of a column of height H standing on y = base,
  /// under uniaxial stress: rho g / E * integral (H - z) dz over the layers' heights.
  double uniaxialShortening(double rho, double g, double E, double H, double base) const {
    const double z0 = yMin - base, z1 = yMax - base;
    return rho * g / E * ((H * z1 - 0.5 * z1 * z1) - (H * z0 - 0.5 * z0 * z0));
  }
};

}  // namespace mpm::test
