#pragma once
/// Settings structs: plain data with defaults and units, validated once when handed to a
/// Scene (see validate.h for the rules; every violation names the field and the value).
#include <cstdint>
#include <limits>
#include <memory>

#include "mpm/math.h"
#include "mpm/sdf_grid.h"

namespace mpm {

/// Which algorithm advances the particles (all share shapes, contact, walls and output).
enum class SolverType {
  MlsMpm,       ///< moving-least-squares MPM with APIC transfers (Hu et al. 2018); the default
  StandardMpm,  ///< explicit update-stress-last MPM with a PIC/FLIP blend
  PbMpm,        ///< position-based MPM (Lewin 2024): iterated constraint projection, large steps
  /// meshless Total Lagrangian explicit dynamics (Horton et al. 2010): the
  /// particles are nodes, stress lives on a background grid of integration points; no MPM
  /// grid, no domain walls (boundary conditions come from the shapes)
  Mtled
};

/// Parameters of SolverType::StandardMpm.
struct StandardMpmSettings {
  /// FLIP share of the particle velocity update, in [0, 1]: 0 is PIC (stable, dissipates
  /// motion), 1 is pure FLIP (keeps motion, noisy).
  float flipBlend = 0.95f;
};

/// Parameters of SolverType::PbMpm (the 3D form is documented in src/solvers/pb_mpm.h).
/// Its stiffness comes from the iterations, not from Material::youngsModulus.
struct PbMpmSettings {
  int iterations = 10;     ///< P2G-G2P constraint iterations per substep, in [1, 1000]
  float relaxation = 1.f;  ///< share of each iteration's correction of the velocity gradient, in (0, 2)
  /// beta: 1 projects the deformation onto a rotation (elastic), 0 onto its volume-
  /// preserving part (incompressible, shape free); in [0, 1].
  float rigidity = 1.f;
};

/// Parameters of SolverType::Mtled (the MTLED paper, Horton et al. 2010, sections 2-3; n,
/// alpha and the integration density are the paper's).
struct MtledSettings {
  /// n: nearest nodes in each integration point's support domain, in [4, 32]. The linear
  /// basis has m = 4 terms; the paper takes n = 2m.
  int supportNodes = 8;
  /// alpha > 1 of eq. 8: support radius = alpha * distance of the farthest of the n nodes.
  /// Large alpha weights the n nodes almost equally (the paper uses 10); in (1, 1000].
  float supportScale = 10.f;
  /// Background integration cells per node spacing along each axis, in [1, 4]. 1.26 gives
  /// the paper's two integration points per node (section 3.2).
  float integrationCellsPerSpacing = 1.26f;
  /// true: each point's shape-function derivatives are their average over its cell's
  /// material, by the divergence theorem from the shape functions on the cell's surface
  /// (smoothed strain, as in stabilized conforming nodal integration, Chen et al. 2001,
  /// over the background cells). Faces two cells share cancel, so the interior passes the
  /// patch test. The paper's cylinder, node spacing 0.01 / 0.0083 / 0.00625 m: slip ends
  /// within 0.19 / 0.40 / 0.34 % of the closed form (the rest: the voxel volume, and the
  /// end faces' second node layer, which feels the stress there as MLS is not
  /// interpolating); bonded ends +6.0 / +1.5 / +2.4 % (final force), stiff like finite
  /// elements of the coarsest size. Costs about 14 instead of n nodes per point and half
  /// the critical step. false: the MLS derivatives at the point, as in the paper. These
  /// fail the patch test (the n-nearest supports make the shape functions discontinuous,
  /// so the derivatives do not sum to the surface integral of the shape function and a
  /// uniform stress leaves interior nodes unbalanced): slip ends about 3 % soft at every
  /// spacing (2.9 / 3.3 / 3.1 %), bonded +1.1 / +0.1 / -3.5 %, near the reference at the
  /// coarse spacings only because that softness offsets the coarse model's stiffness.
  bool smoothedStrain = true;
  /// Substep = timeStepSafety * the critical step of eq. 37, in (0, 1]. Eq. 37 is not a
  /// bound here: the paper's cylinder (node spacing 0.01 m) compressed ten times faster
  /// is stable to 0.906 of it and fails at 0.938 with smoothed strain (bench_stability);
  /// with the point derivatives it ran at 0.6 and diverged at 0.9, stable to 0.625 and
  /// failing at 0.656 in the fast compression (the paper found 1.34 on its own cylinder).
  float timeStepSafety = 0.5f;
};

/// Where the kernels run. `Auto` picks CUDA when a device is present, else the CPU.
enum class Backend { Auto, Cpu, Cuda };

/// What the domain walls do to grid velocity pointing into them.
enum class WallMode {
  Sticky,   ///< all velocity removed: material touching the wall stops
  Slip,     ///< normal velocity removed, tangential kept (frictionless, never separates)
  Separate  ///< only the inward normal velocity removed: material may leave the wall
};

/// The box that holds the grid, and how its faces act on the material.
struct DomainSettings {
  Vec3f lower{-1.f, -1.f, -1.f};  ///< lower corner [m]
  Vec3f upper{1.f, 1.f, 1.f};     ///< upper corner [m]
  bool walls = true;              ///< false: no wall conditions (material must stay inside)
  WallMode wallMode = WallMode::Separate;
  int wallThickness = 2;          ///< cells at each face that the wall acts on (>= 1)
  /// Lower faces (x, y, z) that are mirror (symmetry) planes: the scene holds the part of
  /// a body symmetric about them on their upper side (a half, quarter or eighth model) and
  /// the material moves as the whole body would. Each plane is the node layer
  /// wallThickness cells inside its lower face, lower + wallThickness * dx, and replaces
  /// that face's wall; material must start on its upper side. Shape impulses are those on
  /// the modelled part (half of the whole per plane for a shape centred on it); bodies are
  /// not mirrored, so use mirror planes with static or kinematic shapes.
  bool mirrorLower[3] = {false, false, false};

