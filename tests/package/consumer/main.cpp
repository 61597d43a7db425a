// A user's program: a Bullet world with a ground and a falling tool, and the README's
// embedding lines adding tissue to it. Exits 0 when the tissue advanced with Bullet and
// held the tool above the ground, 1 otherwise (tests/package/check_package.sh).
#include <btBulletDynamicsCommon.h>
#include <mpm/scene.h>
#include <mpm_bullet/coupler.h>

#include <cmath>
#include <cstdio>

int main() {
#include "embed_world.inc"
#include "embed_snippet.inc"

  for (int f = 0; f < 30; ++f) world->stepSimulation(1.f / 60, 10, 1.f / 240);
  const float y = toolBody.getCenterOfMassPosition().y();
  std::printf("consumer: tissue at t = %.3f s, %zu particles; the tool's centre at y = %.4f m\n", scene.time(),
              scene.particleCount(), y);
  world->removeRigidBody(&toolBody);
  world->removeRigidBody(&groundBody);
  // the tool fell from 0.2 m onto the slab (top at 0.102 m): its centre rests 3 cm above
  // the slab's top, within 1 cm, as in tests/test_embedding.cpp
  return std::fabs(scene.time() - 0.5) < 1e-3 && std::fabs(y - 0.132f) < 0.01f ? 0 : 1;
}
