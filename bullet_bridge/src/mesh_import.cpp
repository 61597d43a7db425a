// Mesh files through assimp, and Bullet shapes that own the triangles they collide with.
#include "mpm_bullet/mesh_import.h"

#include <assimp/IOSystem.hpp>
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <BulletCollision/CollisionShapes/btBvhTriangleMeshShape.h>
#include <BulletCollision/CollisionShapes/btConvexHullShape.h>
#include <BulletCollision/CollisionShapes/btTriangleIndexVertexArray.h>
#include <BulletCollision/Gimpact/btGImpactShape.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "mpm/error.h"

namespace mpm::bullet {
namespace {

std::string show(float v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", v);
  return text;
}

// ------------------------------------------------------------------ assimp import

// Joins vertices at bit-identical positions across all meshes of a file (assimp's own
// JoinIdenticalVertices works per mesh and only when normals and UVs agree too).
class VertexWelder {
 public:
  explicit VertexWelder(mpm::TriangleMesh& mesh) : mesh_(mesh) {}
  uint32_t add(mpm::Vec3f p) {
    // +0.f turns -0 into 0, so the two zeros join
    p = {p.x + 0.f, p.y + 0.f, p.z + 0.f};
    Key key;
    std::memcpy(key.bits, &p.x, sizeof(float));
    std::memcpy(key.bits + 1, &p.y, sizeof(float));
    std::memcpy(key.bits + 2, &p.z, sizeof(float));
    const auto found = index_.find(key);
    if (found != index_.end()) return found->second;
    const uint32_t index = static_cast<uint32_t>(mesh_.vertices.size());
    mesh_.vertices.push_back(p);
    index_.emplace(key, index);
    return index;
  }

 private:
  struct Key {
    uint32_t bits[3];
    bool operator==(const Key& o) const { return bits[0] == o.bits[0] && bits[1] == o.bits[1] && bits[2] == o.bits[2]; }
  };
  struct KeyHash {
    size_t operator()(const Key& k) const {
      uint64_t h = 1469598103934665603ull;  // FNV-1a over the three words
      for (uint32_t b : k.bits) h = (h ^ b) * 1099511628211ull;
      return static_cast<size_t>(h);
    }
  };
  mpm::TriangleMesh& mesh_;
  std::unordered_map<Key, uint32_t, KeyHash> index_;
};

void appendNode(const aiScene& scene, const aiNode& node, const aiMatrix4x4& parent, float scale,
                VertexWelder& welder, mpm::TriangleMesh& out) {
  const aiMatrix4x4 transform = parent * node.mTransformation;
  // a mirroring transform turns counter-clockwise into clockwise: swap two corners back
  const bool mirrored = transform.Determinant() < 0;
  for (unsigned m = 0; m < node.mNumMeshes; ++m) {
    const aiMesh& mesh = *scene.mMeshes[node.mMeshes[m]];
    std::vector<uint32_t> welded(mesh.mNumVertices);
    for (unsigned v = 0; v < mesh.mNumVertices; ++v) {
      const aiVector3D p = transform * mesh.mVertices[v];
      welded[v] = welder.add({scale * p.x, scale * p.y, scale * p.z});
    }
    for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
      const aiFace& face = mesh.mFaces[f];
      if (face.mNumIndices != 3) continue;  // points and lines have no inside
      const uint32_t a = welded[face.mIndices[0]];
      const uint32_t b = welded[face.mIndices[mirrored ? 2 : 1]];
      const uint32_t c = welded[face.mIndices[mirrored ? 1 : 2]];
      out.indices.insert(out.indices.end(), {a, b, c});
    }
  }
  for (unsigned child = 0; child < node.mNumChildren; ++child)
    appendNode(scene, *node.mChildren[child], transform, scale, welder, out);
}

// What assimp's reader made is validated (ValidateDataStructure) and checked here
// (checkFaces) before any post-processing step: its readers pass on what a file says, and
// its steps trust it. fuzz_mesh_import found a PLY face naming vertex 100000000 of 3 (the
// steps read past the vertex array: a segmentation fault) and PLY faces of no vertices
// (Triangulate's assertion aborted the program); such files are refused with the reason.
constexpr unsigned kReadSteps = aiProcess_ValidateDataStructure;
constexpr unsigned kPostSteps =
    aiProcess_RemoveComponent | aiProcess_Triangulate | aiProcess_JoinIdenticalVertices | aiProcess_SortByPType;

void checkScale(float scale) {
  if (!std::isfinite(scale) || !(scale > 0.f))
    throw mpm::InvalidArgument("scale", show(scale), "must be a finite number > 0");
}

void configure(Assimp::Importer& importer) {
  // drop everything but positions before joining, so vertices that differ only in normal
  // or texture coordinate (every corner of an STL box) join too
  importer.SetPropertyInteger(AI_CONFIG_PP_RVC_FLAGS,
                              aiComponent_NORMALS | aiComponent_TANGENTS_AND_BITANGENTS | aiComponent_COLORS |
                                  aiComponent_TEXCOORDS | aiComponent_BONEWEIGHTS | aiComponent_ANIMATIONS |
                                  aiComponent_TEXTURES | aiComponent_LIGHTS | aiComponent_CAMERAS);
  importer.SetPropertyInteger(AI_CONFIG_PP_SBP_REMOVE, aiPrimitiveType_POINT | aiPrimitiveType_LINE);
}

/// The read scene post-processed (kPostSteps) once its faces are checked: a face of no
/// vertices is refused (assimp validates it only when the reader set the mesh's primitive
/// types). Null when reading failed (collectTriangles says why).
const aiScene* postProcessed(Assimp::Importer& importer, const aiScene* scene, const std::string& what) {
  if (scene == nullptr) return nullptr;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m)
    for (unsigned f = 0; f < scene->mMeshes[m]->mNumFaces; ++f)
      if (scene->mMeshes[m]->mFaces[f].mNumIndices == 0)
        throw mpm::Error("loadTriangleMesh: " + what + ": face " + std::to_string(f) + " of mesh " + std::to_string(m) +
                         " has no vertices");
  return importer.ApplyPostProcessing(kPostSteps);
}

