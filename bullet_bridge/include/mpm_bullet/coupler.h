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
/// Per internal tick (DESIGN section 5, "Coupling loop"): Bullet steps the bodies; each
/// coupled body's shape takes the body's new pose and velocities; the scene advances over
/// the tick with its own substeps; the momentum the grid gave each shape goes back to its
/// body as an impulse (rigid bodies) or as a force over the next tick (multibody links).
///
/// Light bodies: inside the scene a dynamic body's velocity is updated implicitly every
/// substep with the mass of the nodes it touches (see shape_kernels.h), so a body lighter
/// than the tissue under it settles instead of oscillating; Bullet then receives exactly
/// the momentum the tissue gave up.
#include <functional>
#include <vector>

#include "mpm/scene.h"

class btDynamicsWorld;
class btRigidBody;
class btCollisionObject;
class btMultiBody;
class btMultiBodyLinkCollider;

namespace mpm::bullet {

/// Contact settings and sampling for a coupled body.
struct CouplingOptions {
  ContactParams contact;
  /// Sample spacing of signed distance grids built for meshes and hulls [m]; 0 = dx / 2.
  float sdfCellSize = 0.f;
};

class Coupler {
 public:
  /// Hooks `world`'s internal post-tick callback (Bullet has one slot; a callback that was
  /// set before is replaced: pass your own through setUserTickCallback instead).
  Coupler(btDynamicsWorld* world, Scene& scene);
  ~Coupler();  ///< unhooks the world
  Coupler(const Coupler&) = delete;
  Coupler& operator=(const Coupler&) = delete;

  /// Couples a rigid body (static, kinematic or dynamic) through its collision shape.
  ShapeId addRigidBody(btRigidBody* body, const CouplingOptions& options = {});
  /// Couples every link collider (and the base's) of a multibody.
  std::vector<ShapeId> addMultiBody(btMultiBody* body, const CouplingOptions& options = {});
  /// Stops coupling a body; its shape leaves the scene.
  void remove(const btCollisionObject* object);

  /// Called after each internal tick's coupling, with the tick length [s].
  void setUserTickCallback(std::function<void(float)> callback);

  /// Shape of a coupled object, e.g. to read its last impulse.
  ShapeId shapeOf(const btCollisionObject* object) const;

  /// The coupling step for one internal tick (called by the hook; public for tests).
  void tick(float dt);
  /// Adds (+1) or takes back (-1) the pending multibody link forces (pre-tick hook).
  void applyLinkForces(float sign);

 private:
  struct Link;
  ShapeId addObject(btCollisionObject* object, btRigidBody* rigid, btMultiBody* multi, int link,
                    const CouplingOptions& options);
  btDynamicsWorld* world_;
  Scene& scene_;
  std::vector<Link> links_;
  std::function<void(float)> userCallback_;
};

}  // namespace mpm::bullet
