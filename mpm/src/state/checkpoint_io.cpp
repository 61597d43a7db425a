#include "mpm/checkpoint_io.h"

#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <memory>
#include <sys/stat.h>
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

/// Checks a file's header against its `size` [bytes]: the magic, the version, and that the
/// payload length it states is what the file holds. `head` holds the first
/// min(size, kHeaderBytes) bytes; `where` starts each message (a file's path, or nothing).
void checkHeader(const uint8_t* head, uint64_t size, const std::string& where) {
  if (size < 8 || std::memcmp(head, kMagic, 8) != 0)
    throw CheckpointError(Reason::NotACheckpoint, where + "not a checkpoint (its first bytes are not \"MPMCKPT\")");
  if (size < kHeaderBytes)
    throw CheckpointError(Reason::Truncated, where + "truncated: " + std::to_string(size) + " bytes, shorter than the " +
                                                 std::to_string(kHeaderBytes) + "-byte header");
  const uint32_t version = readAt<uint32_t>(head + 8);
  if (version != kFormatVersion)
    throw CheckpointError(Reason::Version, where + "format version " + std::to_string(version) +
                                               ", this library reads " + std::to_string(kFormatVersion));
  const uint64_t n = readAt<uint64_t>(head + 16);
  if (n != size - kHeaderBytes)
    throw CheckpointError(Reason::Truncated, where + "the header says " + std::to_string(n) +
                                                 " bytes of payload, the file has " +
                                                 std::to_string(size - kHeaderBytes) +
                                                 (n > size - kHeaderBytes ? " (truncated)" : " (trailing bytes)"));
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
  checkHeader(file, size, "");
  const uint64_t n = size - kHeaderBytes;
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
  const std::unique_ptr<std::FILE, int (*)(std::FILE*)> closer(f, std::fclose);
  // its kind, size and header first: a device (/dev/zero), a pipe or a directory has no
  // size to check and may never end, and a file whose header does not hold is not read
  struct stat st;
  if (::fstat(fileno(f), &st) != 0) throw CheckpointError(Reason::Io, ioError("cannot read", path));
  if (!S_ISREG(st.st_mode))
    throw CheckpointError(Reason::NotACheckpoint,
                          "'" + path + "' is not a regular file (" +
                              (S_ISDIR(st.st_mode)   ? "a directory"
                               : S_ISCHR(st.st_mode) ? "a character device"
                               : S_ISBLK(st.st_mode) ? "a block device"
                               : S_ISFIFO(st.st_mode) ? "a pipe"
                                                      : "a socket or other special file") +
                              ")");
  const auto readFailed = [&] {
    return CheckpointError(Reason::Io, std::ferror(f) ? ioError("cannot read", path)
                                                      : "'" + path + "' changed size while it was read");
  };
  const uint64_t size = (uint64_t)st.st_size;
  std::vector<uint8_t> bytes((size_t)std::min<uint64_t>(size, kHeaderBytes));
  if (std::fread(bytes.data(), 1, bytes.size(), f) != bytes.size()) throw readFailed();
  checkHeader(bytes.data(), size, "'" + path + "': ");
  bytes.resize((size_t)size);
  const size_t rest = bytes.size() - kHeaderBytes;
  if (std::fread(bytes.data() + kHeaderBytes, 1, rest, f) != rest || std::fgetc(f) != EOF) throw readFailed();
  return bytes;
}

}  // namespace mpm::checkpoint
