// The README's embedding lines (tests/embed_snippet.inc, included verbatim in README.md)
// compile and run in a user's existing Bullet world: the tissue advances with
// stepSimulation and holds up the tool dropped on it.
#include <gtest/gtest.h>

#include <btBulletDynamicsCommon.h>

#include <fstream>
#include <sstream>
#include <string>

#include "mpm/scene.h"
#include "mpm_bullet/coupler.h"

namespace {

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(Embedding, ReadmeShowsExactlyTheTestedSnippet) {
  const std::string root = MPM_SOURCE_DIR;
  const std::string snippet = readFile(root + "/tests/embed_snippet.inc");
  const std::string readme = readFile(root + "/README.md");
  ASSERT_FALSE(snippet.empty());
  EXPECT_NE(readme.find(snippet), std::string::npos) << "README.md must contain tests/embed_snippet.inc verbatim";
}

TEST(Embedding, SnippetCouplesAUsersBulletWorld) {
#include "embed_world.inc"
#include "embed_snippet.inc"

  for (int f = 0; f < 30; ++f) world->stepSimulation(1.f / 60, 10, 1.f / 240);
  EXPECT_NEAR(scene.time(), 0.5, 1e-3) << "the tissue advanced with Bullet";
  // the tool fell from 0.2 m and rests on the slab (top at 0.102 m), not on the ground
  EXPECT_NEAR(toolBody.getCenterOfMassPosition().y(), 0.102f + 0.03f, 0.01f);
  world->removeRigidBody(&toolBody);
  world->removeRigidBody(&groundBody);
}

}  // namespace
