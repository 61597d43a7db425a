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

void appendIntLittleEndian(std::vector<unsigned char>& bytes, int32_t value) {
  const uint32_t bits = static_cast<uint32_t>(value);
  for (int shift = 0; shift < 32; shift += 8) bytes.push_back(static_cast<unsigned char>((bits >> shift) & 0xffu));
}

void writeBytes(const std::string& path, const std::vector<unsigned char>& bytes) {
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

}  // namespace

void PlyFrame::addPoints(const std::vector<Vec3f>& p, Rgb c) {
  points.insert(points.end(), p.begin(), p.end());
  colours.insert(colours.end(), p.size(), c);
}

void PlyFrame::addPolyline(const std::vector<Vec3f>& p, Rgb c) {
  const int first = static_cast<int>(points.size());
  addPoints(p, c);
  for (int i = 1; i < static_cast<int>(p.size()); ++i) edges.push_back({first + i - 1, first + i});
}

void writePly(const std::string& path, const PlyFrame& frame) {
  const size_t n = frame.points.size();
  if (frame.colours.size() != n)
    throw Error("writePly: '" + path + "': " + std::to_string(frame.colours.size()) + " colours for " +
                std::to_string(n) + " points");
  for (const std::array<int, 2>& e : frame.edges)
    if (e[0] < 0 || e[1] < 0 || static_cast<size_t>(e[0]) >= n || static_cast<size_t>(e[1]) >= n)
      throw Error("writePly: '" + path + "': an edge names a point beyond the " + std::to_string(n) + " points");
  std::string header = "ply\nformat binary_little_endian 1.0\ncomment written by mpm_io\n";
  header += "element vertex " + std::to_string(n) + "\n";
  header += "property float x\nproperty float y\nproperty float z\n";
  header += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  if (!frame.edges.empty())
    header += "element edge " + std::to_string(frame.edges.size()) + "\nproperty int vertex1\nproperty int vertex2\n";
  header += "end_header\n";
  std::vector<unsigned char> bytes;
  bytes.reserve(header.size() + n * 15 + frame.edges.size() * 8);
  bytes.insert(bytes.end(), header.begin(), header.end());
  for (size_t i = 0; i < n; ++i) {
    for (int c = 0; c < 3; ++c) appendFloatLittleEndian(bytes, frame.points[i][c]);
    bytes.push_back(frame.colours[i].r);
    bytes.push_back(frame.colours[i].g);
    bytes.push_back(frame.colours[i].b);
  }
  for (const std::array<int, 2>& e : frame.edges) {
    appendIntLittleEndian(bytes, e[0]);
    appendIntLittleEndian(bytes, e[1]);
  }
  writeBytes(path, bytes);
}

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
  writeBytes(path, bytes);
}

}  // namespace mpm::io