/// The triangles of what assimp read (`scene`, null when it failed), welded and scaled;
/// `what` names the source in errors.
mpm::TriangleMesh collectTriangles(const Assimp::Importer& importer, const aiScene* scene, const std::string& what,
                                   float scale) {
  if (scene == nullptr || scene->mRootNode == nullptr)
    throw mpm::Error("loadTriangleMesh: cannot read " + what + ": " + importer.GetErrorString());
  if ((scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE) != 0)
    throw mpm::Error("loadTriangleMesh: " + what + " was read only in part: " + importer.GetErrorString());
  mpm::TriangleMesh mesh;
  VertexWelder welder(mesh);
  appendNode(*scene, *scene->mRootNode, aiMatrix4x4(), scale, welder, mesh);
  if (mesh.indices.empty()) throw mpm::Error("loadTriangleMesh: " + what + " holds no triangles");
  for (const mpm::Vec3f& v : mesh.vertices)
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
      throw mpm::Error("loadTriangleMesh: " + what + " has a vertex that is not a finite number");
  return mesh;
}

/// assimp's text readers take a NUL byte for the end of the file, the checks here do not:
/// a text format's file holding one is refused (fuzz_mesh_import found an ASCII STL cut
/// short by NULs inside a vertex, which assimp's reader threw on and leaked its mesh).
void refuseNul(const uint8_t* data, size_t size, const std::string& what, const char* format) {
  const uint8_t* nul = std::find(data, data + size, 0);
  if (nul != data + size)
    throw mpm::Error("loadTriangleMesh: " + what + ": a NUL byte at byte " + std::to_string(nul - data) + " of an " +
                     format + " file");
}

/// Is `word` a number assimp's PLY reader parses whole: [+-] digits [. digits] [e [+-] digits]
/// (or the fraction alone); an integer type's without a fraction or exponent.
bool plyNumber(const std::string& word, bool integer) {
  size_t i = word.size() > 0 && (word[0] == '+' || word[0] == '-') ? 1 : 0;
  auto digits = [&] {
    const size_t from = i;
    while (i < word.size() && word[i] >= '0' && word[i] <= '9') ++i;
    return i - from;
  };
  size_t whole = digits();
  if (integer) return whole > 0 && i == word.size();
  if (i < word.size() && word[i] == '.') {
    ++i;
    whole += digits();
  }
  if (whole == 0) return false;
  if (i < word.size() && (word[i] == 'e' || word[i] == 'E')) {
    ++i;
    if (i < word.size() && (word[i] == '+' || word[i] == '-')) ++i;
    if (digits() == 0) return false;
  }
  return i == word.size();
}

/// Up to 40 characters of `text` for a message, every byte that is no printable ASCII as '?'.
std::string printable(const std::string& text) {
  std::string out = text.substr(0, 40);
  for (char& c : out)
    if (c < 32 || c > 126) c = '?';
  return out;
}

/// The words of a line, split at spaces and tabs.
std::vector<std::string> wordsOf(const std::string& text) {
  std::vector<std::string> words;
  for (size_t i = 0; i < text.size();) {
    const size_t from = text.find_first_not_of(" \t", i);
    if (from == std::string::npos) break;
    const size_t to = std::min(text.find_first_of(" \t", from), text.size());
    words.push_back(text.substr(from, to - from));
    i = to;
  }
  return words;
}

