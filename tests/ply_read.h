#pragma once
// Reads back the binary PLY frames mpm::io::writePly(path, PlyFrame) writes: the header's
// element counts, then x, y, z (float) and red, green, blue (uchar) per vertex and
// vertex1, vertex2 (int) per edge, little-endian.
#include <array>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "mpm/output.h"

namespace mpm::test {

struct PlyRead {
  std::vector<std::string> header;  ///< its lines, "ply" to "end_header"
  size_t vertexCount = 0, edgeCount = 0;  ///< as the header names them
  io::PlyFrame frame;
  size_t trailingBytes = 0;  ///< after the last element: 0 for a well-formed file
};

inline PlyRead readPly(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), {});
  PlyRead r;
  const std::string marker = "end_header\n";
  const size_t end = bytes.find(marker);
  if (end == std::string::npos) return r;
  std::istringstream header(bytes.substr(0, end + marker.size()));
  for (std::string line; std::getline(header, line);) {
    r.header.push_back(line);
    std::istringstream words(line);
    std::string element, name;
    size_t count = 0;
    if (words >> element >> name >> count && element == "element") (name == "vertex" ? r.vertexCount : r.edgeCount) = count;
  }
  size_t at = end + marker.size();
  auto take = [&](void* out, size_t n) {  // a little-endian host reads the file's bytes as they are
    if (at + n > bytes.size()) return false;
    std::memcpy(out, bytes.data() + at, n);
    at += n;
    return true;
  };
  for (size_t i = 0; i < r.vertexCount; ++i) {
    Vec3f p;
    io::Rgb c;
    if (!take(&p.x, 4) || !take(&p.y, 4) || !take(&p.z, 4) || !take(&c.r, 1) || !take(&c.g, 1) || !take(&c.b, 1))
      return r;
    r.frame.points.push_back(p);
    r.frame.colours.push_back(c);
  }
  for (size_t i = 0; i < r.edgeCount; ++i) {
    std::array<int32_t, 2> e;
    if (!take(e.data(), 8)) return r;
    r.frame.edges.push_back({e[0], e[1]});
  }
  r.trailingBytes = bytes.size() - at;
  return r;
}

}  // namespace mpm::test
