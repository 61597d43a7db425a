#pragma once
// The CPU backend's threads: a team of persistent workers that the step's loops share.
//
// Why not OpenMP's team: its threads spin while they wait (the default wait policy), and on
// a machine whose other core is busy a spinning thread holds the core its partner needs:
// 0.2 s of the README's embedding scene took 10.0 s on 2 threads against 0.43 s on one,
// with another 2-thread process on the second core. With OMP_WAIT_POLICY=passive every
// barrier is a wake-up instead, and at 9000 particles a second thread then gains nothing.
// Here a waiting thread spins only briefly (a barrier's partner is usually microseconds
// away), then yields its core, then sleeps on a condition variable.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>
#include <vector>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace mpm {

class ThreadTeam {
 public:
  ThreadTeam() = default;
  ThreadTeam(const ThreadTeam&) = delete;
  ThreadTeam& operator=(const ThreadTeam&) = delete;
  ~ThreadTeam() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    generation_.fetch_add(1);
    wake();
    for (std::thread& w : workers_) w.join();
  }

  /// f(t, nt) on nt threads, t = 0 on the caller; returns when every call has returned.
  /// One run at a time per team (the scene's step is single-threaded outside its loops).
  template <class F>
  void run(int nt, const F& f) {
    if (nt <= 1) {
      f(0, 1);
      return;
    }
    grow(nt - 1);
    job_ = &f;
    call_ = [](const void* job, int t, int n) { (*static_cast<const F*>(job))(t, n); };
    members_ = nt;
    done_.store(0);
    generation_.fetch_add(1);  // publishes the job to the workers
    wake();
    f(0, nt);
    // every worker reports, members or not, so none can still be reading this job when
    // the next run publishes its own
    const int workers = (int)workers_.size();
    waitUntil([&] { return done_.load() == workers; });
  }

  /// Inside run: returns once all nt members have called it (a sense-reversing barrier).
  void barrier(int nt) {
    const uint64_t round = barrierRound_.load();
    if (arrived_.fetch_add(1) == nt - 1) {
      arrived_.store(0);
      barrierRound_.fetch_add(1);
      wake();
      return;
    }
    waitUntil([&] { return barrierRound_.load() != round; });
  }

 private:
  /// Spins this many checks (about 10-30 us), then yields this many times, then sleeps.
  static constexpr int kSpin = 2000, kYield = 50;

  template <class Ready>
  void waitUntil(const Ready& ready) {
    for (int i = 0; i < kSpin; ++i) {
      if (ready()) return;
#if defined(__x86_64__) || defined(__i386__)
      _mm_pause();
#endif
    }
    for (int i = 0; i < kYield; ++i) {
      if (ready()) return;
      std::this_thread::yield();
    }
    std::unique_lock<std::mutex> lock(mutex_);
    sleepers_.fetch_add(1);
    cv_.wait(lock, ready);
    sleepers_.fetch_sub(1);
  }
  /// Wakes the sleepers after a change they may wait for (made before this call, seq_cst:
  /// a waiter either sees the change or is counted, and then waits under the lock taken
  /// here before the notify).
  void wake() {
    if (sleepers_.load() == 0) return;
    { std::lock_guard<std::mutex> lock(mutex_); }
    cv_.notify_all();
  }
  void grow(int workers) {
    while ((int)workers_.size() < workers) {
      const int index = (int)workers_.size() + 1;
      const uint64_t seen = generation_.load();
      workers_.emplace_back([this, index, seen] { work(index, seen); });
    }
  }
  void work(int index, uint64_t seen) {
    for (;;) {
      waitUntil([&] { return generation_.load() != seen; });
      seen = generation_.load();
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (stop_) return;
      }
      if (index < members_) call_(job_, index, members_);
      done_.fetch_add(1);
      wake();
    }
  }

  std::vector<std::thread> workers_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::atomic<int> sleepers_{0};
  std::atomic<uint64_t> generation_{0};
  std::atomic<int> done_{0};
  std::atomic<int> arrived_{0};
  std::atomic<uint64_t> barrierRound_{0};
  const void* job_ = nullptr;
  void (*call_)(const void*, int, int) = nullptr;
  int members_ = 0;
  bool stop_ = false;
};

}  // namespace mpm