/// assimp's PLY reader trusts the header: in a binary file an element's count and each
/// list's length (a face's vertex count) are read as promised, past the end of the file
/// when it ends sooner (fuzz_mesh_import found a face of 191 vertices in a file that held
/// 3: a segmentation fault); in an ASCII file a value that is no number throws from inside
/// the reader, which then leaks the mesh it was filling (found too). Walks the body of a
/// PLY by its header (binary: bytes; ASCII: one line per item, one number per value) and
/// refuses a file that does not hold what its header says, naming the element and item, or
/// a header line it cannot follow; files that are not PLY pass unchecked.
void checkPly(const uint8_t* data, size_t size, const std::string& what) {
  // assimp's reader takes any file that begins with "ply" ("plyply" too: found by the fuzzer)
  if (size < 3 || std::memcmp(data, "ply", 3) != 0) return;
  auto refuse = [&](const std::string& why) { throw mpm::Error("loadTriangleMesh: " + what + ": PLY " + why); };
  struct Property {
    int size = 0, countSize = 0;  // countSize > 0: a list whose length is that wide
    bool signedCount = false, integer = false;
  };
  struct Element {
    std::string name;
    unsigned long long count = 0;
    std::vector<Property> properties;
  };
  auto typeSize = [&](const std::string& type, bool* isSigned, bool* integer) {
    static const std::pair<const char*, int> types[] = {
        {"char", 1},  {"int8", 1},   {"uchar", 1}, {"uint8", 1},   {"short", 2},   {"int16", 2},
        {"ushort", 2}, {"uint16", 2}, {"int", 4},   {"int32", 4},   {"uint", 4},    {"uint32", 4},
        {"float", 4}, {"float32", 4}, {"double", 8}, {"float64", 8}};
    for (const auto& t : types)
      if (type == t.first) {
        if (isSigned) *isSigned = type[0] != 'u';
        if (integer) *integer = type.compare(0, 5, "float") != 0 && type != "double";
        return t.second;
      }
    refuse("header: property type '" + type + "' is none of PLY's");
    return 0;
  };
  std::vector<Element> elements;
  bool bigEndian = false, ascii = false, formatSeen = false;
  size_t at = 0;
  for (int line = 1;; ++line) {
    const size_t end = std::find(data + at, data + size, '\n') - data;
    if (end == size) refuse("header: no 'end_header' line (the file ends at header line " + std::to_string(line) + ")");
    std::string text(reinterpret_cast<const char*>(data) + at, end - at);
    at = end + 1;
    if (!text.empty() && text.back() == '\r') text.pop_back();
    const std::vector<std::string> words = wordsOf(text);
    if (words.empty() || words[0] == "ply" || words[0] == "comment" || words[0] == "obj_info") continue;
    const std::string where = "header line " + std::to_string(line) + " '" + printable(text) + "'";
    if (words[0] == "format") {
      if (words.size() < 2) refuse(where + ": no format");
      if (words[1] != "ascii" && words[1] != "binary_little_endian" && words[1] != "binary_big_endian")
        refuse(where + ": the format is none of ascii, binary_little_endian, binary_big_endian");
      formatSeen = true;
      ascii = words[1] == "ascii";
      bigEndian = words[1] == "binary_big_endian";
    } else if (words[0] == "element") {
      if (words.size() != 3 || words[2].empty() || words[2].find_first_not_of("0123456789") != std::string::npos ||
          words[2].size() > 18)
        refuse(where + ": an element is 'element NAME COUNT'");
      elements.push_back({words[1], std::stoull(words[2]), {}});
    } else if (words[0] == "property") {
      if (elements.empty()) refuse(where + ": a property before any element");
      Property p;
      if (words.size() == 5 && words[1] == "list") {
        p.countSize = typeSize(words[2], &p.signedCount, nullptr);
        p.size = typeSize(words[3], nullptr, &p.integer);
      } else if (words.size() == 3) {
        p.size = typeSize(words[1], nullptr, &p.integer);
      } else {
        refuse(where + ": a property is 'property TYPE NAME' or 'property list COUNT_TYPE TYPE NAME'");
      }
      elements.back().properties.push_back(p);
    } else if (words[0] == "end_header" && words.size() == 1) {
      if (!formatSeen) refuse(where + ": no format line before it");
      break;
    } else {
      refuse(where + ": not a header line");
    }
  }
  if (ascii) {
    refuseNul(data, size, what, "ASCII PLY");
    // one line per item, as many numbers on it as its properties (and lists) say
    int line = 0;
    for (const Element& e : elements)
      for (unsigned long long item = 0; item < e.count; ++item) {
        const std::string where = "element '" + e.name + "' " + std::to_string(item) + " of " + std::to_string(e.count);
        if (at >= size) refuse(where + ": the file ends before it");
        const size_t end = std::find(data + at, data + size, '\n') - data;
        std::string text(reinterpret_cast<const char*>(data) + at, end - at);
        at = std::min(end + 1, size);
        ++line;
        if (!text.empty() && text.back() == '\r') text.pop_back();
        const std::vector<std::string> words = wordsOf(text);
        const std::string here = where + " (body line " + std::to_string(line) + ")";
        size_t w = 0;
        for (const Property& p : e.properties) {
          size_t n = 1;
          if (p.countSize > 0) {
            if (w >= words.size() || !plyNumber(words[w], true) || words[w][0] == '-' || words[w].size() > 9)
              refuse(here + ": '" + (w < words.size() ? printable(words[w]) : "") + "' is no list length");
            n = std::stoul(words[w++]);
          }
          for (size_t k = 0; k < n; ++k, ++w)
            if (w >= words.size() || !plyNumber(words[w], p.integer))
              refuse(here + ": '" + (w < words.size() ? printable(words[w]) : "") + "' is no " +
                     (p.integer ? "integer" : "number") + (w >= words.size() ? " (the line ends)" : ""));
        }
        if (w != words.size())
          refuse(here + ": " + std::to_string(words.size() - w) + " values more than its properties");
      }
    return;
  }
  // the body: every element's items, each list as long as its count says
  for (const Element& e : elements) {
    bool fixed = true;
    unsigned long long itemBytes = 0;
    for (const Property& p : e.properties) {
      fixed = fixed && p.countSize == 0;
      itemBytes += p.size;
    }
    if (fixed) {
      const unsigned long long left = size - at;
      if (itemBytes > 0 && e.count > left / itemBytes)
        refuse("element '" + e.name + "': " + std::to_string(e.count) + " of " + std::to_string(itemBytes) +
               " bytes each, but the file has " + std::to_string(left) + " bytes left");
      at += itemBytes * e.count;
      continue;
    }
    for (unsigned long long item = 0; item < e.count; ++item)
      for (const Property& p : e.properties) {
        auto past = [&](size_t bytes) {
          if (bytes > size - at)
            refuse("element '" + e.name + "' " + std::to_string(item) + " of " + std::to_string(e.count) +
                   ": the file ends inside it (" + std::to_string(size - at) + " bytes left, " + std::to_string(bytes) +
                   " needed)");
        };
        if (p.countSize == 0) {
          past(p.size);
          at += p.size;
          continue;
        }
        past(p.countSize);
        uint64_t n = 0;
        for (int b = 0; b < p.countSize; ++b) {
          const int byte = bigEndian ? b : p.countSize - 1 - b;
          n = (n << 8) | data[at + byte];
        }
        if (p.signedCount && (n >> (8 * p.countSize - 1)) != 0)
          refuse("element '" + e.name + "' " + std::to_string(item) + ": a list of negative length");
        at += p.countSize;
        past(n * p.size);  // n < 2^32, size <= 8: no overflow
        at += n * p.size;
      }
  }
}

