// "settings": any field of mpm::SceneSettings, through its field list (settings_fields.h),
// so a field added there is readable here without a line of its own:
// "SceneSettings.domain.lower" is settings.domain.lower, "...mirrorLower[1]" the second
// element of the array settings.domain.mirrorLower.
#include <map>

#include "mpm/settings_fields.h"
#include "scene_file/readers.h"

namespace mpm::bullet::scene_file {

namespace {

constexpr char kPrefix[] = "SceneSettings.";

/// The field's name below "settings", and its element index when it is one of an array's.
struct FieldPath {
  std::vector<std::string> keys;
  int index = -1;
};
FieldPath fieldPath(const std::string& name) {
  FieldPath p;
  std::string rest = name.substr(sizeof kPrefix - 1);
  const size_t bracket = rest.find('[');
  if (bracket != std::string::npos) {
    p.index = std::stoi(rest.substr(bracket + 1));
    rest = rest.substr(0, bracket);
  }
  for (size_t start = 0;;) {
    const size_t dot = rest.find('.', start);
    p.keys.push_back(rest.substr(start, dot - start));
    if (dot == std::string::npos) break;
    start = dot + 1;
  }
  return p;
}

std::string joined(const std::vector<std::string>& keys, size_t n) {
  std::string s = "settings";
  for (size_t i = 0; i < n; ++i) s += "." + keys[i];
  return s;
}

/// Refuses keys below `j` (at `path`) that name no field: `leaves` maps each field's
/// path below settings to its array length (1 for a scalar).
void checkKeys(const Json& j, const std::string& path, const std::string& below,
               const std::map<std::string, int>& leaves) {
  if (!j.is_object()) fail(path, j, "must be an object");
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string key = below.empty() ? it.key() : below + "." + it.key();
    if (leaves.count(key)) continue;
    const auto inner = leaves.lower_bound(key + ".");
    if (inner == leaves.end() || inner->first.compare(0, key.size() + 1, key + ".") != 0)
      fail(child(path, it.key()), it.value(), "unknown key");
    checkKeys(it.value(), child(path, it.key()), key, leaves);
  }
}

}  // namespace

SceneSettings readSettings(const Json* j) {
  SceneSettings s;
  if (!j) return s;
  std::map<std::string, int> leaves;
  forEachField(s, [&](const char* name, auto&, FieldRole) {
    const FieldPath p = fieldPath(name);
    std::string key = p.keys[0];
    for (size_t i = 1; i < p.keys.size(); ++i) key += "." + p.keys[i];
    int& n = leaves[key];
    n = std::max(n, p.index + 1);
  });
  checkKeys(*j, "settings", "", leaves);
  forEachField(s, [&](const char* name, auto& value, FieldRole) {
    const FieldPath p = fieldPath(name);
    const Json* at = j;
    for (const std::string& k : p.keys) {
      auto it = at->find(k);
      if (it == at->end()) return;  // absent: the default
      at = &*it;
    }
    const std::string path = joined(p.keys, p.keys.size());
    if (p.index < 0) return parse(*at, path, value);
    int size = 0;
    for (const auto& [k, n] : leaves)
      if (path == "settings." + k) size = n;
    if (!at->is_array() || (int)at->size() != size)
      fail(path, *at, "must be an array of " + std::to_string(size));
    parse((*at)[p.index], element(path, p.index), value);
  });
  return s;
}

}  // namespace mpm::bullet::scene_file
