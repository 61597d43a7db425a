#pragma once
// Memory bandwidth of this machine, measured in the benchmark's own run so that the
// achieved bytes per second of a step can be set against it (the roofline of bench_throughput). Two
// STREAM-like kernels over float arrays far larger than the last-level cache:
//
//   triad:  a[i] = b[i] + s c[i]   (STREAM's triad; counted as 12 bytes per element: read b
//                                   and c, write a; the write-allocate read of a is not counted,
//                                   as in STREAM)
//   update: a[i] = a[i] + s b[i]   (read two arrays, write one in place: no write-allocate;
//                                   the pattern of a particle pass that updates its state
//                                   in place; 12 bytes per element)
//
// Each thread owns a contiguous slice (first-touched by that thread); the best of `passes`
// timed passes is kept, as STREAM does.
#include <algorithm>
#include <chrono>
#include <cstddef>
#include <memory>
#include <thread>
#include <vector>

namespace mpm::bench {

struct Bandwidth {
  int threads = 0;
  double triadGBs = 0;   ///< [1e9 bytes/s]
  double updateGBs = 0;  ///< [1e9 bytes/s]
  size_t arrayBytes = 0;  ///< bytes of each of the three arrays
};

namespace detail {
/// Runs f(begin, end) over [0, n) split into `threads` contiguous slices, one std::thread each.
template <class F>
void parallelSlices(size_t n, int threads, F f) {
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) {
    const size_t b = n * (size_t)t / (size_t)threads, e = n * (size_t)(t + 1) / (size_t)threads;
    pool.emplace_back([=] { f(b, e); });
  }
  for (std::thread& th : pool) th.join();
}
}  // namespace detail

/// Measures triad and in-place update bandwidth with `threads` threads over three arrays of
/// `arrayMiB` MiB each (default 256 MiB: 7x a 36 MiB L3).
inline Bandwidth measureBandwidth(int threads, size_t arrayMiB = 256, int passes = 8) {
  Bandwidth r;
  r.threads = threads;
  const size_t n = arrayMiB * (size_t(1) << 20) / sizeof(float);
  r.arrayBytes = n * sizeof(float);
  std::unique_ptr<float[]> a(new float[n]), b(new float[n]), c(new float[n]);  // uninitialised
  float* A = a.get();
  float* B = b.get();
  float* Cc = c.get();
  detail::parallelSlices(n, threads, [=](size_t i0, size_t i1) {
    for (size_t i = i0; i < i1; ++i) {
      A[i] = 1.f;
      B[i] = 2.f;
      Cc[i] = 0.5f;
    }
  });
  const float s = 0.999f;
  auto best = [&](auto kernel) {
    double t = 1e30;
    for (int k = 0; k < passes; ++k) {
      const auto t0 = std::chrono::steady_clock::now();
      detail::parallelSlices(n, threads, kernel);
      t = std::min(t, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    return t;
  };
  const double triad = best([=](size_t i0, size_t i1) {
    for (size_t i = i0; i < i1; ++i) A[i] = B[i] + s * Cc[i];
  });
  const double update = best([=](size_t i0, size_t i1) {
    for (size_t i = i0; i < i1; ++i) A[i] = A[i] + s * B[i];
  });
  // keep the arrays alive and the stores observable
  volatile float sink = A[n / 2] + A[n - 1];
  (void)sink;
  r.triadGBs = 3.0 * (double)r.arrayBytes / triad / 1e9;
  r.updateGBs = 3.0 * (double)r.arrayBytes / update / 1e9;
  return r;
}

}  // namespace mpm::bench