/// assimp's ASCII STL reader throws from inside itself, leaking the mesh and node it was
/// filling, on a number that is none ("vertex 0.1pmx -0.02 -0.1") and on a facet of fewer
/// than three vertices ("STL: Invalid number of vertices"), both found by fuzz_mesh_import,
/// and on a facet without its normal or a name of 1024 characters. An STL that assimp reads
/// as text (it begins with "solid" and is not a binary STL by its size; assimp's test for
/// bytes past ASCII compares a signed char with 127, so it never finds one) is first walked
/// by the format's grammar: solid NAME, then facets of "facet normal X Y Z", "outer loop",
/// three "vertex X Y Z", "endloop", "endfacet", then "endsolid NAME" (another solid may
/// follow); a file that strays from it is refused naming the line. Other files pass.
void checkAsciiStl(const uint8_t* data, size_t size, const std::string& what) {
  if (size >= 84) {
    uint32_t faces;
    std::memcpy(&faces, data + 80, 4);
    if (uint64_t(faces) * 50 + 84 == size) return;  // binary, by assimp's test
  }
  size_t start = 0;
  while (start < size && (data[start] == ' ' || data[start] == '\t' || data[start] == '\r' || data[start] == '\n'))
    ++start;
  if (start + 5 >= size || std::memcmp(data + start, "solid", 5) != 0) return;
  refuseNul(data, size, what, "ASCII STL");
  // every word, with the line it is on
  struct Word {
    std::string text;
    int line;
  };
  std::vector<Word> words;
  int line = 1;
  for (size_t i = 0; i < size;) {
    const uint8_t c = data[i];
    if (c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v' || c == 0) {
      line += c == '\n';
      ++i;
      continue;
    }
    const size_t from = i;
    while (i < size && data[i] != ' ' && data[i] != '\t' && data[i] != '\r' && data[i] != '\n' && data[i] != '\f' &&
           data[i] != '\v' && data[i] != 0)
      ++i;
    words.push_back({std::string(reinterpret_cast<const char*>(data) + from, i - from), line});
  }
  size_t w = 0;
  auto refuse = [&](const std::string& expected) {
    const std::string found = w < words.size() ? "'" + printable(words[w].text) + "'" : "the end of the file";
    throw mpm::Error("loadTriangleMesh: " + what + ": STL line " +
                     std::to_string(w < words.size() ? words[w].line : line) + ": " + expected + " expected, " + found +
                     " found");
  };
  auto expect = [&](const char* word) {
    if (w >= words.size() || words[w].text != word) refuse(std::string("'") + word + "'");
    ++w;
  };
  // the three numbers on the keyword's line (assimp's reader does not look past its end)
  auto numbers = [&](const char* after) {
    const int on = words[w - 1].line;
    for (int k = 0; k < 3; ++k, ++w)
      if (w >= words.size() || words[w].line != on || !plyNumber(words[w].text, false))
        refuse(std::string("a number (") + std::to_string(k + 1) + " of 3 after '" + after + "', on its line)");
  };
  auto restOfLine = [&](int of) {
    size_t length = 0;
    for (; w < words.size() && words[w].line == of; ++w) length += words[w].text.size() + 1;
    return length;
  };
  // assimp takes a word that begins with "solid" (or "endsolid") for the keyword and its name
  while (w < words.size() && words[w].text.compare(0, 5, "solid") == 0) {
    const int at = words[w].line;
    if (restOfLine(at) >= 1024 + 6) throw mpm::Error("loadTriangleMesh: " + what + ": STL line " + std::to_string(at) +
                                                 ": the solid's name is 1024 characters or more");
    while (w < words.size() && words[w].text == "facet") {
      ++w;
      expect("normal");
      numbers("normal");
      expect("outer");
      expect("loop");
      for (int k = 0; k < 3; ++k) {
        expect("vertex");
        numbers("vertex");
      }
      expect("endloop");
      expect("endfacet");
    }
    if (w == words.size()) return;  // no endsolid: assimp warns and keeps what it read
    if (words[w].text.compare(0, 8, "endsolid") != 0) refuse("'facet' or 'endsolid'");
    restOfLine(words[w].line);
  }
}

