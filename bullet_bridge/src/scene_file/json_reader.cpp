#include "scene_file/json_reader.h"

#include <cmath>
#include <cstdlib>
#include <sstream>
#include <limits>

namespace mpm::bullet::scene_file {

namespace {

/// A float as mpm::validate::show writes it: the shortest text that reads back, "nan" for
/// any NaN, "inf" and "-inf".
std::string number(float value) {
  if (std::isnan(value)) return "nan";
  std::string text;
  for (int digits = 6; digits <= 9; ++digits) {
    std::ostringstream s;
    s.precision(digits);
    s << value;
    text = s.str();
    if (std::strtof(text.c_str(), nullptr) == value || !std::isfinite(value)) break;
  }
  return text;
}

/// JSON text, but with nan, inf and -inf where dump() writes null: a number from Python
/// (Scene(settings), add_object) may be any double.
std::string text(const Json& value) {
  if (value.is_number_float() && !std::isfinite(value.get<double>())) return number((float)value.get<double>());
  if (value.is_array()) {
    std::string s = "[";
    for (size_t i = 0; i < value.size(); ++i) s += (i ? "," : "") + text(value[i]);
    return s + "]";
  }
  if (value.is_object()) {
    std::string s = "{";
    for (auto it = value.begin(); it != value.end(); ++it)
      s += (it == value.begin() ? "" : ",") + Json(it.key()).dump() + ":" + text(it.value());
    return s + "}";
  }
  return value.dump();
}

}  // namespace

std::string show(const Json& value) {
  std::string s = text(value);
  // a whole object in a one-line message helps nobody
  if (s.size() > 60) s = s.substr(0, 57) + "...";
  return s;
}

void fail(const std::string& path, const Json& value, const std::string& why) {
  throw InvalidArgument(path, show(value), why);
}

void fail(const std::string& path, float value, const std::string& why) { throw InvalidArgument(path, number(value), why); }

void failMissing(const std::string& path, const std::string& why) { throw InvalidArgument(path, "missing", why); }

void rethrowAt(const InvalidArgument& e, const std::string& cppPrefix, const std::string& jsonPath) {
  const std::string& field = e.field();
  const std::string why = std::string(e.what()).substr(field.size() + 3 + e.value().size() + 2);  // "FIELD = VALUE: why"
  if (field.compare(0, cppPrefix.size(), cppPrefix) == 0)
    throw InvalidArgument(jsonPath + field.substr(cppPrefix.size()), e.value(), why);
  throw InvalidArgument(jsonPath, field + " = " + e.value(), why);
}

std::string child(const std::string& path, const std::string& key) { return path.empty() ? key : path + "." + key; }
std::string element(const std::string& path, size_t i) { return path + "[" + std::to_string(i) + "]"; }

void parse(const Json& j, const std::string& path, double& out) {
  if (!j.is_number()) fail(path, j, "must be a number");
  out = j.get<double>();
}
void parse(const Json& j, const std::string& path, float& out) {
  double d;
  parse(j, path, d);
  if (!(std::fabs(d) <= std::numeric_limits<float>::max())) fail(path, j, "must be a finite float");
  out = (float)d;
}
void parse(const Json& j, const std::string& path, int& out) {
  if (!j.is_number_integer()) fail(path, j, "must be an integer");
  const long long v = j.get<long long>();
  if (v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max()) fail(path, j, "must fit an int");
  out = (int)v;
}
void parse(const Json& j, const std::string& path, bool& out) {
  if (!j.is_boolean()) fail(path, j, "must be true or false");
  out = j.get<bool>();
}
void parse(const Json& j, const std::string& path, std::string& out) {
  if (!j.is_string()) fail(path, j, "must be a string");
  out = j.get<std::string>();
}
void parse(const Json& j, const std::string& path, Vec3f& out) {
  if (!j.is_array() || j.size() != 3) fail(path, j, "must be an array of 3 numbers");
  for (size_t i = 0; i < 3; ++i) parse(j[i], element(path, i), out[(int)i]);
}
void parse(const Json& j, const std::string& path, Quat& out) {
  Node n(j, path);
  Vec3f axis{0.f, 0.f, 1.f};
  float angle = 0.f;
  n.readRequired("axis", axis);
  n.readRequired("angle", angle);
  n.finish();
  const float len = std::sqrt(dot(axis, axis));
  if (!(len > 0.f)) fail(n.at("axis"), j["axis"], "must not be zero");
  const float s = std::sin(0.5f * angle) / len;
  out = {std::cos(0.5f * angle), s * axis.x, s * axis.y, s * axis.z};
}
void parse(const Json& j, const std::string& path, Pose& out) {
  Node n(j, path);
  n.read("position", out.position);
  n.read("rotation", out.rotation);
  n.finish();
}

Node::Node(const Json& j, std::string path) : j_(j), path_(std::move(path)) {
  if (!j.is_object()) fail(path_.empty() ? "(scene)" : path_, j, "must be an object");
}

bool Node::has(const char* key) const { return j_.contains(key); }

const Json* Node::get(const char* key) {
  auto it = j_.find(key);
  if (it == j_.end()) return nullptr;
  seen_.insert(key);
  return &*it;
}

const Json& Node::require(const char* key) {
  const Json* j = get(key);
  if (!j) failMissing(at(key));
  return *j;
}

Node Node::object(const char* key) { return Node(require(key), at(key)); }

const Json& Node::array(const char* key) {
  static const Json empty = Json::array();
  const Json* j = get(key);
  if (!j) return empty;
  if (!j->is_array()) fail(at(key), *j, "must be an array");
  return *j;
}

void Node::finish() const {
  for (auto it = j_.begin(); it != j_.end(); ++it)
    if (!seen_.count(it.key())) fail(at(it.key().c_str()), it.value(), "unknown key");
}

}  // namespace mpm::bullet::scene_file
