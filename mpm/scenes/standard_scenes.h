#pragma once
/// Scenes shared by tests and benchmarks, so that "the CRESSim bench scene" is defined
/// once; the demos' scenes are files (assets/scenes/, mpm_bullet/scene_file.h).
#include <array>
#include <functional>
#include <string>
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
    /// The slab's law; both have Hertz's linear limit, they part at finite strain.
    MaterialModel material = MaterialModel::FixedCorotated;
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

/// A kinematic plate (box shape of mass 0), `halfWidth` in x and z, `halfThickness` in y,
/// whose lower face (`below` false) or upper face (`below` true) is at height `faceY`.
ShapeDesc plate(float halfWidth, float halfThickness, float faceY, bool below, const ContactParams& contact);

/// The cylinder of Horton et al. 2010 ( tests/reference/README.md: CalculiX references, Horton et al.
/// 2010's set-up) between two kinematic plates: R = 5 cm, H = 10 cm, axis along y (the
/// library's up axis) with the bottom face at y = 0, decoupled Neo-Hookean mu = 1007 Pa,
/// K = 50001.333 Pa (nu = 0.48999), rho = 1000 kg/m^3, no gravity. Used by
/// tests/test_mtled.cpp (MTLED against the references), bench/stability.cpp (the step
/// sweep and the other cylinder cases) and bench/accuracy.cpp (every solver, three
/// resolutions, error against wall time).
///
/// - Plates: boxes 2 cm thick (half-thickness kPlateHalfThickness), `halfWidth` in x and z,
///   the bottom one's upper face at y = 0 and the top one's lower face at y = H, in the
///   contact mode `ends` with friction 0 (Bonded: glued ends; Frictional: slip ends). MTLED's
///   end nodes lie on the faces: a band of a tenth of the node spacing holds them; the MPM
///   solvers use band 0 (the nodes inside the plate).
/// - Grid: MPM solvers dx = `resolution` with 8 particles per cell; MTLED dx = 1 cm (its
///   node spacing is `resolution`; the grid only bins the nodes). The domain's lower y face
///   and its x, z faces are whole cells from the origin (the plate face y = 0 lies on a node
///   layer and the axis on a node column at every dx); walls off.
/// - Ramp (eq. 43 of the paper): u(t) = D (10 - 15 s + 6 s^2) s^3, s = t / T, T = 3 s,
///   D = 0.2 H (20 %): the top plate moves down (compression), up (extension) or along +x
///   (shear, the plate's height kept).
/// - Force: the impulse the material gave the top plate over a frame divided by the
///   frame's length, negated (the force the plate applies to the cylinder; negative y in
///   compression).
struct CylinderBetweenPlates {
  static constexpr double kRadius = 0.05;      ///< R [m]
  static constexpr double kHeight = 0.1;       ///< H [m]
  static constexpr double kMu = 1007.0;        ///< shear modulus [Pa]
  static constexpr double kBulk = 50001.333;   ///< bulk modulus [Pa]
  static constexpr double kDensity = 1000.0;   ///< [kg/m^3]
  static constexpr double kRampTime = 3.0;     ///< T [s]
  static constexpr double kTravel = 0.02;      ///< D = 0.2 H: 20 % compression, extension or shear [m]
  static constexpr float kPlateHalfThickness = 0.02f;  ///< [m]
  /// Bonded 20 % compression at t = T, CalculiX extrapolated to zero mesh size
  /// (tests/reference/cylinder_compression_extrapolated.csv) [N].
  static constexpr double kBondedFinalForce = -6.804933;

  /// nu of the paper's mu and K, (3K - 2 mu) / (2 (3K + mu)) = 0.48999.
  static double seedPoissonRatio();
  /// The material with the paper's mu and Poisson ratio nu (E = 2 mu (1 + nu)).
  static Material material(double nu);
  /// P-wave speed sqrt((lambda + 2 mu) / rho) of a material [m/s].
  static double waveSpeed(const Material& m);
  /// (10 - 15 s + 6 s^2) s^3 with s clamped to [0, 1].
  static double smoothRamp(double s);