/// assimp's glTF reader decodes a buffer's "data:...;base64," URI and throws from inside
/// itself on a character that is no base64, leaking the buffer it was filling
/// (fuzz_mesh_import found one). Every base64 data URI of a .gltf or .glb is checked first:
/// the alphabet A-Z a-z 0-9 + /, at most two '=' at its end, a length a multiple of 4;
/// refused naming the URI's position in the file.
void checkGltfDataUris(const uint8_t* data, size_t size, const std::string& what) {
  static const char kMarker[] = ";base64,";
  const uint8_t* end = data + size;
  for (const uint8_t* at = data; (at = std::search(at, end, kMarker, kMarker + 8)) != end;) {
    at += 8;
    const uint8_t* stop = at;
    size_t padding = 0;
    for (; stop != end && *stop != '"'; ++stop) {
      const uint8_t c = *stop;
      const bool letter = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '+' || c == '/';
      if (c == '=' && padding < 2) {
        ++padding;
        continue;
      }
      if (!letter || padding > 0)
        throw mpm::Error("loadTriangleMesh: " + what + ": the base64 data URI at byte " + std::to_string(at - data) +
                         " holds '" + printable(std::string(1, (char)c)) + "' at byte " + std::to_string(stop - data) +
                         ", no base64 character");
    }
    if ((stop - at) % 4 != 0)
      throw mpm::Error("loadTriangleMesh: " + what + ": the base64 data URI at byte " + std::to_string(at - data) + " is " +
                       std::to_string(stop - at) + " characters long, not a multiple of 4");
    at = stop;
  }
}

