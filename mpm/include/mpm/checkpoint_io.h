#pragma once
/// The checkpoint container: a 24-byte header (magic, format version, CRC-32 of the
/// payload, payload length) and a payload of named sections written field by field.
/// Public so that the Bullet coupler and embedding programs can write their own records
/// into a checkpoint's attachment (Scene::save) the same way. Readers check every length
/// before they read, so a truncated or corrupted file is refused with a CheckpointError
/// naming what failed, never read out of bounds. Little-endian, as every machine the
/// library targets (x86-64, aarch64, CUDA hosts).
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <string>
#include <type_traits>
#include <vector>

#include "mpm/error.h"

namespace mpm::checkpoint {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "checkpoints are written little-endian");

constexpr char kMagic[8] = {'M', 'P', 'M', 'C', 'K', 'P', 'T', '\0'};
/// Raised whenever what a checkpoint holds, or its layout, changes; older files are refused.
constexpr uint32_t kFormatVersion = 3;  // 2: particle cuts, slicers; 3: curves
constexpr size_t kHeaderBytes = 8 + 4 + 4 + 8;

/// Builds a payload; finish() gives the whole file.
class Writer {
 public:
  template <class T>
  void put(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>, "put: plain data only");
    append(&v, sizeof(T));
  }
  template <class T>
  void putArray(const T* data, size_t count) {
    static_assert(std::is_trivially_copyable_v<T>, "putArray: plain data only");
    put<uint64_t>(count);
    append(data, count * sizeof(T));
  }
  template <class T>
  void putArray(const std::vector<T>& a) { putArray(a.data(), a.size()); }
  void putString(const std::string& s) { putArray(s.data(), s.size()); }
  /// A section starts with its name, so a reader out of step says where.
  void section(const char* name) { putString(name); }

  /// Header + payload.
  std::vector<uint8_t> finish() const;

 private:
  void append(const void* p, size_t n) {
    const auto* b = static_cast<const uint8_t*>(p);
    payload_.insert(payload_.end(), b, b + n);
  }
  std::vector<uint8_t> payload_;
};

/// Reads a payload after checking the header: magic, version, length and CRC-32.
class Reader {
 public:
  Reader(const uint8_t* file, size_t size);

  template <class T>
  T get(const char* what) {
    T v;
    getInto(v, what);
    return v;
  }
  /// get() into `out` (also a fixed-size array). A bool is a byte that must be 0 or 1:
  /// any other byte copied into a bool is undefined behaviour (found by fuzz_checkpoint).
  template <class T>
  void getInto(T& out, const char* what) {
    static_assert(std::is_trivially_copyable_v<T>, "getInto: plain data only");
    if constexpr (std::is_same_v<std::remove_all_extents_t<T>, bool>) {
      uint8_t bytes[sizeof(T)];
      take(bytes, sizeof(T), what);
      for (size_t i = 0; i < sizeof(T); ++i) {
        if (bytes[i] > 1) malformedBool(bytes[i], what);
        reinterpret_cast<bool*>(&out)[i] = bytes[i] == 1;
      }
    } else {
      take(&out, sizeof(T), what);
    }
  }
  template <class T>
  void getArray(std::vector<T>& out, const char* what) {
    static_assert(std::is_trivially_copyable_v<T>, "getArray: plain data only");
    const uint64_t n = get<uint64_t>(what);
    if (n > (size_ - at_) / (sizeof(T) ? sizeof(T) : 1)) truncated(n * sizeof(T), what);
    out.resize((size_t)n);
    take(out.data(), (size_t)n * sizeof(T), what);
  }
  std::string getString(const char* what) {
    std::vector<char> c;
    getArray(c, what);
    return std::string(c.begin(), c.end());
  }
  /// Reads a section name and refuses the file if it is not `name`.
  void section(const char* name);
  bool atEnd() const { return at_ == size_; }
  /// Refuses the file unless all of the payload was read.
  void finish() const;

 private:
  void take(void* out, size_t n, const char* what) {
    if (n > size_ - at_) truncated(n, what);
    if (n == 0) return;  // an empty array's data() may be null, which memcpy must not get
    std::memcpy(out, payload_ + at_, n);
    at_ += n;
  }
  [[noreturn]] void truncated(uint64_t need, const char* what) const;
  [[noreturn]] void malformedBool(unsigned byte, const char* what) const;
  const uint8_t* payload_ = nullptr;
  size_t size_ = 0, at_ = 0;
};

/// Writes `bytes` to `path` so that the file there is always a whole checkpoint: into
/// `path`.tmp, flushed to disk, then renamed over `path`. A write that fails (a full disk,
/// a killed process) leaves the previous file as it was. `writeChunk` is fwrite unless a
/// test replaces it (returning fewer bytes than asked is a failure).
using ChunkWriter = std::function<size_t(const uint8_t* data, size_t size, std::FILE* file)>;
void writeFileAtomically(const std::string& path, const std::vector<uint8_t>& bytes,
                         const ChunkWriter& writeChunk = nullptr);
std::vector<uint8_t> readFile(const std::string& path);

}  // namespace mpm::checkpoint