  enum class Loading { Compression, Extension, Shear };
  static const char* loadingName(Loading loading);  ///< "compression", "extension", "shear"

  /// What a run may vary; the defaults are tests/test_mtled.cpp's bonded MTLED run.
  struct Setup {
    SolverType solver = SolverType::Mtled;
    double resolution = 0.01;   ///< MPM: cell size dx; MTLED: node spacing [m]
    double nu = seedPoissonRatio();
    ContactMode ends = ContactMode::Bonded;
    float halfWidth = 0.1f;     ///< of the domain and the plates, x and z [m]
    int fixedSubsteps = 0;      ///< 0: the CFL policy (MTLED: eq. 37 times timeStepSafety)
    float mtledSafety = 0.5f;   ///< MtledSettings::timeStepSafety
    bool energyCheck = false;   ///< SceneSettings::energyCheck.enabled
    bool smoothedStrain = true; ///< MtledSettings::smoothedStrain
    double rampTime = kRampTime;  ///< T of the loading ramp [s]
    /// The plates' contact band [m]; negative: half a cell for the grid solvers (the node
    /// layer nearest each face follows the plate, ContactParams::band), a tenth of the node
    /// spacing for MTLED (its end nodes lie on the faces).
    float plateBand = -1.f;
    Backend backend = Backend::Cpu;
    int threads = 0;            ///< CPU threads; 0 = all
  };
  static SceneSettings settings(const Setup& setup);
  static ParticleObjectDesc cylinder(const Setup& setup);
  /// The bottom plate (upper face at y = 0) or the top one (lower face at y = H), at rest.
  static ShapeDesc plate(const Setup& setup, bool top);

  struct Parts {
    ParticleObjectId body;
    ShapeId bottom, top;
  };
  /// Adds the cylinder and both plates.
  static Parts build(Scene& scene, const Setup& setup);

  /// Top-plate displacement from its start at time t under `loading` [m] (x: shear,
  /// y: compression (negative) and extension).
  static std::array<double, 3> topDisplacement(Loading loading, double t, double rampTime = kRampTime);

  /// One run of the ramp: forces on the cylinder from the top plate at t = sample,
  /// 2 sample, ..., T.
  struct Run {
    std::vector<double> time;
    std::vector<double> axialForce;  ///< y [N] (negative: compression)
    std::vector<double> shearForce;  ///< x [N] (negative: against the shear)
    size_t particles = 0;            ///< particles or MTLED nodes
    long long substeps = 0;
    float substepDt = 0;             ///< of the last frame [s]
    double simulated = 0;            ///< time simulated, T + frame / 2 [s]
    double wallSeconds = 0, cpuSeconds = 0;  ///< the stepping only (not the set-up)
    EnergyBalance energy;            ///< at the end (with Setup::energyCheck)
  };
  /// Frames of `frame` seconds: the first [0, frame / 2], then [k frame - frame / 2,
  /// k frame + frame / 2], so every frame whose middle is a multiple of `sample` (sample a
  /// multiple of frame) gives the force there as the mean over a frame centred on it (the
  /// value at the sample to second order); the last is centred on T. The top plate gets its
  /// pose at the frame's start and the frame's mean velocity. `progress(t)` after each frame.
  /// A SimulationDiverged propagates.
  static Run run(const Setup& setup, Loading loading, double frame = 0.01, double sample = 0.1,
                 const std::function<void(double)>& progress = {});

  /// Columns of a reference CSV ('#' lines are comments, then one header line); throws
  /// mpm::Error when the file cannot be read.
  static std::vector<std::vector<double>> readCsv(const std::string& path);
  /// Value of a column at time t from (times, values) tabulated at the samples; NaN if absent.
  static double at(const std::vector<double>& times, const std::vector<double>& values, double t);
};

}  // namespace mpm::scenes
