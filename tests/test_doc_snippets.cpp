// The documentation's code: every ```cpp, ```c and ```python block of README.md and docs/*.md
// is one of the files the tests compile or run (tests/embed_snippet.inc, tests/doc_snippets/),
// shown verbatim; a block only meant to be read is marked "cpp fragment" (or "c fragment",
// "python fragment"). The C++ snippets of docs/api.md run here on the embedding scene.
#include <gtest/gtest.h>

#include <btBulletDynamicsCommon.h>

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

}  // namespace