  /// Position of the mirror plane of `axis` (if mirrorLower[axis]) for cell size dx [m].
  float mirrorPlane(int axis, float dx) const { return lower[axis] + (float)wallThickness * dx; }
};

/// The CFL number a solver takes when SubstepPolicy::cflNumber is 0, each a stated margin
/// under the largest stable step bench_stability measured (its step sweep, the MTLED paper's
/// cylinder at nu = 0.49 compressed fast; bench/results/epyc-2core/stability.md), in units of dx / c_p:
/// - MLS-MPM 0.55: stable to 1.06, failing at 1.12 (a margin of 1.93x). Not more: at 0.6
///   the Python tests' mesh cube pushed 1.6 % off its box (bound 1 %) and their resting
///   sphere's 0.8-1.2 s average read +2.5 % (bound 2 %: it still rocks, less damped), and at
///   0.7 a sticky wall's hold fails (Walls.StickyFloorHoldsTheBottomLayer: the bottom layer
///   slips 3.7 / 13.1 / 14.0 / 15.8 mm at 0.3 / 0.55 / 0.6 / 0.7, bound 15 mm);
/// - standard MPM 0.55: stable to 0.875, failing at 0.906 (1.59x);
/// - PB-MPM 0.3: not bound by c_p (stable beyond 8); the number bounds how far particles
///   and shapes move per substep only (0.3 of a cell), as before;
/// - MTLED 0.3: its elastic bound is MtledSettings::timeStepSafety; this bounds motion only.
inline float defaultCflNumber(SolverType solver) {
  switch (solver) {
    case SolverType::MlsMpm: return 0.55f;
    case SolverType::StandardMpm: return 0.55f;
    default: return 0.3f;
  }
}

/// How an `advance(dt)` is cut into substeps.
struct SubstepPolicy {
  /// Substep = cflNumber * dx / (fastest elastic wave speed + fastest particle speed), in
  /// [0, 1]; 0: the solver's own default (defaultCflNumber). Earlier versions' default
  /// was 0.3 for every solver (a margin of 3.5x for MLS-MPM): set 0.3 to get that back.
  float cflNumber = 0.f;
  /// If > 0, use exactly this many substeps per advance() and skip the CFL bound; at
  /// most kMaxSubsteps.
  int fixedSubsteps = 0;
  /// Most substeps one advance takes (the CFL count, fixedSubsteps, and recovery's
  /// halvings of either): a day of substeps at 10 ms each. More means a material, speed
  /// or spacing far from what the scene can step (E = 1e30 Pa asks for 2.4e12 substeps in
  /// a millisecond); an int count would also overflow.
  static constexpr int kMaxSubsteps = 10000000;