/// assimp's OBJ reader checks a face's vertex, texture and normal indices only once it builds
/// the mesh, and throws from there, leaking the mesh (fuzz_mesh_import found "vertex index
/// out of range"). Every index of an "f", "l" or "p" line is checked first: an integer, not
/// 0, counting from 1 up to the file's number of "v" (and "vt", "vn") lines, or back from
/// -1 over those read so far; and those lines hold numbers only, 3 to 7 for "v", 1 to 3 for
/// "vt", 3 for "vn"; refused naming the line.
void checkObjIndices(const uint8_t* data, size_t size, const std::string& what) {
  struct Reference {
    long long index;
    int kind;  // 0 v, 1 vt, 2 vn
    int line;
  };
  refuseNul(data, size, what, "OBJ text");
  std::vector<Reference> references;
  long long count[3] = {0, 0, 0};
  int line = 0;
  for (size_t at = 0; at < size;) {
    const size_t end = std::find(data + at, data + size, '\n') - data;
    const std::string text(reinterpret_cast<const char*>(data) + at, end - at);
    at = end + 1;
    ++line;
    const std::vector<std::string> words = wordsOf(text);
    if (words.empty()) continue;
    const std::string& key = words[0];
    if (key == "v" || key == "vt" || key == "vn") {
      // numbers only (assimp counts a line's numbers to tell its kind of vertex: a word that
      // is none made it read a vertex short, and a face's index then named none: found by
      // the fuzzer, "v 0.03 0ase51 -0.01")
      const size_t least = key == "vt" ? 1 : 3, most = key == "v" ? 7 : 3;
      if (words.size() - 1 < least || words.size() - 1 > most)
        throw mpm::Error("loadTriangleMesh: " + what + ": OBJ line " + std::to_string(line) + ": '" + key + "' with " +
                         std::to_string(words.size() - 1) + " values (" + std::to_string(least) + " to " +
                         std::to_string(most) + ")");
      for (size_t w = 1; w < words.size(); ++w) {
        std::string word = words[w];
        if (!word.empty() && word.back() == '\r') word.pop_back();
        if (!plyNumber(word, false))
          throw mpm::Error("loadTriangleMesh: " + what + ": OBJ line " + std::to_string(line) + ": '" + printable(word) +
                           "' is no number");
      }
      ++count[key == "v" ? 0 : key == "vt" ? 1 : 2];
    }
    if (key != "f" && key != "l" && key != "p") continue;
    for (size_t w = 1; w < words.size(); ++w) {
      std::string word = words[w];
      if (!word.empty() && word.back() == '\r') word.pop_back();
      if (word.empty()) continue;
      size_t from = 0;
      for (int kind = 0; kind < 3 && from <= word.size(); ++kind) {
        const size_t slash = std::min(word.find('/', from), word.size());
        const std::string part = word.substr(from, slash - from);
        from = slash + 1;
        if (part.empty() && kind > 0) continue;  // "1//3": no texture index
        if (!plyNumber(part, true) || part.size() > 12)
          throw mpm::Error("loadTriangleMesh: " + what + ": OBJ line " + std::to_string(line) + ": '" + printable(word) +
                           "' is no vertex reference");
        const long long index = std::stoll(part);
        if (index == 0 || (index < 0 && -index > count[kind]))
          throw mpm::Error("loadTriangleMesh: " + what + ": OBJ line " + std::to_string(line) + ": index " + part +
                           " in '" + printable(word) + "' names no " + (kind == 0 ? "vertex" : kind == 1 ? "texture coordinate" : "normal"));
        if (index > 0) references.push_back({index, kind, line});
        if (slash == word.size()) break;
      }
    }
  }
  for (const Reference& r : references)
    if (r.index > count[r.kind])
      throw mpm::Error("loadTriangleMesh: " + what + ": OBJ line " + std::to_string(r.line) + ": index " +
                       std::to_string(r.index) + " names no " +
                       (r.kind == 0 ? "vertex" : r.kind == 1 ? "texture coordinate" : "normal") + " (the file has " +
                       std::to_string(count[r.kind]) + ")");
}

