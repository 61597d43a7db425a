// Binary PLY point clouds for ParaView and Blender.
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "mpm/error.h"
#include "mpm/output.h"

namespace mpm::io {
namespace {

// the header promises little-endian whatever the host is, so floats are laid out byte by byte
void appendFloatLittleEndian(std::vector<unsigned char>& bytes, float value) {
  uint32_t bits;
  std::memcpy(&bits, &value, sizeof bits);
  bytes.push_back(static_cast<unsigned char>(bits & 0xffu));
  bytes.push_back(static_cast<unsigned char>((bits >> 8) & 0xffu));
  bytes.push_back(static_cast<unsigned char>((bits >> 16) & 0xffu));
  bytes.push_back(static_cast<unsigned char>((bits >> 24) & 0xffu));
}

}  // namespace

void writePly(const std::string& path, const std::vector<Vec3f>& positions,
              const std::vector<Vec3f>* velocities) {
  const bool withVelocity = velocities != nullptr && velocities->size() == positions.size();

  std::string header = "ply\nformat binary_little_endian 1.0\ncomment written by mpm_io\n";
  header += "element vertex " + std::to_string(positions.size()) + "\n";
  header += "property float x\nproperty float y\nproperty float z\n";
  if (withVelocity) header += "property float vx\nproperty float vy\nproperty float vz\n";
  header += "end_header\n";

  // one buffer and one fwrite: per-vertex writes dominate the cost for a million particles
  const size_t floatsPerVertex = withVelocity ? 6 : 3;
  std::vector<unsigned char> bytes;
  bytes.reserve(header.size() + positions.size() * floatsPerVertex * sizeof(float));
  bytes.insert(bytes.end(), header.begin(), header.end());
  for (size_t i = 0; i < positions.size(); ++i) {
    const Vec3f p = positions[i];
    appendFloatLittleEndian(bytes, p.x);
    appendFloatLittleEndian(bytes, p.y);
    appendFloatLittleEndian(bytes, p.z);
    if (withVelocity) {
      const Vec3f v = (*velocities)[i];
      appendFloatLittleEndian(bytes, v.x);
      appendFloatLittleEndian(bytes, v.y);
      appendFloatLittleEndian(bytes, v.z);
    }
  }

  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (file == nullptr)
    throw Error("writePly: cannot open '" + path + "' for writing: " + std::strerror(errno));
  const bool allWritten = std::fwrite(bytes.data(), 1, bytes.size(), file) == bytes.size();
  int writeErrno = errno;
  // fclose flushes, so its failure (e.g. disk full) is a failed write too
  const bool closed = std::fclose(file) == 0;
  if (allWritten && !closed) writeErrno = errno;
  if (!allWritten || !closed)
    throw Error("writePly: failed writing '" + path + "': " + std::strerror(writeErrno));
}

}  // namespace mpm::io
