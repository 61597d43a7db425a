// Checkpoints (issue 14): the container refuses what is not a whole checkpoint of this
// format, and a save that fails midway leaves the previous file loadable.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "state/checkpoint_format.h"

namespace mpm {
namespace {

using checkpoint::Reader;
using checkpoint::Writer;
using Reason = CheckpointError::Reason;

std::vector<uint8_t> sampleFile() {
  Writer w;
  w.section("numbers");
  w.put<double>(1.25);
  w.putArray(std::vector<float>{1.f, 2.f, 3.f});
  w.putString("end");
  return w.finish();
}

Reason refusal(const std::vector<uint8_t>& file) {
  try {
    Reader r(file.data(), file.size());
    r.section("numbers");
    r.get<double>("a double");
    std::vector<float> a;
    r.getArray(a, "floats");
    r.getString("a string");
    r.finish();
  } catch (const CheckpointError& e) {
    return e.reason();
  }
  ADD_FAILURE() << "accepted";
  return Reason::Io;
}

TEST(CheckpointFormat, ReadsBackWhatWasWritten) {
  const std::vector<uint8_t> file = sampleFile();
  Reader r(file.data(), file.size());
  r.section("numbers");
  EXPECT_EQ(r.get<double>("a double"), 1.25);
  std::vector<float> a;
  r.getArray(a, "floats");
  EXPECT_EQ(a, (std::vector<float>{1.f, 2.f, 3.f}));
  EXPECT_EQ(r.getString("a string"), "end");
  EXPECT_NO_THROW(r.finish());
}

TEST(CheckpointFormat, RefusesWrongMagicVersionAndChecksum) {
  std::vector<uint8_t> f = sampleFile();
  f[0] = 'X';
  EXPECT_EQ(refusal(f), Reason::NotACheckpoint);
  f = sampleFile();
  f[8] += 1;  // the format version
  EXPECT_EQ(refusal(f), Reason::Version);
  // any flipped payload bit is caught by the CRC
  for (size_t at = checkpoint::kHeaderBytes; at < sampleFile().size(); at += 5) {
    f = sampleFile();
    f[at] ^= 0x10;
    EXPECT_EQ(refusal(f), Reason::Checksum) << "byte " << at;
  }
}

TEST(CheckpointFormat, RefusesTruncationAtEveryLength) {
  const std::vector<uint8_t> whole = sampleFile();
  for (size_t n = 0; n < whole.size(); ++n) {
    const std::vector<uint8_t> cut(whole.begin(), whole.begin() + (long)n);
    const Reason r = refusal(cut);
    EXPECT_TRUE(r == Reason::Truncated || (n < 8 && r == Reason::NotACheckpoint)) << "cut at " << n;
  }
  std::vector<uint8_t> longer = whole;
  longer.push_back(0);
  EXPECT_EQ(refusal(longer), Reason::Truncated);
}

TEST(CheckpointFormat, AFailedSaveLeavesThePreviousFile) {
  const std::string path = ::testing::TempDir() + "mpm_checkpoint_atomic.bin";
  const std::vector<uint8_t> first = sampleFile();
  checkpoint::writeFileAtomically(path, first);
  // a second save whose writer dies after half of the bytes (a full disk, a killed process)
  std::vector<uint8_t> second = first;
  second.resize(second.size() * 4, 7);
  const checkpoint::ChunkWriter dies = [&](const uint8_t* d, size_t n, std::FILE* f) {
    return std::fwrite(d, 1, n / 2, f);
  };
  try {
    checkpoint::writeFileAtomically(path, second, dies);
    FAIL() << "the failed write was not reported";
  } catch (const CheckpointError& e) {
    EXPECT_EQ(e.reason(), Reason::Io) << e.what();
  }
  EXPECT_EQ(checkpoint::readFile(path), first);
  EXPECT_EQ(std::fopen((path + ".tmp").c_str(), "rb"), nullptr) << "the partial file was left behind";
  std::remove(path.c_str());
}

}  // namespace
}  // namespace mpm
