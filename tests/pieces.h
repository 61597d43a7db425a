#pragma once
// Connected pieces of a particle cloud: what a cut separates (test_cutting) and what a
// needle and thread must not (test_suturing_bullet).
#include <numeric>
#include <vector>

#include "mpm/scene.h"

namespace mpm::test {

/// Connected pieces of the particles, linking those closer than 1.5 particle spacings.
inline int pieces(const std::vector<Vec3f>& x, float spacing) {
  const size_t n = x.size();
  std::vector<size_t> parent(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](size_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  const float r2 = (1.5f * spacing) * (1.5f * spacing);
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j) {
      const Vec3f d = x[i] - x[j];
      if (dot(d, d) < r2) parent[find(i)] = find(j);
    }
  int count = 0;
  for (size_t i = 0; i < n; ++i) count += find(i) == i;
  return count;
}

}  // namespace mpm::test
