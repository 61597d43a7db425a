// The documentation's code: every ```cpp, ```c and ```python block of README.md and docs/*.md
// is one of the files the tests compile or run (tests/embed_snippet.inc, tests/doc_snippets/),
// shown verbatim; a block only meant to be read is marked "cpp fragment" (or "c fragment",
// "python fragment"). The C++ snippets of docs/api.md run here on the embedding scene.
#include <gtest/gtest.h>

#include <btBulletDynamicsCommon.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "mpm/scene.h"
#include "mpm_bullet/coupler.h"

namespace {

namespace fs = std::filesystem;

std::string readFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

struct Block {
  std::string file, info, text;
};

/// The fenced blocks of a markdown file: info string and text (without the fences).
std::vector<Block> fencedBlocks(const fs::path& path) {
  std::vector<Block> blocks;
  std::istringstream in(readFile(path));
  std::string line;
  Block* open = nullptr;
  while (std::getline(in, line)) {
    if (line.rfind("```", 0) == 0) {
      if (open) {
        open = nullptr;
      } else {
        blocks.push_back({path.filename().string(), line.substr(3), ""});
        open = &blocks.back();
      }
    } else if (open) {
      open->text += line + "\n";
    }
  }
  return blocks;
}

const fs::path kRoot = MPM_SOURCE_DIR;

TEST(DocSnippets, EveryCodeBlockMeantToCompileIsATestedFile) {
  std::set<std::string> tested = {readFile(kRoot / "tests/embed_snippet.inc")};
  for (const auto& entry : fs::directory_iterator(kRoot / "tests/doc_snippets")) tested.insert(readFile(entry.path()));
  std::vector<fs::path> docs = {kRoot / "README.md"};
  for (const auto& entry : fs::directory_iterator(kRoot / "docs"))
    if (entry.path().extension() == ".md") docs.push_back(entry.path());
  int compiled = 0;
  for (const fs::path& doc : docs) {
    for (const Block& b : fencedBlocks(doc)) {
      if (b.info != "cpp" && b.info != "c" && b.info != "python") continue;
      ++compiled;
      EXPECT_TRUE(tested.count(b.text)) << b.file << ": a ```" << b.info << " block that no test compiles or runs "
                                        << "(put it in tests/doc_snippets/ or mark it \"" << b.info
                                        << " fragment\"):\n" << b.text;
    }
  }
  EXPECT_GE(compiled, 4) << "README.md and docs/api.md show the tested snippets";
}

TEST(DocSnippets, EverySnippetFileIsShownInADoc) {
  std::string all = readFile(kRoot / "README.md");
  for (const auto& entry : fs::directory_iterator(kRoot / "docs"))
    if (entry.path().extension() == ".md") all += readFile(entry.path());
  for (const auto& entry : fs::directory_iterator(kRoot / "tests/doc_snippets"))
    EXPECT_NE(all.find(readFile(entry.path())), std::string::npos)
        << entry.path().filename() << " is in no doc verbatim";
}

/// Runs in a temporary folder: the snippets write their checkpoints to the working directory.
struct InTempDir : testing::Test {
  fs::path before = fs::current_path();
  void SetUp() override { fs::current_path(testing::TempDir()); }
  void TearDown() override { fs::current_path(before); }
};

using DocSnippetRuns = InTempDir;

TEST_F(DocSnippetRuns, SceneAloneStepsSavesAndRewinds) {
#include "doc_snippets/scene_alone.inc"

  EXPECT_NEAR(scene.time(), 1.0 / 60, 1e-6) << "the load rewound the step after the save";
  EXPECT_EQ(r.halvings, 0);
  std::vector<mpm::Vec3f> after;
  scene.readPositions(id, after);
  ASSERT_EQ(after.size(), x.size());
  for (size_t i = 0; i < x.size(); ++i) {
    ASSERT_EQ(after[i].x, x[i].x);
    ASSERT_EQ(after[i].y, x[i].y);
    ASSERT_EQ(after[i].z, x[i].z);
  }
}

TEST_F(DocSnippetRuns, CouplerCheckpointRestoresTissueAndBodies) {
#include "embed_world.inc"
#include "embed_snippet.inc"

  for (int f = 0; f < 6; ++f) world->stepSimulation(1.f / 60, 10, 1.f / 240);
  const double savedTime = scene.time();
  const btVector3 savedTool = tool->getCenterOfMassPosition();
#include "doc_snippets/coupler_checkpoint.inc"

  EXPECT_EQ(scene.time(), savedTime);
  EXPECT_EQ(tool->getCenterOfMassPosition().y(), savedTool.y()) << "the falling tool is back where it was";
  world->removeRigidBody(&toolBody);
  world->removeRigidBody(&groundBody);
}

// The scalpel lines of docs/api.md, on a heavy Bullet body (its own gravity off, its turn
// locked, as a hand holds it) pressed down at 5 cm/s into the README's slab (its numbers,
// with the toughness of soft tissue, G_c 100 J/m^2): the blade cuts (a gap opens across its
// plane) and, its edge in the material, feels G_c times the edge's 3 cm in material
// against its motion (3 N), within 20 %, averaged while the edge goes from 1 to 3.5 cm deep
// (the blade is 4 cm wide).
TEST(DocSnippetScalpel, TheScalpelLinesCutTheReadmeSlab) {
#include "embed_world.inc"
  mpm::SceneSettings settings;
  settings.domain = {{-0.25f, -0.1f, -0.25f}, {0.25f, 0.4f, 0.25f}};
  settings.dx = 0.02f;
  mpm::Scene scene(settings);
  mpm::ParticleObjectDesc tissue;
  tissue.center = {0.f, 0.052f, 0.f};
  tissue.halfExtents = {0.15f, 0.05f, 0.15f};
  tissue.material = {mpm::MaterialModel::NeoHookeanDecoupled, 2e5f, 0.3f, 1000.f};
  tissue.material.fractureToughness = 100.f;
  const mpm::ParticleObjectId slab = scene.addParticleObject(tissue);
  mpm::bullet::Coupler coupler(world, scene);
  coupler.addRigidBody(ground);
  world->removeRigidBody(tool);  // the README's falling tool stays out of the cut
  const float top = 0.102f, speed = 0.05f;
  btBoxShape handle(btVector3(0.015f, 0.005f, 0.002f));
  btDefaultMotionState scalpelState(btTransform(btQuaternion::getIdentity(), btVector3(0, top + 0.01f, 0.0032f)));
  btRigidBody scalpelBody(1000.f, &scalpelState, &handle, btVector3(1, 1, 1));
  world->addRigidBody(&scalpelBody);
  scalpelBody.setGravity(btVector3(0, 0, 0));
  scalpelBody.setCollisionFlags(scalpelBody.getCollisionFlags() | btCollisionObject::CF_NO_CONTACT_RESPONSE);
  scalpelBody.setAngularFactor(btVector3(0, 0, 0));
  scalpelBody.setActivationState(DISABLE_DEACTIVATION);
  scalpelBody.setLinearVelocity(btVector3(0, -speed, 0));
  btRigidBody* scalpel = &scalpelBody;
#include "doc_snippets/scalpel.inc"

  const mpm::SlicerId id = coupler.slicerOf(scalpel);
  double force = 0;
  int samples = 0;
  for (int f = 0; f < 54; ++f) {  // 0.9 s: the edge 3.5 cm deep
    world->stepSimulation(1.f / 60, 10, 1.f / 240);
    coupler.rethrowError();
    const double depth = top - scalpel->getCenterOfMassPosition().y();
    const double fy = scene.slicerImpulse(id).linear.y / coupler.lastTickDt();
    if (depth > 0.01 && depth < 0.035) {
      force += fy;
      ++samples;
    }
  }
  force /= std::max(samples, 1);
  // the gap across the blade's plane under the edge's path, 1 cm below the top
  std::vector<mpm::Vec3f> x;
  scene.readPositions(slab, x);
  float nearMax = -1.f, farMin = 1.f;
  for (const mpm::Vec3f& p : x) {
    if (std::fabs(p.x) > 0.01f || p.y > top - 0.01f || p.y < top - 0.02f) continue;
    if (p.z < 0.0032f) nearMax = std::max(nearMax, p.z);
    else farMin = std::min(farMin, p.z);
  }
  std::printf("[cut] the README's scalpel: %.3f N against G_c d = 3 N (%+.1f %%), gap %.1f mm (particle spacing 10 mm)\n",
              force, 100.0 * (force / 3.0 - 1.0), (farMin - nearMax) * 1e3);
  EXPECT_NEAR(force, 3.0, 0.6);
  EXPECT_GT(farMin - nearMax, 0.5f * settings.dx + 0.001f) << "no gap opened: the blade did not cut";
  world->removeRigidBody(&scalpelBody);
  world->removeRigidBody(&groundBody);
}

}  // namespace
