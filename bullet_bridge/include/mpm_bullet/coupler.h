#pragma once
/// Two-way coupling of an mpm::Scene with a Bullet world. The coupler hooks Bullet's
/// internal tick, so the user keeps calling world->stepSimulation() as before:
///
///   mpm::Scene scene(settings);                              // the tissue
///   scene.addParticleObject(tissue);
///   mpm::bullet::Coupler coupler(world, scene);             // btDiscreteDynamicsWorld* or
///   coupler.addRigidBody(tool);                              // btMultiBodyDynamicsWorld*
///   world->stepSimulation(1.f / 60, 10, 1.f / 240);          // tissue advances with Bullet
///
/// Per internal tick (the coupling loop, run at the start of each tick, so
/// it sits between Bullet's previous tick and its next): each coupled body's shape takes
/// the body's pose and velocities; the scene advances over the tick with its own substeps,
/// a dynamic shape feeling its body's gravity there; the momentum the grid gave each shape
/// goes to its body as an impulse (rigid bodies) or as a force over the tick (multibody
/// links) before Bullet integrates the tick.
///
/// Why gravity inside the scene and the impulse before Bullet's integration: applying the
/// impulse after Bullet had already moved the body with this tick's gravity would let a
/// resting body creep into the tissue by g dt^2 every tick (measured: a 20 g box sank 1.6 cm
/// into a stiff slab in 0.8 s that way).
///
/// Light bodies: inside the scene a dynamic body's velocity is updated implicitly every
/// substep with the mass of the nodes it touches (see contact/rigid_body.h), so a body lighter
/// than the tissue under it settles instead of oscillating; Bullet then receives exactly
/// the momentum the tissue gave up.
///
/// Errors: Bullet is not exception-safe, so nothing the coupling throws inside a tick (the
/// scene's SimulationDiverged, an InvalidArgument, the user tick callback's own exceptions)
/// unwinds through stepSimulation. The first one is kept and the coupling is suspended:
/// the rest of that stepSimulation, and any later one, runs Bullet alone (no scene step,
/// no impulses, no user callback) until the caller takes the error:
///
///   world->stepSimulation(1.f / 60, 10, 1.f / 240);
///   coupler.rethrowError();  // throws the kept exception (its own type), then resumes
///
/// The scene is as it was before the failed tick (Scene::fetchResults), so its clock
/// counts the completed ticks only.
///
/// Coupling at the rate the solver wants (setTissueInterval): a solver whose stable step
/// is longer than Bullet's tick (PB-MPM) need not advance at every tick. With an interval
/// of n ticks the tissue advances once every n ticks, over all n at once, at the start of
/// the first, from the bodies' poses and velocities then (its dynamic shapes move on with
/// their own mass and gravity through the advance); the momentum the grid gave each shape
/// goes to its body spread evenly over the n ticks (a share of 1/n as an impulse before
/// each tick, or as a force over it), so at the end of the interval Bullet's body has it
/// all, and the next advance takes the bodies' states again. Within an interval the
/// scene's clock is ahead of Bullet's. What it costs in accuracy is measured in
/// tests/test_bullet_coupling.cpp (TissueInterval) and bench/results/epyc-2core/embedding_realtime.md.
#include <exception>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "mpm/scene.h"

class btDynamicsWorld;
class btIDebugDraw;
class btRigidBody;
class btCollisionObject;
class btMultiBody;
class btMultiBodyLinkCollider;

namespace mpm::bullet {

/// How a coupled body touches the tissue: mpm::ContactParams, except that the friction
/// is the Bullet body's own unless set here.
///
/// Mapping of Bullet's contact properties (read when the body is added):
/// - btCollisionObject::getFriction() (of the rigid body, or of each multibody link
///   collider) becomes the shape's kinetic friction coefficient mu_k (ContactParams::
///   friction) as it is: the tissue has no Bullet friction of its own to combine with
///   (Bullet multiplies the two bodies' coefficients). Set `friction` to override it.
/// - Rolling and spinning friction do not apply: they are torques Bullet's solver puts at
///   a contact point to stand for a contact patch it does not model; on the grid the patch
///   is resolved, node by node with Coulomb friction, so the tissue's own deformation gives
///   that resistance.
/// - Restitution does not apply: the grid contact removes the approaching normal velocity
///   of each node (perfectly inelastic there), and any rebound comes from the tissue's
///   elasticity and damping. Contact stiffness/damping and anisotropic friction neither.
struct CouplingContact {
  ContactMode mode = ContactMode::Frictional;
  /// Kinetic friction coefficient mu_k, >= 0; unset: the body's getFriction().
  std::optional<float> friction;
  float drag = 1.f;  ///< as ContactParams::drag
  float band = 0.f;  ///< as ContactParams::band [m]

