#pragma once
// Reading JSON with the key path in every error: each value is read at a path such as
// "objects[1].material.poissonRatio" and refused, naming it, in the library's own form
// ("PATH = VALUE: why", mpm::InvalidArgument). Objects tick off the keys they read, so a
// key nobody read (a typo) is refused too.
#include <nlohmann/json.hpp>

#include <set>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "mpm/error.h"
#include "mpm/math.h"
#include "mpm/shapes.h"

namespace mpm::bullet::scene_file {

using Json = nlohmann::json;

/// The value as the error shows it: its JSON text, cut short when long.
std::string show(const Json& value);
[[noreturn]] void fail(const std::string& path, const Json& value, const std::string& why);
/// A number already read, shown as the library shows it (the shortest text that reads back).
[[noreturn]] void fail(const std::string& path, float value, const std::string& why);
[[noreturn]] void failMissing(const std::string& path, const std::string& why = "required");
/// Rethrows a library error whose field starts with `cppPrefix` (e.g. "ParticleObjectDesc")
/// with that prefix replaced by the JSON path (e.g. "objects[1]"), so the message names the
/// key in the file; any other error is named after `jsonPath` as a whole.
[[noreturn]] void rethrowAt(const InvalidArgument& e, const std::string& cppPrefix, const std::string& jsonPath);

std::string child(const std::string& path, const std::string& key);
std::string element(const std::string& path, size_t i);

/// Names of an enum's values as the C++ source spells them (SolverType::MlsMpm: "MlsMpm").
template <class E>
const std::vector<std::pair<const char*, E>>& enumNames();

void parse(const Json& j, const std::string& path, float& out);
void parse(const Json& j, const std::string& path, double& out);
void parse(const Json& j, const std::string& path, int& out);
void parse(const Json& j, const std::string& path, bool& out);
void parse(const Json& j, const std::string& path, std::string& out);
void parse(const Json& j, const std::string& path, Vec3f& out);
/// A rotation as {"axis": [x, y, z], "angle": rad} (Quat, w first).
void parse(const Json& j, const std::string& path, Quat& out);
void parse(const Json& j, const std::string& path, Pose& out);
template <class E, std::enable_if_t<std::is_enum_v<E>, int> = 0>
void parse(const Json& j, const std::string& path, E& out) {
  std::string names;
  if (j.is_string())
    for (const auto& [name, value] : enumNames<E>()) {
      if (j.get<std::string>() == name) {
        out = value;
        return;
      }
      names += (names.empty() ? "" : ", ") + std::string(name);
    }
  else
    for (const auto& nv : enumNames<E>()) names += (names.empty() ? "" : ", ") + std::string(nv.first);
  fail(path, j, "must be one of " + names);
}

/// A JSON object being read at `path`.
class Node {
 public:
  /// Refuses a value that is not an object.
  Node(const Json& j, std::string path);
  const std::string& path() const { return path_; }
  std::string at(const char* key) const { return child(path_, key); }
  bool has(const char* key) const;
  /// The value of `key` (ticked off as read), or null when absent.
  const Json* get(const char* key);
  const Json& require(const char* key);
  /// Reads `key` into `out` if present; returns whether it was.
  template <class T>
  bool read(const char* key, T& out) {
    const Json* j = get(key);
    if (j) parse(*j, at(key), out);
    return j != nullptr;
  }
  template <class T>
  void readRequired(const char* key, T& out) {
    parse(require(key), at(key), out);
  }
  /// `key` as an object (required / absent: false).
  Node object(const char* key);
  /// `key` as an array (absent: empty).
  const Json& array(const char* key);
  /// Refuses every key not read.
  void finish() const;

 private:
  const Json& j_;
  std::string path_;
  std::set<std::string> seen_;
};

}  // namespace mpm::bullet::scene_file