/// The checks above, before assimp reads `data` as a file of extension `extension`. assimp
/// picks its reader by the extension, but when that reader does not recognise the bytes it
/// tries every reader on them (fuzz_mesh_import found an ASCII STL read through the hint
/// "glb"): so the checks that look for their own format's signature (PLY, ASCII STL, glTF's
/// data URIs) run on every file, and the OBJ check, which has no signature, on a file named
/// .obj or one named .stl, .ply, .gltf or .glb that does not carry that format's signature.
void checkBeforeAssimp(const uint8_t* data, size_t size, std::string extension, const std::string& what) {
  for (char& c : extension) c = (char)std::tolower((unsigned char)c);
  checkPly(data, size, what);
  checkAsciiStl(data, size, what);
  checkGltfDataUris(data, size, what);
  auto startsWith = [&](const char* magic) {
    const size_t n = std::strlen(magic);
    return size >= n && std::memcmp(data, magic, n) == 0;
  };
  size_t first = 0;
  while (first < size && std::isspace(data[first])) ++first;
  bool signed_ = false;
  if (extension == "ply") signed_ = startsWith("ply");
  else if (extension == "glb") signed_ = startsWith("glTF");
  else if (extension == "gltf") signed_ = first < size && data[first] == '{';
  else if (extension == "stl") {
    uint32_t faces = 0;
    if (size >= 84) std::memcpy(&faces, data + 80, 4);
    signed_ = (size >= 84 && uint64_t(faces) * 50 + 84 == size) ||
              (first + 5 < size && std::memcmp(data + first, "solid", 5) == 0);
  }
  const bool ours = extension == "ply" || extension == "glb" || extension == "gltf" || extension == "stl";
  if (extension == "obj" || (ours && !signed_)) checkObjIndices(data, size, what);
}

/// An assimp file system with no files in it: reading from memory, the bytes given are the
/// whole input, and nothing else on the disk is read on their say.
class NoFiles : public Assimp::IOSystem {
 public:
  bool Exists(const char*) const override { return false; }
  char getOsSeparator() const override { return '/'; }
  Assimp::IOStream* Open(const char*, const char*) override { return nullptr; }
  void Close(Assimp::IOStream*) override {}
};

// ------------------------------------------------------------------ Bullet shapes

void validateForBullet(const mpm::TriangleMesh& mesh, float margin) {
  if (mesh.triangleCount() == 0 || mesh.indices.size() % 3 != 0)
    throw mpm::InvalidArgument("TriangleMesh.indices", std::to_string(mesh.indices.size()) + " indices",
                               "a shape needs at least one triangle and three indices per triangle");
  for (size_t i = 0; i < mesh.indices.size(); ++i)
    if (mesh.indices[i] >= mesh.vertices.size())
      throw mpm::InvalidArgument("TriangleMesh.indices[" + std::to_string(i) + "]", std::to_string(mesh.indices[i]),
                                 "must be < the vertex count " + std::to_string(mesh.vertices.size()));
  if (mesh.vertices.size() > size_t(std::numeric_limits<int>::max()) ||
      mesh.indices.size() > size_t(std::numeric_limits<int>::max()))
    throw mpm::InvalidArgument("TriangleMesh.vertices", std::to_string(mesh.vertices.size()) + " vertices",
                               "too many for Bullet's int indices");
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    const mpm::Vec3f v = mesh.vertices[i];
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
      throw mpm::InvalidArgument("TriangleMesh.vertices[" + std::to_string(i) + "]",
                                 "(" + show(v.x) + ", " + show(v.y) + ", " + show(v.z) + ")",
                                 "every component must be a finite number");
  }
  if (!std::isfinite(margin) || margin < 0.f)
    throw mpm::InvalidArgument("margin", show(margin), "must be a finite number >= 0");
}

/// A btStridingMeshInterface that owns its triangles: copies of the mesh's vertices and
/// indices, which the base class's btIndexedMesh points into. The vectors are filled once
/// and never resized, so those pointers stay valid for the object's life.
class OwnedTriangleArray : public btTriangleIndexVertexArray {
 public:
  explicit OwnedTriangleArray(const mpm::TriangleMesh& mesh) {
    vertices_.reserve(3 * mesh.vertices.size());
    for (const mpm::Vec3f& v : mesh.vertices) vertices_.insert(vertices_.end(), {btScalar(v.x), btScalar(v.y), btScalar(v.z)});
    indices_.assign(mesh.indices.begin(), mesh.indices.end());
    btIndexedMesh part;
    part.m_numTriangles = static_cast<int>(mesh.triangleCount());
    part.m_triangleIndexBase = reinterpret_cast<const unsigned char*>(indices_.data());
    part.m_triangleIndexStride = 3 * sizeof(int);
    part.m_numVertices = static_cast<int>(mesh.vertices.size());
    part.m_vertexBase = reinterpret_cast<const unsigned char*>(vertices_.data());
    part.m_vertexStride = 3 * sizeof(btScalar);  // m_vertexType defaults to btScalar's type
    addIndexedMesh(part, PHY_INTEGER);
  }
  OwnedTriangleArray(const OwnedTriangleArray&) = delete;
  OwnedTriangleArray& operator=(const OwnedTriangleArray&) = delete;

 private:
  std::vector<btScalar> vertices_;
  std::vector<int> indices_;
};

// Base-from-member: a base listed before the Bullet shape is built before it and destroyed
// after it, so the triangle data outlives everything the shape does with it.
struct OwnedTriangleArrayHolder {
  std::unique_ptr<OwnedTriangleArray> triangles;
};