  CouplingContact() = default;
  /// All of `p`, its friction included (an explicit override). Implicit on purpose, so
  /// `options.contact = params` keeps meaning what it did.
  CouplingContact(const ContactParams& p) : mode(p.mode), friction(p.friction), drag(p.drag), band(p.band) {}
  /// The shape's contact parameters for a body whose Bullet friction is `bodyFriction`.
  ContactParams resolve(float bodyFriction) const;
};

/// How a thread (a chain multibody, mpm_bullet/suture.h) is coupled: Coupler::addThread.
struct ThreadCoupling {
  /// [m] the thread's radius in the tissue; <= 0: the radius of the base collider's
  /// btCapsuleShape (makeSutureThread's capsules).
  float radius = 0.f;
  float friction = 0.f;  ///< as LineSegmentsDesc::friction (mu_k of the slip along the thread)
  float drag = 1.f;      ///< as LineSegmentsDesc::drag
  /// true: the segments are dynamic in the scene (LineSegmentsDesc::linearDensity = the
  /// links' total mass over the thread's length, gravity = the world's), and each
  /// segment's impulse goes back to its link as a force over the tick. false: kinematic
  /// segments, one-way (the thread pushes the tissue; its links get nothing back).
  bool dynamic = true;
  /// With `dynamic`: the added-mass coupling, in which the tissue holds the thread with its
  /// whole resistance. The scene's segments are kinematic (the nodes round a segment move
  /// with it across itself), and each link carries in Bullet, besides its own mass, the
  /// mass of the nodes its segment held in the last advance (Scene::segmentContactMasses;
  /// its inertia scaled alike), so Bullet's joints and pins, solving the chain, move that
  /// tissue too. The force on the link over the tick is the segment's impulse less the part
  /// that brought those nodes to the segment's change of velocity across itself (counted
  /// once, by the added mass): the tissue's elastic push and its drag. Without it a dynamic
  /// segment's link receives only the segment's own momentum change, so the tissue holds it
  /// with at most m v_rel / dt: a light thread passes through the tissue when pulled
  /// (tests/test_suturing_bullet.cpp, PullingTheStitch). The links' masses are the thread's
  /// own again after removeThread.
  bool addedMass = false;
};

/// Contact settings and sampling for a coupled body.
struct CouplingOptions {
  CouplingContact contact;
  /// Sample spacing of signed distance grids built for meshes and hulls [m]; 0 = dx / 2.
  float sdfCellSize = 0.f;
};

/// What Coupler::debugDraw draws and in which colours (RGB in [0, 1]).
struct DebugDrawOptions {
  /// [m] length of each of the three lines of a particle's cross; 0: a quarter of dx.
  float particleSize = 0.f;
  int particleStride = 1;  ///< draws every n-th particle of each object (n >= 1)
  Vec3f tissueColor{1.f, 0.55f, 0.7f};  ///< pink
  Vec3f toolColor{0.6f, 0.6f, 0.6f};    ///< grey: blades and needles
  Vec3f threadColor{0.2f, 0.4f, 1.f};   ///< blue
};

class Coupler {
 public:
  /// Hooks `world`'s internal pre- and post-tick callbacks (Bullet has one slot of each; a
  /// callback set before is replaced: pass your own through setUserTickCallback instead).
  Coupler(btDynamicsWorld* world, Scene& scene);
  ~Coupler();  ///< unhooks the world
  Coupler(const Coupler&) = delete;
  Coupler& operator=(const Coupler&) = delete;

