#pragma once
// Objects that own threads (the CPU backend's thread team, a scene's step worker), kept per
// process.
//
// A forked child has only the thread that called fork: an object made before the fork has
// no threads there, and its mutexes and condition variables may hold the state of threads
// that do not exist (a broadcast can then wait for them forever). So the child abandons the
// parent's object (never touched or destroyed there: its memory is the child's only leak)
// and makes its own when first asked. Data generation forks (Python's multiprocessing).
#include <pthread.h>

#include <atomic>

namespace mpm {

/// How many forks lie between the process that first asked and this one (a child's
/// handler counts them; an atomic load where getpid() is a system call per ask).
inline unsigned forkGeneration() {
  static std::atomic<unsigned> forks{0};
  static const int registered = pthread_atfork(nullptr, nullptr, [] { forks.fetch_add(1); });
  (void)registered;
  return forks.load(std::memory_order_relaxed);
}

template <class T>
class PerProcess {
 public:
  PerProcess() = default;
  PerProcess(const PerProcess&) = delete;
  PerProcess& operator=(const PerProcess&) = delete;
  ~PerProcess() {
    if (!inherited()) delete object_;
  }

  /// This process's object, made on the first call here.
  T& get() {
    if (!object_ || inherited()) {
      object_ = new T;
      owner_ = forkGeneration();
    }
    return *object_;
  }
  /// The object was made by the process this one was forked from (and is not used here).
  bool inherited() const { return object_ && owner_ != forkGeneration(); }

 private:
  T* object_ = nullptr;
  unsigned owner_ = 0;  ///< forkGeneration() where object_ was made
};

}  // namespace mpm