class OwningBvhTriangleMeshShape : private OwnedTriangleArrayHolder, public btBvhTriangleMeshShape {
 public:
  explicit OwningBvhTriangleMeshShape(std::unique_ptr<OwnedTriangleArray> data)
      : OwnedTriangleArrayHolder{std::move(data)},
        btBvhTriangleMeshShape(triangles.get(), /*useQuantizedAabbCompression=*/true, /*buildBvh=*/true) {}
};

class OwningGImpactMeshShape : private OwnedTriangleArrayHolder, public btGImpactMeshShape {
 public:
  explicit OwningGImpactMeshShape(std::unique_ptr<OwnedTriangleArray> data)
      : OwnedTriangleArrayHolder{std::move(data)}, btGImpactMeshShape(triangles.get()) {}
};

}  // namespace

mpm::TriangleMesh loadTriangleMesh(const std::string& path, float scale) {
  checkScale(scale);
  {
    std::ifstream in(path, std::ios::binary);
    const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const size_t dot = path.find_last_of('.'), slash = path.find_last_of("/\\");
    const bool dotted = dot != std::string::npos && (slash == std::string::npos || dot > slash);
    if (in || !bytes.empty()) checkBeforeAssimp(bytes.data(), bytes.size(), dotted ? path.substr(dot + 1) : "", "'" + path + "'");
  }
  Assimp::Importer importer;
  configure(importer);
  const std::string what = "'" + path + "'";
  const aiScene* scene = postProcessed(importer, importer.ReadFile(path, kReadSteps), what);
  return collectTriangles(importer, scene, what, scale);
}

mpm::TriangleMesh loadTriangleMeshFromMemory(const void* data, size_t size, const std::string& formatHint,
                                             float scale, const std::string& name) {
  checkScale(scale);
  if (data == nullptr) throw mpm::InvalidArgument("data", "NULL", "must point to the file's bytes");
  if (size == 0) throw mpm::InvalidArgument("size", "0", "a mesh file is not empty");
  Assimp::Importer importer;
  // assimp picks the reader from the name's extension: a hint that names none, or a path,
  // would make it guess from the bytes or look elsewhere
  if (formatHint.empty() || formatHint.size() > 16 ||
      formatHint.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789") !=
          std::string::npos ||
      !importer.IsExtensionSupported("." + formatHint))
    throw mpm::InvalidArgument("formatHint", "'" + formatHint + "'",
                               "must be the extension of a mesh format assimp reads (obj, stl, ply, gltf, glb, ...)");
  const std::string what = name + " (" + formatHint + ")";
  checkBeforeAssimp(static_cast<const uint8_t*>(data), size, formatHint, what);
  configure(importer);
  // the bytes are the whole file: a reference to another file finds nothing
  importer.SetIOHandler(new NoFiles);
  const aiScene* scene =
      postProcessed(importer, importer.ReadFileFromMemory(data, size, kReadSteps, formatHint.c_str()), what);
  return collectTriangles(importer, scene, what, scale);
}

std::unique_ptr<btCollisionShape> makeBvhTriangleMeshShape(const mpm::TriangleMesh& mesh, float margin) {
  validateForBullet(mesh, margin);
  auto shape = std::make_unique<OwningBvhTriangleMeshShape>(std::make_unique<OwnedTriangleArray>(mesh));
  shape->setMargin(margin);
  return shape;
}

std::unique_ptr<btCollisionShape> makeConvexHullShape(const mpm::TriangleMesh& mesh, float margin) {
  validateForBullet(mesh, margin);
  // only the vertices the triangles use
  std::vector<char> used(mesh.vertices.size(), 0);
  for (uint32_t index : mesh.indices) used[index] = 1;
  auto shape = std::make_unique<btConvexHullShape>();
  for (size_t i = 0; i < mesh.vertices.size(); ++i)
    if (used[i]) {
      const mpm::Vec3f v = mesh.vertices[i];
      shape->addPoint(btVector3(v.x, v.y, v.z), /*recalculateLocalAabb=*/false);
    }
  shape->optimizeConvexHull();
  shape->setMargin(margin);
  // the cached local box includes the margin: recompute it after changing the margin
  shape->recalcLocalAabb();
  return shape;
}

std::unique_ptr<btCollisionShape> makeGImpactMeshShape(const mpm::TriangleMesh& mesh, float margin) {
  validateForBullet(mesh, margin);
  auto shape = std::make_unique<OwningGImpactMeshShape>(std::make_unique<OwnedTriangleArray>(mesh));
  shape->setMargin(margin);
  shape->updateBound();
  return shape;
}

}  // namespace mpm::bullet
