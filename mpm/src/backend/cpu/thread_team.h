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
//
// Fork-safe: a forked child makes a crew of its own (core/per_process.h).
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

#include "core/per_process.h"

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace mpm {

class ThreadTeam {
 public:
  ThreadTeam() = default;
  ThreadTeam(const ThreadTeam&) = delete;
  ThreadTeam& operator=(const ThreadTeam&) = delete;

  /// f(t, nt) on nt threads, t = 0 on the caller; returns when every call has returned.
  /// One run at a time per team (the scene's step is single-threaded outside its loops).
  /// What a call throws (std::bad_alloc from a worker's allocation, say) is rethrown here,
  /// on the caller, once every member has left the job: a member waiting at a barrier for
  /// the one that threw leaves it too. A worker that let an exception out of its thread
  /// would end the process; a caller that let it out at once would leave the workers on
  /// the job's stack frame.
  template <class F>
  void run(int nt, const F& f) {
    if (nt <= 1) {
      f(0, 1);
      return;
    }
    Crew& c = crew_.get();
    c.grow(nt - 1);
    c.job = &f;
    c.call = [](const void* job, int t, int n) { (*static_cast<const F*>(job))(t, n); };
    c.members = nt;
    c.failure = nullptr;
    c.failed.store(false);
    c.done.store(0);
    c.generation.fetch_add(1);  // publishes the job to the workers
    c.wake();
    c.member(0, nt);
    // every worker reports, members or not, so none can still be reading this job when
    // the next run publishes its own
    const int workers = (int)c.workers.size();
    c.waitUntil([&] { return c.done.load() == workers; });
    if (c.failed.load()) {
      c.arrived.store(0);  // a barrier the members left when the job failed
      std::exception_ptr e = std::move(c.failure);
      c.failure = nullptr;
      std::rethrow_exception(e);
    }
  }

  /// Inside run: returns once all nt members have called it (a sense-reversing barrier).
  void barrier(int nt) { crew_.get().barrier(nt); }

 private:
  struct Crew {
    /// Spins this many checks (about 10-30 us), then yields this many times, then sleeps.
    static constexpr int kSpin = 2000, kYield = 50;

    ~Crew() {
      {
        std::lock_guard<std::mutex> lock(mutex);
        stop = true;
      }
      generation.fetch_add(1);
      wake();
      for (std::thread& w : workers) w.join();
    }
    /// Thrown at a barrier whose job another member has failed: unwinds this member.
    struct Abandoned {};

    void barrier(int nt) {
      if (failed.load()) throw Abandoned{};
      const uint64_t round = barrierRound.load();
      if (arrived.fetch_add(1) == nt - 1) {
        arrived.store(0);
        barrierRound.fetch_add(1);
        wake();
        return;
      }
      waitUntil([&] { return barrierRound.load() != round || failed.load(); });
      if (barrierRound.load() == round) throw Abandoned{};
    }
    /// Member t's share of the job; the first exception any member throws is kept for run.
    void member(int t, int n) {
      try {
        call(job, t, n);
      } catch (const Abandoned&) {
      } catch (...) {
        {
          std::lock_guard<std::mutex> lock(mutex);
          if (!failure) failure = std::current_exception();
        }
        failed.store(true);
        wake();  // members asleep at a barrier
      }
    }
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
      std::unique_lock<std::mutex> lock(mutex);
      sleepers.fetch_add(1);
      cv.wait(lock, ready);
      sleepers.fetch_sub(1);
    }
    /// Wakes the sleepers after a change they may wait for (made before this call,
    /// seq_cst: a waiter either sees the change or is counted, and then waits under the
    /// lock taken here before the notify).
    void wake() {
      if (sleepers.load() == 0) return;
      { std::lock_guard<std::mutex> lock(mutex); }
      cv.notify_all();
    }
    void grow(int count) {
      while ((int)workers.size() < count) {
        const int index = (int)workers.size() + 1;
        const uint64_t seen = generation.load();
        workers.emplace_back([this, index, seen] { work(index, seen); });
      }
    }
    void work(int index, uint64_t seen) {
      for (;;) {
        waitUntil([&] { return generation.load() != seen; });
        seen = generation.load();
        {
          std::lock_guard<std::mutex> lock(mutex);
          if (stop) return;
        }
        if (index < members) member(index, members);
        done.fetch_add(1);
        wake();
      }
    }

    std::vector<std::thread> workers;
    std::mutex mutex;
    std::condition_variable cv;
    std::atomic<int> sleepers{0};
    std::atomic<uint64_t> generation{0};
    std::atomic<int> done{0};
    std::atomic<int> arrived{0};
    std::atomic<uint64_t> barrierRound{0};
    std::atomic<bool> failed{false};
    std::exception_ptr failure;  ///< under mutex while the job runs
    const void* job = nullptr;
    void (*call)(const void*, int, int) = nullptr;
    int members = 0;
    bool stop = false;
  };

  PerProcess<Crew> crew_;
};

}  // namespace mpm
