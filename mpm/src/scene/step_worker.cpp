#include "scene/step_worker.h"

#include <utility>

namespace mpm {

StepWorker::StepWorker() : thread_([this] { loop(); }) {}

StepWorker::~StepWorker() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

std::future<StepReport> StepWorker::submit(std::function<StepReport()> job) {
  std::packaged_task<StepReport()> task(std::move(job));
  std::future<StepReport> result = task.get_future();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    task_ = std::move(task);
    pending_ = true;
  }
  wake_.notify_all();
  return result;
}

void StepWorker::loop() {
  for (;;) {
    std::packaged_task<StepReport()> task;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stop_ || pending_; });
      if (!pending_) return;
      task = std::move(task_);
      pending_ = false;
    }
    task();  // an exception is stored in the future, rethrown by fetchResults()
  }
}

}  // namespace mpm
