#pragma once
// The thread that runs a scene's steps (Scene::advance hands it the step, fetchResults
// waits for it).
#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

#include "mpm/scene.h"

namespace mpm {

/// The one thread that runs a scene's steps. It lives as long as the scene: a new thread per
/// advance() would also make OpenMP build a new thread team every frame (measured: binning
/// on 2 threads took 10 ms per frame at 8k particles against 1.4 ms on 1).
///
/// The result is handed over under the worker's mutex, and the worker lets go of the job and
/// of any exception it threw before that: the job's captures are destroyed on the worker,
/// the exception on the caller's thread. (With std::packaged_task the worker held the
/// shared state, and so the exception, until after the caller had seen it; whichever
/// thread dropped the last reference destroyed it, ordered only by libstdc++'s
/// uninstrumented reference count, which ThreadSanitizer reported as a race.)
class StepWorker {
 public:
  StepWorker();
  ~StepWorker();
  /// Starts `job`; the previous job's result must have been taken by wait().
  void submit(std::function<StepReport()> job);
  /// Waits for the submitted job; returns its report or rethrows what it threw.
  StepReport wait();

 private:
  void loop();

  std::mutex mutex_;
  std::condition_variable wake_, finished_;
  std::function<StepReport()> job_;
  StepReport report_;
  std::exception_ptr error_;
  bool queued_ = false, done_ = false, stop_ = false;
  std::thread thread_;  // last: starts after the members it uses exist
};

}  // namespace mpm