  /// Couples a rigid body (static, kinematic or dynamic) through its collision shape.
  ShapeId addRigidBody(btRigidBody* body, const CouplingOptions& options = {});
  /// Couples every link collider (and the base's) of a multibody.
  std::vector<ShapeId> addMultiBody(btMultiBody* body, const CouplingOptions& options = {});
  /// Couples a rigid body (kinematic or dynamic) as a slicer, a scalpel: `blade.pose` is
  /// the blade's frame in the body's centre-of-mass frame (its velocities are not used:
  /// the blade moves with the body). Every tick the slicer takes the body's motion, and a
  /// dynamic body receives what the tissue gave the slicer: the faces' and the spine's
  /// contact and the resistance to cutting (Material::fractureToughness). The body's
  /// collision shape is not coupled by this: a handle that should push tissue is added
  /// with addRigidBody too.
  SlicerId addSlicer(btRigidBody* body, const QuadSlicerDesc& blade);
  /// Slicer of a body coupled with addSlicer, e.g. to read its last impulse.
  SlicerId slicerOf(const btRigidBody* body) const;
  /// Couples a rigid body (kinematic or dynamic) as a suture needle (mpm/curves.h):
  /// `needle.pose` is the arc's frame in the body's centre-of-mass frame (its velocities
  /// are not used). Every tick the curve takes the body's motion (the arc frame origin's
  /// velocity v + w x r), and a dynamic body receives Scene::curveImpulse (given about the
  /// arc frame's origin; the lever torque is added here). The force on the needle over a
  /// tick is that impulse over lastTickDt(). As with addSlicer, the body's collision shape
  /// is not coupled by this. The needle is kinematic inside the scene (ArcDesc has no mass),
  /// so this coupling is explicit: the body must be heavier than the tissue it drags
  /// (tests/test_suturing_bullet.cpp: 10 to 50 g bodies thrown into a 30 kPa block at
  /// dx 2.5 mm conserve momentum to 1e-6; a 5 g body diverged). Give it the mass of what
  /// holds it (a NeedleDriver's hand and holder).
  CurveId addNeedle(btRigidBody* body, const ArcDesc& needle);
  /// Curve of a body coupled with addNeedle.
  CurveId needleOf(const btRigidBody* body) const;
  /// Couples a thread: a chain multibody (link i's parent i - 1, base symmetric about its
  /// centre; makeSutureThread builds one) as a LineSegmentsDesc whose points are the
  /// chain's (threadPoints: the base's outer end, each joint, the last link's outer end).
  /// Every tick the points and their velocities (each from its segment's v + w x r) go to
  /// the scene; with `options.dynamic` each segment's impulse (Scene::segmentImpulses,
  /// segment 0 the base, segment i link i - 1) goes back to its link as a force over the
  /// tick, added before the tick and taken back after it, as for multibody links.
  ///
  /// Stability (measured, tests/test_suturing_bullet.cpp and demos/suturing): a thread
  /// thrown through a block (E 30 kPa, dx 2.5 mm, ticks of 1/960 s) is stable with
  /// segments of two cells (5 mm) and 1e-2 kg/m, and blows up within a few ticks with
  /// segments of one cell or with 1e-3 kg/m: the scene's implicit update of adjacent
  /// light segments amplifies a zigzag between them (the scene alone, without Bullet:
  /// point velocities +-0.02 m/s give segment velocity changes of 0.29 m/s in one 1/960 s
  /// advance with 30 segments of 2 mm at 1e-3 kg/m, 1.2 m/s at 1e-4 kg/m). A thread
  /// segment that shares grid nodes with a moving needle takes the needle's drag in one
  /// tick: keep the thread away from where the needle goes in.
  CurveId addThread(btMultiBody* thread, const ThreadCoupling& options = {});
  /// Curve of a thread coupled with addThread.
  CurveId threadOf(const btMultiBody* thread) const;
  /// Stops coupling a thread (its curve leaves the scene).
  void removeThread(const btMultiBody* thread);
  /// Stops coupling a body (its shape, its slicer, its needle: they leave the scene; cuts
  /// stay). A collider of a coupled thread removes the whole thread.
  void remove(const btCollisionObject* object);

  /// Called at the start of each internal tick, before the coupling step, with the tick
  /// length [s]: the place for a NeedleDriver's tick (mpm_bullet/suture.h). Like the user
  /// callback it does not run while an error is kept (see the top of this file).
  void setPreTickCallback(std::function<void(float)> callback);
  /// Length of the last internal tick [s] (0 before the first): a needle's force is
  /// Scene::curveImpulse / (tissueInterval() lastTickDt()), a segment's likewise.
  float lastTickDt() const { return lastDt_; }

  /// Advances the tissue once every `ticks` internal ticks (>= 1; 1, the default: every
  /// tick), over the whole interval (see the top of this file). For fixed ticks
  /// (stepSimulation with maxSubSteps > 0): the advance covers `ticks` times the tick it
  /// starts in. From the next tick that starts an interval; while one is open (the scene
  /// ahead of Bullet) the call throws InvalidArgument. A thread's segments take their
  /// shares as forces over each tick, and with the added mass their links carry the held
  /// nodes' mass through the interval: so a thread can tick at Bullet's small step while
  /// PB-MPM takes its own (PullingTheStitch.ClosesTheGapPbMpm).
  void setTissueInterval(int ticks);
  int tissueInterval() const { return tissueInterval_; }
  /// Whether the tissue advanced in the last tick (at every tick with an interval of 1):
  /// the scene's impulses (Scene::shapeImpulse, ...) are those of that advance, over
  /// tissueInterval() ticks.
  bool tissueAdvanced() const { return advancedThisTick_; }

