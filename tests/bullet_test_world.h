#pragma once
// A Bullet world of either type for the coupling tests, owning what is added to it, and
// the fixture of the suites that run for every (world type, solver) pair.
#include <gtest/gtest.h>

#include <btBulletDynamicsCommon.h>
#include <BulletDynamics/Featherstone/btMultiBody.h>
#include <BulletDynamics/Featherstone/btMultiBodyConstraintSolver.h>
#include <BulletDynamics/Featherstone/btMultiBodyDynamicsWorld.h>
#include <BulletDynamics/Featherstone/btMultiBodyLinkCollider.h>

#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "solver_cases.h"

namespace mpm::test {

enum class WorldType { Discrete, MultiBody };

/// The world type as it appears in test names: Discrete, MultiBody.
inline std::string worldTypeName(WorldType t) { return t == WorldType::Discrete ? "Discrete" : "MultiBody"; }

/// Fixture of a suite run for every world type and solver; instantiate it with
/// worldTypesAndSolvers() and pairParamName(worldTypeName) ("Discrete_PbMpm").
class WorldAndSolver : public ::testing::TestWithParam<std::tuple<WorldType, SolverType>> {
 protected:
  WorldType world() const { return std::get<0>(GetParam()); }
  SolverType solver() const { return std::get<1>(GetParam()); }
  /// "Discrete PbMpm", for printed results.
  std::string name() const { return worldTypeName(world()) + " " + solverName(solver()); }
};

inline auto worldTypesAndSolvers() {
  return ::testing::Combine(::testing::Values(WorldType::Discrete, WorldType::MultiBody), allSolvers());
}

/// A Bullet world of either type with gravity (0, -g, 0) and no bodies.
struct BulletWorld {
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher{&config};
  btDbvtBroadphase broadphase;
  std::unique_ptr<btSequentialImpulseConstraintSolver> solver;
  std::unique_ptr<btDiscreteDynamicsWorld> world;
  btMultiBodyDynamicsWorld* multiWorld = nullptr;  ///< the same world, if it is one
  std::vector<std::unique_ptr<btCollisionShape>> shapes;
  std::vector<std::unique_ptr<btDefaultMotionState>> states;
  std::vector<std::unique_ptr<btRigidBody>> bodies;
  std::vector<std::unique_ptr<btMultiBodyLinkCollider>> colliders;
  std::vector<std::unique_ptr<btMultiBody>> multiBodies;

  BulletWorld(WorldType type, float g) {
    if (type == WorldType::MultiBody) {
      auto* mbSolver = new btMultiBodyConstraintSolver;
      solver.reset(mbSolver);
      auto mw = std::make_unique<btMultiBodyDynamicsWorld>(&dispatcher, &broadphase, mbSolver, &config);
      multiWorld = mw.get();
      world = std::move(mw);
    } else {
      solver = std::make_unique<btSequentialImpulseConstraintSolver>();
      world = std::make_unique<btDiscreteDynamicsWorld>(&dispatcher, &broadphase, solver.get(), &config);
    }
    world->setGravity(btVector3(0, -g, 0));  // before bodies are added: they copy it
  }
  ~BulletWorld() {
    for (auto& b : bodies) world->removeRigidBody(b.get());
    for (auto& c : colliders) world->removeCollisionObject(c.get());
    for (auto& m : multiBodies) multiWorld->removeMultiBody(m.get());
  }
  btRigidBody* addBody(btCollisionShape* shape, float mass, const btTransform& pose) {
    shapes.emplace_back(shape);
    btVector3 inertia(0, 0, 0);
    if (mass > 0.f) shape->calculateLocalInertia(mass, inertia);
    states.emplace_back(new btDefaultMotionState(pose));
    bodies.emplace_back(new btRigidBody(mass, states.back().get(), shape, inertia));
    world->addRigidBody(bodies.back().get());
    return bodies.back().get();
  }
  btRigidBody* addGround() {  // the plane y = 0
    return addBody(new btStaticPlaneShape(btVector3(0, 1, 0), 0), 0.f, btTransform::getIdentity());
  }

  /// A floating-base chain of equal boxes along x (base first), joined by revolute joints
  /// about z with a gap between neighbours, base centre at `at`. Multibody world only.
  btMultiBody* addBoxChain(int boxes, const btVector3& half, float gap, float massEach, const btVector3& at) {
    btBoxShape* box = new btBoxShape(half);
    shapes.emplace_back(box);
    btVector3 inertia;
    box->calculateLocalInertia(massEach, inertia);
    multiBodies.emplace_back(new btMultiBody(boxes - 1, massEach, inertia, false, false));
    btMultiBody* mb = multiBodies.back().get();
    const btVector3 toPivot(half.x() + 0.5f * gap, 0, 0);
    for (int i = 0; i < boxes - 1; ++i)
      mb->setupRevolute(i, massEach, inertia, i - 1, btQuaternion::getIdentity(), btVector3(0, 0, 1), toPivot, toPivot,
                        true);
    return finishChain(mb, box, at);
  }
  /// A floating-base chain of capsules along x (base first; radius r, half length
  /// `halfLength` including the caps), joined end to end by spherical joints with a 2 mm
  /// gap, base centre at `at`. Multibody world only.
  btMultiBody* addCapsuleChain(int links, float r, float halfLength, float massEach, const btVector3& at) {
    btCapsuleShapeX* capsule = new btCapsuleShapeX(r, 2.f * (halfLength - r));
    shapes.emplace_back(capsule);
    btVector3 inertia;
    capsule->calculateLocalInertia(massEach, inertia);
    multiBodies.emplace_back(new btMultiBody(links - 1, massEach, inertia, false, false));
    btMultiBody* mb = multiBodies.back().get();
    const btVector3 toPivot(halfLength + 0.001f, 0, 0);
    for (int i = 0; i < links - 1; ++i)
      mb->setupSpherical(i, massEach, inertia, i - 1, btQuaternion::getIdentity(), toPivot, toPivot, true);
    return finishChain(mb, capsule, at);
  }
  /// Places a chain's base, adds it and one collider of `shape` per link to the world.
  btMultiBody* finishChain(btMultiBody* mb, btCollisionShape* shape, const btVector3& at) {
    mb->finalizeMultiDof();
    mb->setBasePos(at);
    mb->setWorldToBaseRot(btQuaternion::getIdentity());
    multiWorld->addMultiBody(mb);
    for (int link = -1; link < mb->getNumLinks(); ++link) {
      colliders.emplace_back(new btMultiBodyLinkCollider(mb, link));
      btMultiBodyLinkCollider* c = colliders.back().get();
      c->setCollisionShape(shape);
      world->addCollisionObject(c, btBroadphaseProxy::DefaultFilter, btBroadphaseProxy::AllFilter);
      if (link < 0)
        mb->setBaseCollider(c);
      else
        mb->getLink(link).m_collider = c;
    }
    btAlignedObjectArray<btQuaternion> scratchRot;
    btAlignedObjectArray<btVector3> scratchPos;
    mb->updateCollisionObjectWorldTransforms(scratchRot, scratchPos);
    return mb;
  }
  std::vector<btCollisionObject*> chainColliders(btMultiBody* mb) const {
    std::vector<btCollisionObject*> out{mb->getBaseCollider()};
    for (int i = 0; i < mb->getNumLinks(); ++i) out.push_back(mb->getLink(i).m_collider);
    return out;
  }
};

}  // namespace mpm::test
