#pragma once
/// Rigid shapes the MPM grid sees: a geometry with a signed distance (negative inside), a
/// rigid motion, and a contact model. They are how Bullet bodies, tools and fixtures push
/// on tissue; the grid pushes back through the impulse each shape accumulates.
#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "mpm/math.h"
#include "mpm/sdf_grid.h"

namespace mpm {

/// Unit quaternion (w, x, y, z).
struct Quat {
  float w = 1.f, x = 0.f, y = 0.f, z = 0.f;
};

/// Rigid placement: p_world = rotation * p_local + position.
struct Pose {
  Vec3f position{0.f, 0.f, 0.f};  ///< [m]
  Quat rotation;
};

/// Primitive geometry of one part of a shape, in the part's local frame.
enum class GeometryType {
  Plane,     ///< half-space y <= 0 (local): the solid is below the local x-z plane
  Box,       ///< halfExtents
  Sphere,    ///< radius
  Capsule,   ///< segment from -halfHeight to +halfHeight on the local `axis`, radius
  Cylinder,  ///< along the local `axis`, halfHeight, radius
  Mesh       ///< sampled signed distance grid (`sdf`)
};

/// One solid part. A shape with several parts is a compound.
struct Geometry {
  GeometryType type = GeometryType::Box;
  Vec3f halfExtents{0.05f, 0.05f, 0.05f};  ///< [m] (Box)
  float radius = 0.05f;                    ///< [m] (Sphere, Capsule, Cylinder)
  float halfHeight = 0.05f;                ///< [m] (Capsule, Cylinder)
  int axis = 1;                            ///< 0 = x, 1 = y, 2 = z (Capsule, Cylinder)
  std::shared_ptr<const SignedDistanceGrid> sdf;  ///< (Mesh), in the part's frame
  Pose localPose;  ///< the part in the shape's frame

  static Geometry box(Vec3f halfExtents) {
    Geometry g;
    g.type = GeometryType::Box;
    g.halfExtents = halfExtents;
    return g;
  }
  static Geometry sphere(float radius) {
    Geometry g;
    g.type = GeometryType::Sphere;
    g.radius = radius;
    return g;
  }
};

/// How the grid and a shape interact where the material touches it.
enum class ContactMode {
  Frictional,  ///< Coulomb friction mu_k then drag c_d on the tangential slip; separates freely
  Sticky,      ///< no slip while pressed on; separates freely
  /// no slip, no separation: clamps, graspers, glued ends. On a grid the material it touches
  /// stays glued while within a cell of it (pulled to 60 % strain, tests/test_grips.cpp)
  Bonded
};

struct ContactParams {
  ContactMode mode = ContactMode::Frictional;
  float friction = 0.f;  ///< kinetic friction coefficient mu_k, >= 0
  float drag = 1.f;      ///< c_d in [0, 1]: 1 = no drag, 0 = sticky
  /// Grid nodes whose signed distance to the shape is below `band` are in contact [m].
  /// 0: the nodes inside the solid, right for a tool pressing into tissue from outside
  /// (a band makes contact start `band` early: Hertz force +43 % at 0.25 dx, R = 4 dx).
  /// A shape holding material from the start (a compression plate, a clamp face) wants
  /// half a cell, 0.5 dx, so the node layer nearest its face follows it: the MTLED paper's
  /// cylinder between slip plates measured 25 % soft with 0 and 4 % with 0.5 dx at
  /// H = 10 dx (2.6 % at 20 dx). A Bonded shape holds every node within the band, and on a
  /// grid its band is never less than 0.5 dx.
  float band = 0.f;
};

/// Description of a rigid shape. mass = 0: kinematic (moved by the caller, unaffected by
/// the tissue); mass > 0: dynamic, its velocity responds to the tissue within a step.
/// Speed bound (here, in ShapeState, and for slicers and curves): no point of the shape
/// may move faster than SubstepPolicy::kMaxSubsteps (1e7) * cflFor(solver) * dx per
/// second, the speed that alone would need more substeps per simulated second than an
/// advance may take (16.5 km/s at dx = 3 mm with MLS-MPM's 0.55); linearVelocity beyond it,
/// or angularVelocity turning the shape's farthest point (a plane: the domain's diagonal)
/// beyond it, is refused where it is given (InvalidArgument naming the field).
struct ShapeDesc {
  std::vector<Geometry> parts;  ///< one part, or several for a compound
  Pose pose;
  Vec3f linearVelocity{0.f, 0.f, 0.f};   ///< of the centre of mass [m/s]
  Vec3f angularVelocity{0.f, 0.f, 0.f};  ///< [rad/s], world frame
  Vec3f centerOfMass{0.f, 0.f, 0.f};     ///< in the shape frame [m]
  ContactParams contact;
  float mass = 0.f;                      ///< [kg]; 0 = kinematic
  Vec3f inertia{0.f, 0.f, 0.f};          ///< principal moments in the shape frame [kg m^2]
  Vec3f gravity{0.f, 0.f, 0.f};          ///< acceleration a dynamic shape feels between substeps
};

/// Handle to a shape.
struct ShapeId {
  uint32_t index = std::numeric_limits<uint32_t>::max();
  uint32_t generation = 0;
};

/// Momentum the grid gave a shape during the last advance(): the impulse [N s] at the centre
/// of mass and the angular impulse about it [N m s], world frame.
struct ShapeImpulse {
  Vec3f linear{0.f, 0.f, 0.f};
  Vec3f angular{0.f, 0.f, 0.f};
};

/// Pose and velocity of a shape (after a step, a dynamic shape's velocity includes the
/// tissue's push).
/// Its velocities are bounded as ShapeDesc's are.
struct ShapeState {
  Pose pose;
  Vec3f linearVelocity{0.f, 0.f, 0.f};
  Vec3f angularVelocity{0.f, 0.f, 0.f};
};

}  // namespace mpm
