#pragma once
/// Scenes shared by tests, demos and benchmarks, so that "the CRESSim bench scene" or "the
/// block drop" is defined once (STYLE: scenes shared by tests, demos and benchmarks).
#include <functional>
#include <vector>

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

/// Hertz contact (bench/hertz.cpp, tests/test_hertz.cpp): a rigid sphere of radius R pressed
/// slowly into an elastic slab, the force against the depth d compared with
/// F_H = 4/3 E* sqrt(R) d^1.5, E* = E / (1 - nu^2) (rigid frictionless indenter), d <= 0.1 R.
///
/// - Sphere: kinematic (mass 0), R = 1 cm; Frictional contact, friction 0, band 0 (the
///   defaults: a node touches when it lies inside the sphere and approaches it).
/// - Slab: fixed corotated, E = 10 kPa, nu = 0.3, rho = 1000 kg/m^3, 8 particles per cell;
///   by default 8R x 8R x 4R (half-width and thickness H = 4R, 12.6 contact radii
///   a = sqrt(R d) at d = 0.1 R), modelled as a quarter on mirror planes through the
///   sphere's axis; free sides; on the domain's floor wall in Slip mode;
///   gravity 0. A slip floor, not a sticky one: a layer on a frictionless base stiffens the
///   contact less than a bonded layer (Dimitriadis et al. 2002, at nu = 0.3:
///   F / F_H - 1 = 0.76 a/H + 0.57 (a/H)^2 against 0.88 a/H + 0.78 (a/H)^2). The finite
///   width softens more than the floor stiffens: at R/dx = 4 the force at d = 0.1 R is
///   36.5 %, 32.4 % and 30.0 % below Hertz with H = 2R, 3R and 4R (half-width = H); the
///   quarter model keeps H = 4R at R/dx = 10 within reach of two cores.
/// - Grid: dx = R / cellsPerRadius. The slab's top surface lies on a node layer and the
///   sphere's axis on a node column at every resolution, so the rows of a resolution study
///   differ in dx only.
/// - Depth: d = 0 when the sphere's bottom touches the slab's top surface, the top particle
///   layer plus half a particle spacing (y = H). The grid feels the sphere earlier: the top
///   particles put mass on the node layer one cell above the surface, and contact acts on
///   nodes, so a small force (the MPM standoff) appears from d = -dx.
/// - Loading: the sphere starts 1.05 dx above the surface, clear of every node holding slab
///   mass, approaches at 5 V to d = -dx / 4, then moves at V, which takes `loadingTransits`
///   P-wave transits of the slab (H / c_p) from d = 0 to 0.1 R: quasi-static up to the
///   slab's ringing, which the force averaging below removes.
/// - Force: the shape's impulse over each frame over the frame's length, averaged over the
///   frames within kWindowTransits transits (one period of the slab's slowest ringing,
///   14.6 H / c_p measured with the sphere held at d = 0.06 R, for slabs with half-width = H).
///   Each node layer or ring that enters the contact steps the force and rings the slab.
struct HertzIndentation {
  static constexpr float kRadius = 0.01f;          ///< sphere radius R [m]
  static constexpr float kYoungsModulus = 1e4f;    ///< E [Pa]
  static constexpr float kPoissonRatio = 0.3f;     ///< nu
  static constexpr float kDensity = 1000.f;        ///< rho [kg/m^3]
  static constexpr float kMaxDepth = 0.1f * kRadius;      ///< deepest compared depth [m]
  static constexpr float kWindowTransits = 15.f;   ///< force averaging window [H / c_p]
  static constexpr float kFrameDepth = 0.002f * kRadius;  ///< sphere travel per loading frame [m]

  /// What a run may vary; the defaults are the benchmark's scene.
  struct Setup {
    int cellsPerRadius = 4;                ///< R / dx
    float slabHalfWidth = 4.f * kRadius;   ///< in x and z [m]
    float slabThickness = 4.f * kRadius;   ///< H [m]
    float loadingTransits = 20.f;          ///< time from d = 0 to kMaxDepth [H / c_p]
    /// Model a quarter of the slab, on mirror planes x = 0 and z = 0 through the sphere's
    /// axis (DomainSettings::mirrorLower): the same motion at a quarter of the cost; the
    /// forces reported are still the whole slab's.
    bool quarter = true;
    Backend backend = Backend::Cpu;
    int threads = 0;                       ///< CPU threads; 0 = all
  };

  /// dx = R / cellsPerRadius [m].
  static float cellSize(const Setup& setup);
  static SceneSettings settings(const Setup& setup);
  static ParticleObjectDesc slab(const Setup& setup);
  /// The sphere at its start, 1.05 dx above the slab, approaching at 5 V.
  static ShapeDesc indenter(const Setup& setup);
  /// y of the slab's top surface, H [m] (the slab's bottom face is at y = 0).
  static float surfaceHeight(const Setup& setup);
  /// P-wave speed c_p [m/s] and its transit time through the slab, H / c_p [s].
  static float waveSpeed();
  static float transitTime(const Setup& setup);
  /// Sphere speed while loading, V [m/s].
  static float loadingSpeed(const Setup& setup);
  /// 4/3 E* sqrt(R) d^1.5 [N]; 0 for d <= 0.
  static double hertzForce(double depth);

  /// One frame: the depth halfway through it [m] and the mean force on the sphere [N].
  struct Sample {
    double depth = 0;
    double force = 0;
  };
  struct Run {
    Setup setup;
    std::vector<Sample> approach;  ///< frames at 5 V, to d = -dx / 4
    std::vector<Sample> loading;   ///< frames at V, to half a window past kMaxDepth
    size_t particles = 0;  ///< particles stored (a quarter of the slab's with `quarter`)
    long long substeps = 0;
  };
  /// Builds the scene and presses the sphere in; `progress(frame, frames)` after each frame.
  static Run run(const Setup& setup, const std::function<void(int, int)>& progress = {});

  /// Half the averaging window in depth, V kWindowTransits H / c_p / 2 [m].
  static double windowHalfDepth(const Setup& setup);
  /// Mean force of the loading frames within the window about `depth` [N]; with `hertz`,
  /// the mean of F_H at those frames' depths, the same average of the closed form.
  static double averagedForce(const Run& run, double depth, bool hertz = false);

  /// The averaged force against the averaged closed form.
  struct Comparison {
    /// sqrt(sum (F - F_H)^2 / sum F_H^2) over d = 0.02 R, 0.025 R, ..., 0.1 R
    double l2Error = 0;
    double errorAtMaxDepth = 0;  ///< F / F_H - 1 at d = 0.1 R (signed)
    /// d - d_H at d = 0.1 R, where F_H(d_H) = F: the depth the contact loses [cells]
    double depthLossCells = 0;
  };
  static Comparison compare(const Run& run);
};

}  // namespace mpm::scenes
