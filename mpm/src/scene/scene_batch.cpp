// SceneBatch: a few runner threads take the batch's CPU scenes one at a time and step each
// on its share of the threads: Scene::step on the runner, which leads the scene's own
// thread team (backend/cpu/thread_team.h), so a scene's results are those of its own
// advance(). CUDA scenes are all started at once: each has its worker thread and its
// stream (CudaExec).
#include "mpm/scene_batch.h"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

#include "core/per_process.h"
#include "core/validate.h"

#if defined(_OPENMP)
#include <omp.h>
#endif

namespace mpm {

namespace {
int allThreads() {
#if defined(_OPENMP)
  return omp_get_max_threads();  // OMP_NUM_THREADS, as SceneSettings::cpuThreads = 0
#else
  return (int)std::max(1u, std::thread::hardware_concurrency());
#endif
}
}  // namespace

class SceneBatchImpl {
 public:
  SceneBatchImpl(std::vector<Scene*> s, int t) : scenes(std::move(s)) {
    validate::atLeast("SceneBatch threads", t, 0);
    for (size_t i = 0; i < scenes.size(); ++i) {
      const std::string field = "SceneBatch scenes[" + std::to_string(i) + "]";
      if (!scenes[i]) throw InvalidArgument(field, "null", "every entry must point to a Scene");
      for (size_t j = 0; j < i; ++j)
        if (scenes[j] == scenes[i])
          throw InvalidArgument(field, "scenes[" + std::to_string(j) + "]",
                                "the same Scene twice: a scene can only advance once per step");
    }
    threads = t > 0 ? t : allThreads();
    for (size_t i = 0; i < scenes.size(); ++i) (scenes[i]->backend() == Backend::Cuda ? gpu : cpu).push_back(i);
    // at least as many scenes as threads: one thread each, every thread busy; fewer
    // scenes: each gets an equal share (the rest of the division idles)
    runnerCount = (int)std::min<size_t>((size_t)threads, cpu.size());
    share = runnerCount > 0 ? threads / runnerCount : 1;
  }

  ~SceneBatchImpl() {
    if (stepping) {
      try {
        fetch();  // the scenes are the caller's: none is left waiting for a fetch
      } catch (...) {  // an error nobody fetched
      }
    }
  }

  void advance(const std::vector<float>& dt) {
    if (stepping) throw StepInProgress("SceneBatch::advance: a step is running; call fetchResults() first");
    if (dt.size() != scenes.size())
      throw InvalidArgument("SceneBatch::advance dt", std::to_string(dt.size()) + " values",
                            "one per scene: the batch has " + std::to_string(scenes.size()));
    for (size_t i = 0; i < dt.size(); ++i)
      validate::positive("SceneBatch::advance dt[" + std::to_string(i) + "]", dt[i]);
    for (size_t i = 0; i < scenes.size(); ++i)
      if (scenes[i]->stepping())
        throw InvalidArgument("SceneBatch scenes[" + std::to_string(i) + "]", "stepping",
                              "its own advance() waits for its fetchResults()");
    if (scenes.empty()) return;
    dts = dt;
    reports.assign(scenes.size(), StepReport{});
    errors.assign(scenes.size(), nullptr);
    started.assign(scenes.size(), 0);
    failed.clear();
    for (size_t i : gpu) {
      try {
        scenes[i]->advance(dt[i]);
        started[i] = 1;
      } catch (...) {
        errors[i] = std::current_exception();
      }
    }
    next = 0;
    Runners& r = runners.get();
    while ((int)r.threads.size() < runnerCount) r.threads.emplace_back([this, &r] { loop(r); });
    {
      std::lock_guard<std::mutex> lock(r.mutex);
      r.busy = runnerCount;
      ++r.generation;
    }
    r.wake.notify_all();
    stepping = true;
  }

