// Coupling demo: three rigid boxes, light, equal and heavy relative to the tissue under
// them, dropped on a soft slab that lies on a Bullet ground. Bullet steps the boxes; the
// coupler advances the tissue with every internal tick. Writes PLY frames, PNGs and
// heights.csv (each box's height over time) to --out. Heavier boxes sink deeper.
#include <CLI/CLI.hpp>
#include <btBulletDynamicsCommon.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <vector>

#include "mpm/output.h"
#include "mpm/scene.h"
#include "mpm_bullet/coupler.h"

int main(int argc, char** argv) {
  CLI::App app{"Rigid boxes of different masses on a soft tissue slab (Bullet + MPM)"};
  std::string out = "out/coupling";
  int frames = 90, pngEvery = 5, threads = 0;
  app.add_option("--out", out, "output folder");
  app.add_option("--frames", frames, "frames at 60 per second")->check(CLI::PositiveNumber);
  app.add_option("--png-every", pngEvery, "write a PNG every N frames")->check(CLI::PositiveNumber);
  app.add_option("--threads", threads, "CPU threads (0 = all)")->check(CLI::NonNegativeNumber);
  CLI11_PARSE(app, argc, argv);

  try {
    std::filesystem::create_directories(out);
    // the user's Bullet world: ground plane y = 0 and three boxes
    btDefaultCollisionConfiguration config;
    btCollisionDispatcher dispatcher(&config);
    btDbvtBroadphase broadphase;
    btSequentialImpulseConstraintSolver solver;
    btDiscreteDynamicsWorld world(&dispatcher, &broadphase, &solver, &config);
    world.setGravity(btVector3(0, -9.81f, 0));
    btStaticPlaneShape groundShape(btVector3(0, 1, 0), 0);
    btRigidBody ground(0.f, nullptr, &groundShape);
    world.addRigidBody(&ground);

    // tissue: 0.6 x 0.08 x 0.2 m slab, 1000 kg/m^3, so a 0.08 m box of tissue weighs 0.5 kg
    mpm::SceneSettings settings;
    settings.domain = {{-0.35f, -0.05f, -0.15f}, {0.35f, 0.4f, 0.15f}};
    settings.dx = 0.01f;
    settings.cpuThreads = threads;
    mpm::Scene scene(settings);
    mpm::ParticleObjectDesc slab;
    slab.center = {0.f, 0.041f, 0.f};
    slab.halfExtents = {0.3f, 0.04f, 0.1f};
    slab.material = {mpm::MaterialModel::NeoHookeanDecoupled, 3e4f, 0.4f, 1000.f};
    const mpm::ParticleObjectId tissue = scene.addParticleObject(slab);

    mpm::bullet::Coupler coupler(&world, scene);
    coupler.addRigidBody(&ground);
    const float half = 0.04f, masses[3] = {0.05f, 0.5f, 5.f};  // light, equal, heavy
    const char* names[3] = {"light", "equal", "heavy"};
    btBoxShape boxShape(btVector3(half, half, half));
    std::vector<std::unique_ptr<btDefaultMotionState>> states;
    std::vector<std::unique_ptr<btRigidBody>> boxes;
    for (int i = 0; i < 3; ++i) {
      btVector3 inertia;
      boxShape.calculateLocalInertia(masses[i], inertia);
      states.emplace_back(new btDefaultMotionState(
          btTransform(btQuaternion::getIdentity(), btVector3(-0.18f + 0.18f * i, 0.2f, 0.f))));
      boxes.emplace_back(new btRigidBody(masses[i], states.back().get(), &boxShape, inertia));
      world.addRigidBody(boxes.back().get());
      mpm::bullet::CouplingOptions opts;
      opts.contact.friction = 0.4f;
      coupler.addRigidBody(boxes.back().get(), opts);
    }
    std::printf("coupling: %zu tissue particles, boxes of %g / %g / %g kg\n", scene.particleCount(),
                masses[0], masses[1], masses[2]);

    mpm::io::Camera camera;
    camera.eye = {0.45f, 0.4f, 0.75f};
    camera.target = {0.f, 0.05f, 0.f};
    camera.width = 800;
    camera.height = 500;
    mpm::io::SplatRenderer renderer(camera);
    renderer.setGround(0.f, 0.5f);
    std::ofstream csv(out + "/heights.csv");
    csv << "time_s,light_y_m,equal_y_m,heavy_y_m\n";
    std::vector<mpm::Vec3f> x, cube;
    mpm::io::ProgressBar progress("coupling", frames);
    char name[64];
    for (int f = 0; f <= frames; ++f) {
      if (f > 0) {
        world.stepSimulation(1.f / 60, 10, 1.f / 240);
        coupler.rethrowError();  // an error inside Bullet's tick surfaces here
      }
      csv << scene.time();
      for (auto& b : boxes) csv << "," << b->getCenterOfMassPosition().y();
      csv << "\n";
      scene.readPositions(tissue, x);
      std::snprintf(name, sizeof name, "/frame_%04d.ply", f);
      mpm::io::writePly(out + name, x);
      if (f % pngEvery == 0) {
        renderer.clear();
        renderer.addParticles(x, 0.3f * settings.dx, {220, 120, 110});
        for (int i = 0; i < 3; ++i) {  // draw each box as a lattice of grey points
          cube.clear();
          const btTransform t = boxes[i]->getCenterOfMassTransform();
          for (int a = 0; a < 8; ++a)
            for (int b = 0; b < 8; ++b)
              for (int c = 0; c < 8; ++c) {
                const btVector3 p = t * btVector3(half * (-0.875f + 0.25f * a), half * (-0.875f + 0.25f * b),
                                                  half * (-0.875f + 0.25f * c));
                cube.push_back({(float)p.x(), (float)p.y(), (float)p.z()});
              }
          const uint8_t g = (uint8_t)(200 - 60 * i);
          renderer.addParticles(cube, 0.006f, {g, g, (uint8_t)(g + 30)});
        }
        std::snprintf(name, sizeof name, "/frame_%04d.png", f);
        renderer.writePng(out + name);
      }
      progress.update(f);
    }
    progress.finish();
    for (int i = 0; i < 3; ++i)
      std::printf("%s box (%g kg): rests at y = %.4f m\n", names[i], masses[i],
                  boxes[i]->getCenterOfMassPosition().y());
    for (auto& b : boxes) world.removeRigidBody(b.get());
    world.removeRigidBody(&ground);
    std::printf("frames, pictures and heights.csv in %s/\n", out.c_str());
  } catch (const mpm::Error& e) {
    std::fprintf(stderr, "coupling: %s\n", e.what());
    return 1;
  }
  return 0;
}
