#pragma once
// The readers of a scene file's "settings" and of one "objects" entry, apart from the rest
// of a LoadedScene (no Bullet here): the Python module (python/src) reads its dicts through
// these, so a dict and a file are refused with the same messages.
#include <optional>
#include <string>

#include "mpm/output.h"
#include "mpm/scene.h"
#include "scene_file/json_reader.h"

namespace mpm::bullet::scene_file {

/// "settings": every field of SceneSettings by its name (settings_fields.h); null: defaults.
SceneSettings readSettings(const Json* settings);

/// One entry of "objects": the tissue and what the file adds to it.
struct ObjectEntry {
  std::optional<std::string> name;
  std::optional<io::Rgb> color;
  ParticleObjectDesc desc;
};
/// Reads the entry `j` at `path` (e.g. "objects[1]"); a mesh file is relative to `baseDir`
/// and sampled at half of `dx` unless it says otherwise. Refuses unknown keys.
ObjectEntry readObjectEntry(const Json& j, const std::string& path, const std::string& baseDir, float dx);
/// scene.addParticleObject(desc), its InvalidArgument renamed from ParticleObjectDesc to `path`.
ParticleObjectId addObjectAt(Scene& scene, const ParticleObjectDesc& desc, const std::string& path);

io::Rgb readColor(const Json& color, const std::string& path);
/// A file named at `path`, relative to `baseDir`; refused naming `path` when missing.
std::string resolveFile(const std::string& baseDir, const Json& name, const std::string& path);

}  // namespace mpm::bullet::scene_file
