#pragma once
/// Scenes shared by tests, demos and benchmarks, so that "the CRESSim bench scene" or "the
/// block drop" is defined once (STYLE: scenes shared by tests, demos and benchmarks).
#include "mpm/scene.h"

namespace mpm::scenes {

/// CRESSim-MPM's own benchmark (BENCH_SCENES.md section 1): grid [-5.5, 5.5]^3 with cell
/// 0.2, a box of particles at spacing 0.1 with mass 10 each (density 1e4), corotated
/// E = 5e5, nu = 0.4, gravity (0, -1, 0), 10 substeps of 0.002 s per 0.02 s frame.
/// Half-sizes 0.5, 1, 1.5, 2.5, 5 give 1k, 8k, 27k, 125k and 1M particles.
struct CressimBench {
  static constexpr float kFrameDt = 0.02f;
  static constexpr int kSubstepsPerFrame = 10;
  static SceneSettings settings(Backend backend = Backend::Cpu, int threads = 0);
  static ParticleObjectDesc box(float halfSize);
};

/// The main demo: an elastic block dropped onto the ground of a 2 m box (sticky-free
/// "separate" walls), soft enough to squash visibly and bounce.
struct BlockDrop {
  static SceneSettings settings();
  static ParticleObjectDesc block();
};

}  // namespace mpm::scenes