  std::vector<StepReport> fetch() {
    if (!stepping) return {};
    if (runners.inherited()) {  // the step ran on the parent's runners: half done, here
      stepping = false;
      throw Error("SceneBatch::fetchResults: the process was forked while a step was running; the scenes' "
                  "state is undefined in the child (fork between fetchResults and the next advance)");
    }
    wait();
    for (size_t i : gpu) {
      if (!started[i]) continue;
      try {
        reports[i] = scenes[i]->fetchResults();
      } catch (...) {
        errors[i] = std::current_exception();
      }
    }
    for (size_t i = 0; i < errors.size(); ++i)
      if (errors[i]) failed.push_back(i);
    if (!failed.empty()) std::rethrow_exception(errors[failed.front()]);
    return reports;
  }

  std::vector<Scene*> scenes;
  int threads = 1;
  int share = 1;  ///< threads each scene's loops run on
  std::vector<size_t> failed;

 private:
  /// The runner threads and what they wait on, kept per process (core/per_process.h): a
  /// forked child has none of the parent's runners, and its copy of their mutex may be held
  /// by a thread it does not have. Started by the first advance in a process.
  struct Runners {
    ~Runners() {
      {
        std::lock_guard<std::mutex> lock(mutex);
        stop = true;
      }
      wake.notify_all();
      for (std::thread& t : threads) t.join();
    }
    std::mutex mutex;
    std::condition_variable wake, finished;
    long generation = 0;
    int busy = 0;  ///< runners still taking scenes this step
    bool stop = false;
    std::vector<std::thread> threads;
  };

  void wait() {
    Runners& r = runners.get();
    std::unique_lock<std::mutex> lock(r.mutex);
    r.finished.wait(lock, [&] { return r.busy == 0; });
    stepping = false;
  }

  /// Takes scenes until none is left. Which runner steps which scene does not matter:
  /// each scene's result depends on the scene alone.
  void loop(Runners& r) {
    long seen = 0;
    for (;;) {
      {
        std::unique_lock<std::mutex> lock(r.mutex);
        r.wake.wait(lock, [&] { return r.stop || r.generation != seen; });
        if (r.stop) return;
        seen = r.generation;
      }
      for (size_t k; (k = next.fetch_add(1)) < cpu.size();) {
        const size_t i = cpu[k];
        Scene& s = *scenes[i];
        try {
          s.setStepThreads(share);
          reports[i] = s.step(dts[i]);
        } catch (...) {
          errors[i] = std::current_exception();
        }
        try {
          s.setStepThreads(0);  // stepped alone again, it runs on its own settings
        } catch (...) {
        }
      }
      {
        std::lock_guard<std::mutex> lock(r.mutex);
        --r.busy;
      }
      r.finished.notify_all();
    }
  }

  std::vector<size_t> cpu, gpu;  ///< the scenes on each backend, in batch order
  std::vector<uint8_t> started;  ///< CUDA scenes whose advance() began
  std::vector<float> dts;
  std::vector<StepReport> reports;
  std::vector<std::exception_ptr> errors;
  std::atomic<size_t> next{0};
  int runnerCount = 0;  ///< runner threads: as many as threads, at most one per CPU scene
  bool stepping = false;
  PerProcess<Runners> runners;  // last: the runners stop before what they use goes
};

SceneBatch::SceneBatch(std::vector<Scene*> scenes, int threads)
    : impl_(std::make_unique<SceneBatchImpl>(std::move(scenes), threads)) {}
SceneBatch::~SceneBatch() = default;
size_t SceneBatch::size() const { return impl_->scenes.size(); }
Scene& SceneBatch::scene(size_t i) {
  if (i >= impl_->scenes.size())
    throw InvalidArgument("SceneBatch::scene index", std::to_string(i),
                          "the batch has " + std::to_string(impl_->scenes.size()) + " scenes");
  return *impl_->scenes[i];
}
int SceneBatch::threads() const { return impl_->threads; }
void SceneBatch::advance(float dt) {
  validate::positive("SceneBatch::advance dt", dt);
  impl_->advance(std::vector<float>(impl_->scenes.size(), dt));
}
void SceneBatch::advance(const std::vector<float>& dt) { impl_->advance(dt); }
std::vector<StepReport> SceneBatch::fetchResults() { return impl_->fetch(); }
std::vector<StepReport> SceneBatch::step(float dt) {
  advance(dt);
  return fetchResults();
}
const std::vector<size_t>& SceneBatch::failedScenes() const { return impl_->failed; }

}  // namespace mpm
