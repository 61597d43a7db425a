// The C++ side of the Python coupler's overhead (bench/pybullet_overhead.py runs the same
// scene through mpm_bullet.pybullet.Coupler): the resting-sphere scene of
// tests/python/pybullet_scenes.py (RestingBoxFeelsItsWeight's slab, z up, a 2 kg sphere of
// radius 6 cm dropped on it, dx 2 cm, ticks of 1/240 s) in a btDiscreteDynamicsWorld with
// mpm::bullet::Coupler. Prints the median and mean wall time of a tick over `--ticks` ticks,
// and the solver's own stages (Scene::timings) per tick, one CPU thread; what is left is
// the coupling and Bullet.
//
//   bench_pybullet_overhead [--ticks 192] [--repeats 3] [--no-tissue 1]
//
// --no-tissue 1 leaves the slab out: a tick is then the coupling, Bullet and the scene's
// fixed cost per tick.
#include <btBulletDynamicsCommon.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "mpm/scene.h"
#include "mpm_bullet/coupler.h"

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}
double mean(const std::vector<double>& v) { return v.empty() ? 0.0 : std::accumulate(v.begin(), v.end(), 0.0) / v.size(); }

struct Times {
  std::vector<double> tick;  ///< [ms] per tick: stepSimulation
  double stages = 0;         ///< [ms] the solver's stages, mean per tick
  double substeps = 0;       ///< mean per tick
};

Times run(int ticks, bool tissue) {
  using Clock = std::chrono::steady_clock;
  const float g = 9.81f, dt = 1.f / 240;
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world(&dispatcher, &broadphase, &solver, &config);
  world.setGravity(btVector3(0, 0, -g));
  btStaticPlaneShape planeShape(btVector3(0, 0, 1), 0);
  btRigidBody ground(0.f, nullptr, &planeShape);
  world.addRigidBody(&ground);
  const float radius = 0.06f, mass = 2.f;
  btSphereShape sphereShape(radius);
  btVector3 inertia;
  sphereShape.calculateLocalInertia(mass, inertia);
  btRigidBody sphere(mass, nullptr, &sphereShape, inertia);
  sphere.setWorldTransform(btTransform(btQuaternion::getIdentity(), btVector3(0, 0, 0.104f + radius + 0.005f)));
  world.addRigidBody(&sphere);

  mpm::SceneSettings st;
  st.domain.lower = {-0.25f, -0.25f, -0.1f};
  st.domain.upper = {0.25f, 0.25f, 0.4f};
  st.dx = 0.02f;
  st.gravity = {0.f, 0.f, -g};
  st.backend = mpm::Backend::Cpu;
  st.cpuThreads = 1;
  mpm::Scene scene(st);
  mpm::ParticleObjectDesc slab;
  slab.center = {0.f, 0.f, 0.05f + 0.002f};
  slab.halfExtents = {0.15f, 0.15f, 0.05f};
  slab.material.model = mpm::MaterialModel::NeoHookeanDecoupled;
  slab.material.youngsModulus = 2e5f;
  slab.material.poissonRatio = 0.3f;
  slab.material.density = 1000.f;
  if (tissue) scene.addParticleObject(slab);

  mpm::bullet::Coupler coupler(&world, scene);
  coupler.addRigidBody(&ground);
  mpm::bullet::CouplingOptions opts;
  opts.contact.friction = 0.5f;
  coupler.addRigidBody(&sphere, opts);
  Times t;
  scene.resetTimings();
  for (int i = 0; i < ticks; ++i) {
    const auto a = Clock::now();
    world.stepSimulation(dt, 1, dt);
    coupler.rethrowError();
    t.tick.push_back(std::chrono::duration<double, std::milli>(Clock::now() - a).count());
  }
  const mpm::StageTimings st2 = scene.timings();
  t.stages = 1e3 * (st2.sort + st2.p2g + st2.gridUpdate + st2.contact + st2.g2p) / ticks;
  t.substeps = (double)st2.substeps / ticks;
  std::printf("  sphere centre at z = %.4f m after %d ticks\n", (double)sphere.getCenterOfMassPosition().z(), ticks);
  world.removeRigidBody(&sphere);
  world.removeRigidBody(&ground);
  return t;
}

}  // namespace

int main(int argc, char** argv) {
  int ticks = 192, repeats = 3;
  bool tissue = true;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--ticks") ticks = std::atoi(argv[i + 1]);
    else if (a == "--repeats") repeats = std::atoi(argv[i + 1]);
    else if (a == "--no-tissue") tissue = std::atoi(argv[i + 1]) == 0;
    else {
      std::fprintf(stderr, "usage: bench_pybullet_overhead [--ticks N] [--repeats N] [--no-tissue 1]\n");
      return 2;
    }
  }
  std::vector<double> tickMedians, tickMeans, stageMeans;
  for (int r = 0; r < repeats; ++r) {
    const Times t = run(ticks, tissue);
    tickMedians.push_back(median(t.tick));
    tickMeans.push_back(mean(t.tick));
    stageMeans.push_back(t.stages);
    std::printf("run %d: tick median %.3f ms, mean %.3f ms; solver stages %.3f ms per tick (%.1f substeps); "
                "mean tick less stages %.3f ms\n",
                r, median(t.tick), mean(t.tick), t.stages, t.substeps, mean(t.tick) - t.stages);
  }
  std::vector<double> rest(tickMeans.size());
  for (size_t i = 0; i < rest.size(); ++i) rest[i] = tickMeans[i] - stageMeans[i];
  std::printf("C++ Coupler, btDiscreteDynamicsWorld, %d ticks x %d runs (medians over runs): tick median %.3f ms, "
              "mean %.3f ms; solver stages %.3f ms; the rest (coupling, Bullet, scene bookkeeping) %.3f ms\n",
              ticks, repeats, median(tickMedians), median(tickMeans), median(stageMeans), median(rest));
  return 0;
}
