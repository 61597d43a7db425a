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

void StepWorker::submit(std::function<StepReport()> job) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    job_ = std::move(job);
    queued_ = true;
    done_ = false;
  }
  wake_.notify_all();
}

StepReport StepWorker::wait() {
  std::exception_ptr error;
  StepReport report;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    finished_.wait(lock, [this] { return done_; });
    done_ = false;
    error = std::move(error_);
    report = std::move(report_);
  }
  if (error) std::rethrow_exception(std::move(error));
  return report;
}

void StepWorker::loop() {
  for (;;) {
    std::function<StepReport()> job;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait(lock, [this] { return stop_ || queued_; });
      if (!queued_) return;
      job = std::move(job_);
      queued_ = false;
    }
    StepReport report;
    std::exception_ptr error;
    try {
      report = job();
    } catch (...) {
      error = std::current_exception();  // rethrown by wait(), i.e. fetchResults()
    }
    job = nullptr;  // its captures go here, before the caller can see the result
    {
      std::lock_guard<std::mutex> lock(mutex_);
      report_ = std::move(report);
      error_ = std::move(error);  // the worker keeps no reference to it
      done_ = true;
    }
    finished_.notify_all();
  }
}

}  // namespace mpm