  /// Called after each internal tick, with the tick length [s].
  void setUserTickCallback(std::function<void(float)> callback);

  /// The exception a tick threw inside stepSimulation, or null. While one is kept the
  /// coupling is suspended (see the top of this file).
  std::exception_ptr error() const { return error_; }
  /// Throws the kept exception, if any, and clears it: the coupling resumes with the next
  /// tick. Call it after each stepSimulation.
  void rethrowError();

  /// Checkpoints of a coupled scene: Scene::save with the poses and velocities of the
  /// coupled Bullet bodies (rigid bodies: transform, linear and angular velocity;
  /// multibodies: base pose and velocities, joint positions and velocities) as its
  /// attachment, so rewinding puts the tools back where the tissue was: the bodies of the
  /// slicers and needles, each thread's chain and its added mass's velocities too (the
  /// scene keeps the needles' tips and the threads' points). Not kept: pins and drivers
  /// (the caller's, as built), the warm-start caches of Bullet's own contacts (body on
  /// body), a thread's pins' share of its tension on the last tick (ThreadBending: it
  /// starts from none, which matters only while the tension's implicit rows act) and the
  /// world's clock (the leftover time of a fixed-step stepSimulation). Bodies touching
  /// only the tissue step on bit for bit as the run that was saved; with Bullet contacts
  /// they resume from the same poses and velocities. load() refuses (CheckpointError, Unsupported)
  /// a checkpoint whose coupled bodies differ in number or kind from this coupler's, and
  /// then changes neither the scene nor the bodies. With a tissue interval, save() refuses
  /// (Unsupported) while an interval is open (the scene ahead of Bullet); stepSimulation
  /// by whole intervals saves between them.
  void save(const std::string& path) const;
  std::vector<uint8_t> saveToMemory() const;
  void load(const std::string& path);
  void loadFromMemory(const std::vector<uint8_t>& checkpoint);

  /// Shape of a coupled object, e.g. to read its last impulse.
  ShapeId shapeOf(const btCollisionObject* object) const;

  /// Draws the tissue and the coupled tools as lines through a Bullet debug drawer
  /// (`drawer`, else the world's getDebugDrawer()), so they show in the viewer that draws
  /// the world: each particle a cross of three lines along the axes; each blade's outline
  /// (edge, ends, spine) and each needle's arc (32 lines, tail to tip) in their poses after
  /// the last advance, as the tissue saw them; each thread's polyline (threadPoints). Draws
  /// nothing without a drawer or when its getDebugMode() is DBG_NoDebug. Between steps;
  /// a bad option throws InvalidArgument naming it.
  void debugDraw(btIDebugDraw* drawer = nullptr, const DebugDrawOptions& options = {}) const;

  /// The coupling step for one internal tick (called by the hook; public for tests).
  void tick(float dt);
  /// End of an internal tick: takes back multibody coupling forces, calls the user.
  void finishTick(float dt);
  /// What Bullet's hook calls: tick (pre) or finishTick, with any exception caught and
  /// kept in error() instead of unwinding through Bullet; nothing runs while one is kept.
  void hookedTick(float dt, bool pre) noexcept;

 private:
  struct Link;
  struct SlicerLink;
  struct NeedleLink;
  struct ThreadLink;
  /// Takes back the thread segments' coupling forces of this tick (after it, or on error).
  void takeBackThreadForces();
  /// The coupled bodies' poses and velocities, as a checkpoint's attachment.
  std::vector<uint8_t> bodiesAttachment() const;
  ShapeId addObject(btCollisionObject* object, btRigidBody* rigid, btMultiBody* multi, int link,
                    const CouplingOptions& options);
  btDynamicsWorld* world_;
  Scene& scene_;
  std::vector<Link> links_;
  std::vector<SlicerLink> slicers_;
  std::vector<NeedleLink> needles_;
  std::vector<ThreadLink> threads_;
  std::function<void(float)> userCallback_;
  std::function<void(float)> preTickCallback_;
  float lastDt_ = 0.f;
  int tissueInterval_ = 1;          ///< ticks per tissue advance
  int intervalTick_ = 0;            ///< ticks of the open interval done (0: the next tick advances)
  bool advancedThisTick_ = false;
  /// Applies each body's share of the last advance's impulses before this tick.
  void applyShares(float dt);
  /// Forgets the open interval and its shares (after an error, a load).
  void resetInterval();
  /// Steps 1-3 of the coupling: bodies to shapes, the scene's advance over the interval
  /// starting with this tick of length dt, the impulses as shares.
  void advanceTissue(float dt);
  std::exception_ptr error_;
};

}  // namespace mpm::bullet
