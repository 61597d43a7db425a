#include "mpm/checkpoint_io.h"

#include <zlib.h>

#include <cerrno>
#include <cstdio>
#include <unistd.h>

namespace mpm::checkpoint {

namespace {

using Reason = CheckpointError::Reason;

uint32_t crc32Of(const uint8_t* data, size_t n) {
  return (uint32_t)crc32_z(crc32_z(0L, Z_NULL, 0), data, n);
}

template <class T>
T readAt(const uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

std::string ioError(const std::string& what, const std::string& path) {
  return what + " '" + path + "': " + std::strerror(errno);
}

}  // namespace

std::vector<uint8_t> Writer::finish() const {
  std::vector<uint8_t> file(kHeaderBytes);
  const uint32_t crc = crc32Of(payload_.data(), payload_.size());
  const uint64_t n = payload_.size();
  std::memcpy(file.data(), kMagic, 8);
  std::memcpy(file.data() + 8, &kFormatVersion, 4);
  std::memcpy(file.data() + 12, &crc, 4);
  std::memcpy(file.data() + 16, &n, 8);
  file.insert(file.end(), payload_.begin(), payload_.end());
  return file;
}

Reader::Reader(const uint8_t* file, size_t size) {
  if (size < 8 || std::memcmp(file, kMagic, 8) != 0)
    throw CheckpointError(Reason::NotACheckpoint, "not a checkpoint (its first bytes are not \"MPMCKPT\")");
  if (size < kHeaderBytes)
    throw CheckpointError(Reason::Truncated, "truncated: " + std::to_string(size) + " bytes, shorter than the " +
                                                 std::to_string(kHeaderBytes) + "-byte header");
  const uint32_t version = readAt<uint32_t>(file + 8);
  if (version != kFormatVersion)
    throw CheckpointError(Reason::Version, "format version " + std::to_string(version) + ", this library reads " +
                                               std::to_string(kFormatVersion));
  const uint64_t n = readAt<uint64_t>(file + 16);
  if (n != size - kHeaderBytes)
    throw CheckpointError(Reason::Truncated, "the header says " + std::to_string(n) + " bytes of payload, the file has " +
                                                 std::to_string(size - kHeaderBytes) +
                                                 (n > size - kHeaderBytes ? " (truncated)" : " (trailing bytes)"));
  if (crc32Of(file + kHeaderBytes, (size_t)n) != readAt<uint32_t>(file + 12))
    throw CheckpointError(Reason::Checksum, "CRC-32 of the payload does not match the header: the file is corrupted");
  payload_ = file + kHeaderBytes;
  size_ = (size_t)n;
}

void Reader::malformedBool(unsigned byte, const char* what) const {
  throw CheckpointError(Reason::Malformed, std::string(what) + " holds " + std::to_string(byte) +
                                               " where a bool (0 or 1) was written, ending at offset " + std::to_string(at_));
}

void Reader::truncated(uint64_t need, const char* what) const {
  // unreachable for a file whose CRC matched, unless it was written by a faulty writer
  throw CheckpointError(Reason::Truncated, std::string("payload ends inside ") + what + " (needs " +
                                               std::to_string(need) + " bytes at offset " + std::to_string(at_) +
                                               ", " + std::to_string(size_ - at_) + " left)");
}

void Reader::section(const char* name) {
  const std::string got = getString("a section name");
  if (got != name)
    throw CheckpointError(Reason::Truncated, "expected section '" + std::string(name) + "', found '" + got + "'");
}

void Reader::finish() const {
  if (!atEnd())
    throw CheckpointError(Reason::Truncated, std::to_string(size_ - at_) + " bytes left unread after the last section");
}

void writeFileAtomically(const std::string& path, const std::vector<uint8_t>& bytes, const ChunkWriter& writeChunk) {
  const std::string tmp = path + ".tmp";
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw CheckpointError(Reason::Io, ioError("cannot create", tmp));
  bool ok = true;
  constexpr size_t kChunk = size_t(1) << 22;
  for (size_t at = 0; ok && at < bytes.size(); at += kChunk) {
    const size_t n = std::min(kChunk, bytes.size() - at);
    ok = (writeChunk ? writeChunk(bytes.data() + at, n, f) : std::fwrite(bytes.data() + at, 1, n, f)) == n;
  }
  // flushed to the disk before the rename, so a crash cannot leave a renamed empty file
  ok = ok && std::fflush(f) == 0 && ::fsync(fileno(f)) == 0;
  const std::string err = ok ? "" : ioError("cannot write", tmp);
  ok = std::fclose(f) == 0 && ok;
  if (!ok) {
    std::remove(tmp.c_str());
    throw CheckpointError(Reason::Io, err.empty() ? ioError("cannot close", tmp) : err);
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string e = ioError("cannot rename the written file to", path);
    std::remove(tmp.c_str());
    throw CheckpointError(Reason::Io, e);
  }
}

std::vector<uint8_t> readFile(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw CheckpointError(Reason::Io, ioError("cannot open", path));
  std::vector<uint8_t> bytes;
  uint8_t buf[1 << 16];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) bytes.insert(bytes.end(), buf, buf + n);
  const bool failed = std::ferror(f) != 0;
  std::fclose(f);
  if (failed) throw CheckpointError(Reason::Io, ioError("cannot read", path));
  return bytes;
}

}  // namespace mpm::checkpoint
