#pragma once
/// Many independent scenes advanced together: data generation, reinforcement learning.
///
///   std::vector<mpm::Scene> scenes;  /* 16 copies of one scene, built in place */
///   std::vector<mpm::Scene*> all;  for (auto& s : scenes) all.push_back(&s);
///   mpm::SceneBatch batch(all);                  // threads: all hardware threads
///   batch.advance(1.f / 60);  /* other work */  auto reports = batch.fetchResults();
///
/// CPU: the batch's threads take the scenes one at a time, each scene's loops on its share
/// of the threads (one each when there are at least as many scenes as threads). A small
/// scene spends much of each substep waking and joining its thread team; a whole scene per
/// thread pays none of that. Each scene ends bit for bit where it would have stepped alone
/// (the CPU path does not depend on the thread count).
///
/// CUDA: every scene's step starts at once (each scene has its own worker thread) and its
/// kernels, sorts and copies go to its own stream, so small scenes' launches overlap on the
/// device. `threads` does not limit them (16 copies of the embedding scene on an H200:
/// 3.58x one scene, bench/results/h200/batch_cuda.md).
#include <cstddef>
#include <exception>
#include <memory>
#include <vector>

#include "mpm/scene.h"

namespace mpm {

class SceneBatchImpl;

class SceneBatch {
 public:
  /// `scenes` (not owned) must outlive the batch and stay where they are (a moved-from
  /// Scene is an empty shell). `threads`: how many CPU scenes run at once and the threads
  /// they share; 0 = all hardware threads (OMP_NUM_THREADS if set). Throws InvalidArgument
  /// naming the field for a null scene ("SceneBatch scenes[i]"), a scene listed twice, or
  /// threads < 0. An empty batch is allowed and does nothing.
  explicit SceneBatch(std::vector<Scene*> scenes, int threads = 0);
  ~SceneBatch();
  SceneBatch(const SceneBatch&) = delete;
  SceneBatch& operator=(const SceneBatch&) = delete;

  size_t size() const;
  Scene& scene(size_t i);
  /// Threads the batch runs on (0 resolved).
  int threads() const;

  /// Starts advancing every scene by `dt` seconds (> 0, finite), or scene i by dt[i] (one
  /// per scene). No scene may be changed until fetchResults() returns. Throws, starting
  /// nothing, on a bad dt (named with its index), a dt list of another length than the
  /// batch, a scene whose own advance() waits for its fetchResults(), or a batch step
  /// that is still running.
  void advance(float dt);
  void advance(const std::vector<float>& dt);
  /// Waits for every scene; returns their reports in batch order. If scenes failed it
  /// rethrows the error of the first of them (its type kept, e.g. SimulationDiverged) once
  /// all have finished: that scene is as it was before the advance (Scene's rollback), the
  /// others have advanced; failedScenes() lists them all. Returns {} with no step running.
  std::vector<StepReport> fetchResults();
  /// advance(dt) followed by fetchResults().
  std::vector<StepReport> step(float dt);
  /// Indices of the scenes whose last batch advance failed (empty after a clean one).
  const std::vector<size_t>& failedScenes() const;

 private:
  std::unique_ptr<SceneBatchImpl> impl_;
};

}  // namespace mpm
