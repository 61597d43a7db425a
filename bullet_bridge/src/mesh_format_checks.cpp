// Format pre-checks on a mesh file's bytes, run before assimp reads them (mesh_import.cpp).
// assimp 5.2.5's readers crash or leak on malformed OBJ, STL, PLY and glTF input, as
// fuzz_mesh_import found (reads past a buffer, exceptions thrown from inside a reader that
// leak what it was filling): each check walks its format's bytes and refuses such a file
// with the reason (mpm::Error), so assimp never sees it.
#include "mesh_format_checks.h"

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "mpm/error.h"

namespace mpm::bullet::detail {
namespace {

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

/// assimp's glTF 2 reader reads a LINE_LOOP primitive's (mode 2) indices without checking
/// them against its vertices: an index past them is a segmentation fault (fuzz_mesh_import
/// found one in a GLB). Lines hold no triangles, so a glTF or GLB with a primitive of mode 2
/// is refused before assimp reads it, naming the byte. The JSON (a GLB's first chunk, or the
/// whole .gltf) is scanned token by token: every string (escapes decoded, as assimp's reader
/// decodes them) that reads "mode" and is followed by ':' and a number equal to 2.
void checkGltfLineLoops(const uint8_t* data, size_t size, const std::string& what) {
  size_t begin = 0, end = size;
  if (size >= 20 && std::memcmp(data, "glTF", 4) == 0) {  // GLB: header, then the JSON chunk
    uint32_t length = 0;
    std::memcpy(&length, data + 12, 4);
    begin = 20;
    // a JSON chunk running past the file: assimp 5.2.5 took 4 GB over a truncated one
    if (uint64_t(20) + length > size)
      throw mpm::Error("loadTriangleMesh: " + what + ": the GLB's JSON chunk (" + std::to_string(length) +
                       " bytes from byte 20) runs past the file's " + std::to_string(size) + " bytes");
    end = 20 + (size_t)length;
  } else {
    while (begin < size && std::isspace(data[begin])) ++begin;
    if (begin == size || data[begin] != '{') return;  // no glTF JSON
  }
  std::string previous;  // the last string token, decoded
  uint8_t before = '{';    // the last character outside strings that is no space
  auto notJson = [&](size_t byte) {
    throw mpm::Error("loadTriangleMesh: " + what + ": the glTF JSON is not valid at byte " + std::to_string(byte) +
                     " (a string out of place)");
  };
  for (size_t at = begin; at < end;) {
    const uint8_t c = data[at];
    if (c == '"') {
      // in JSON a string follows '{', '[', ',' or ':' and is followed by ':', ',', '}' or
      // ']': quotes out of step made assimp 5.2.5 take 20 s and 4 GB over a 713-byte GLB
      // (fuzz_mesh_import, CI); such a file is refused here
      if (at > begin && !std::strchr("{[,:", before)) notJson(at);
      const size_t opening = at;
      std::string text;
      for (++at; at < end && data[at] != '"'; ++at) {
        if (data[at] != '\\' || at + 1 >= end) {
          text += (char)data[at];
          continue;
        }
        const uint8_t e = data[++at];
        if (e == 'u' && at + 4 < end) {
          const std::string hex(reinterpret_cast<const char*>(data) + at + 1, 4);
          char* stop = nullptr;
          const long code = std::strtol(hex.c_str(), &stop, 16);
          text += stop == hex.c_str() + 4 && code < 128 ? (char)code : '?';
          at += 4;
        } else {
          text += (char)e;
        }
      }
      if (at >= end) notJson(opening);  // no closing quote
      ++at;  // the closing quote
      size_t next = at;
      while (next < end && std::isspace(data[next])) ++next;
      if (next < end && !std::strchr(":,}]", data[next])) notJson(opening);
      previous = text;
      before = '"';
      continue;
    }
    if (c == ':' && previous == "mode") {
      size_t n = at + 1;
      while (n < end && std::isspace(data[n])) ++n;
      const std::string number(reinterpret_cast<const char*>(data) + n, std::min<size_t>(end - n, 32));
      char* stop = nullptr;
      const double mode = std::strtod(number.c_str(), &stop);
      if (stop != number.c_str() && mode == 2.0)
        throw mpm::Error("loadTriangleMesh: " + what + ": the glTF primitive mode at byte " + std::to_string(n) +
                         " is 2 (LINE_LOOP): lines hold no triangles");
    }
    if (!std::isspace(c)) {
      previous = c == ':' ? previous : std::string();
      before = c;
    }
    ++at;
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

}  // namespace

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
  checkGltfLineLoops(data, size, what);
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

}  // namespace mpm::bullet::detail