  /// The CFL number in force for `solver`: cflNumber, or the solver's default when 0.
  float cflFor(SolverType solver) const { return cflNumber > 0.f ? cflNumber : defaultCflNumber(solver); }
};

/// Opt-in blow-up detection by energy. The checks for non-finite states and particles
/// leaving the grid always run; this one costs a read-back of the particles per advance
/// (one pass over them, as summary() does; measured 0.7-2 ms at 8k corotated particles on a
/// busy 2-core VM, 15-57 % of one substep), so scenes that leave it off do not pay.
/// Energy is kinetic + gravity's potential (relative to the start) + strain energy W(F)
/// where the solver's forces come from F and E (MLS-MPM, standard MPM; not PB-MPM, whose
/// stiffness is its iterations', nor MTLED, whose strain lives at integration points):
/// a lower bound of the true energy, so the check never blames a solver for energy it
/// does not measure. An advance fails with SimulationDiverged when the energy exceeds its
/// start plus the work the shapes did on the material by more than `tolerance` times the
/// energy supplied so far (initial kinetic + strain energy, the shapes' positive work, the
/// largest potential energy gravity has released, and a noise floor).
struct EnergyCheck {
  bool enabled = false;
  /// Allowed excess as a share of the energy supplied, > 0. Explicit blow-ups grow the
  /// energy geometrically (many times the supply within a few steps); the stable runs of
  /// bench_stability stayed at or below 0.017, but for the largest stable step of
  /// MLS-MPM's sweep, at the edge of stability (0.27; bench/results/epyc-2core/stability.md).
  float tolerance = 0.5f;
  /// Noise floor: energies below 1/2 M noiseSpeed^2 (M the scene's particle mass) are not
  /// judged, so a scene at rest does not fail on rounding [m/s], >= 0.
  float noiseSpeed = 1e-3f;
};

/// Bounds of a particle's volume ratio J = det F that the step check holds every substep,
/// with the non-finite state and the stencil leaving the grid: material squeezed to a
/// hundredth of its volume or swollen a hundredfold has collapsed or blown up (a fixed
/// corotated block given a substep 1.5 times its stable one ends with J = 0 everywhere,
/// every value finite). Soft tissue under surgical loads stays within J of 0.5 to 2.
constexpr float kMinVolumeRatio = 1e-2f;
constexpr float kMaxVolumeRatio = 1e2f;

/// Per-particle checks of every advance, on by default: an advance fails with
/// SimulationDiverged (naming the particle, its object and the cause) when a particle's
/// volume ratio J = det F leaves (kMinVolumeRatio, kMaxVolumeRatio) or a particle moved
/// more than `maxCellsPerSubstep` cells in one substep (the transfers assume a particle
/// stays within its stencil; faster, the step is too long for the motion). With recovery
/// the advance is taken again with half the substep. The volume check runs inside G2P
/// (grid solvers; MTLED's nodes carry no F of their own), the speed check reads the
/// fastest particle of each substep: no extra pass over the particles.
struct DivergenceCheck {
  bool enabled = true;
  /// Largest distance a particle may move in one substep, in cells, > 0.
  float maxCellsPerSubstep = 1.f;
};

/// Keeps a scene going through an advance that diverges (off by default): the advance is
/// rolled back to the state before it and taken again with half the substep, up to
/// `maxHalvings` times, and StepReport::halvings says how often. Diverges means what
/// SimulationDiverged reports: a non-finite state, a particle leaving the grid, (with
/// divergenceCheck) a volume ratio out of bounds or a particle faster than the substep
/// allows, or (with energyCheck) energy from nowhere. Each retry costs the work of the failed attempts; the
/// next advance starts again from the substep policy's count. Off, a diverging advance
/// throws and leaves the scene as it was before it.
struct Recovery {
  bool enabled = false;
  /// Halvings of the substep one advance may try before it throws, in [1, 20].
  int maxHalvings = 4;
};

/// Everything a Scene needs at creation.
struct SceneSettings {
  DomainSettings domain;
  float dx = 0.05f;                 ///< grid cell size [m]
  Vec3f gravity{0.f, -9.81f, 0.f};  ///< [m/s^2]
  SolverType solver = SolverType::MlsMpm;
  StandardMpmSettings standardMpm;  ///< used when solver == StandardMpm
  PbMpmSettings pbMpm;              ///< used when solver == PbMpm
  MtledSettings mtled;              ///< used when solver == Mtled
  /// Substeps per advance. PB-MPM is not bound by the elastic wave speed: with the CFL
  /// policy its substep follows particle and shape speed only. MTLED also takes no more
  /// than its own stable step (MtledSettings::timeStepSafety).
  SubstepPolicy substeps;
  EnergyCheck energyCheck;  ///< off by default
  DivergenceCheck divergenceCheck;  ///< on by default
  Recovery recovery;        ///< off by default
  Backend backend = Backend::Auto;
  int cpuThreads = 0;  ///< CPU backend worker threads; 0 = all hardware threads
};

/// Constitutive law of a particle object.
enum class MaterialModel {
  FixedCorotated,     ///< Stomakhin et al. 2012: 2 mu (F - R) + lambda (J - 1) J F^-T
  NeoHookeanDecoupled ///< W = C10 (I1bar - 3) + (J - 1)^2 / D1, C10 = mu/2, D1 = 2/K (Abaqus form)
};

/// Elastic material. Lamé parameters follow from E and nu.
struct Material {
  MaterialModel model = MaterialModel::FixedCorotated;
  float youngsModulus = 1e4f;  ///< E [Pa], > 0
  float poissonRatio = 0.3f;   ///< nu, in (-1, 0.5)
  float density = 1000.f;      ///< rho [kg/m^3], > 0
  /// Fracture toughness G_c [J/m^2], >= 0: the energy a slicer spends per unit area of new
  /// cut. The blade feels it as a force of G_c times the length of its cutting boundary
  /// engaged in the material, against its cutting motion (liver about 160, gels about 200).
  /// 0: cutting costs nothing.
  float fractureToughness = 0.f;
};

/// Geometry a particle object is sampled from.
enum class PrimitiveType {
  Box,     ///< halfExtents about center
  Sphere,    ///< radius about center
  Cylinder,  ///< axis along y through center: `radius`, half-height `halfExtents.y`
  Mesh       ///< the inside of a closed mesh, given as its signed distance grid `mesh`
};

/// Description of a body of material points.
struct ParticleObjectDesc {
  PrimitiveType primitive = PrimitiveType::Box;
  Vec3f center{0.f, 0.f, 0.f};         ///< [m]
  Vec3f halfExtents{0.1f, 0.1f, 0.1f};  ///< box half sizes [m] (Box); .y: half-height (Cylinder)
  float radius = 0.1f;                  ///< [m] (Sphere, Cylinder)
  /// (Mesh) signed distance grid of a watertight mesh, in a frame whose origin is placed
  /// at `center` (see buildSignedDistanceGrid). A grid whose sign is unreliable (mesh not
  /// watertight) is refused: inside is not defined.
  std::shared_ptr<const SignedDistanceGrid> mesh;
  /// Particles per grid cell along each axis (2 gives the usual 8 per cell). Ignored when
  /// particleSpacing > 0. With SolverType::Mtled the particles are the nodes, placed on a
  /// lattice whose outermost nodes lie on the object's bounds (on a box's or cylinder's
  /// faces, where boundary conditions act) instead of half a spacing inside.
  int particlesPerCellAxis = 2;
  /// If > 0, lattice spacing of the particles [m] instead of dx / particlesPerCellAxis.
  float particleSpacing = 0.f;
  Material material;
  Vec3f velocity{0.f, 0.f, 0.f};         ///< initial linear velocity [m/s]
  Vec3f angularVelocity{0.f, 0.f, 0.f};  ///< initial spin about `center` [rad/s]
};

/// Handle to a particle object: stays valid or is detectably stale, never dangles.
struct ParticleObjectId {
  uint32_t index = std::numeric_limits<uint32_t>::max();
  uint32_t generation = 0;
};

}  // namespace mpm
