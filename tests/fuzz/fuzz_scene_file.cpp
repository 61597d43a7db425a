// libFuzzer target: the scene-file loader (mpm::bullet::LoadedScene::fromString, the
// reader behind mpm_run). The input is JSON text; file names in it are relative to
// assets/ (the seeds are assets/scenes/*.json). A loaded scene takes one Bullet tick of
// 0.1 ms when that is at most 100 MPM substeps. mpm::Error is the loader's answer to a bad
// file; any other exception, a crash or a sanitizer report is a finding.
//
// Work cap, so each input runs in milliseconds under ASan: before loading, a well-formed
// input's grid is coarsened to at most 16 cells along the domain's longest side, at most
// 2 particles per cell axis, 4 objects, 64 thread segments and mesh samples no finer
// than the coarsened dx. These are values the loader accepts (its checks stay in the
// path); the library's own limits (2 GB of grid, 1e8 particles) are real but too large for
// a fuzzer's memory budget. Inputs naming device or process files (/dev, /proc, /sys) are
// skipped: a scene may name any mesh file, and reading those never ends.
#include <BulletDynamics/Featherstone/btMultiBodyDynamicsWorld.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>

#include "mpm/error.h"
#include "mpm_bullet/scene_file.h"

#ifndef MPM_FUZZ_ASSETS_DIR
#error "MPM_FUZZ_ASSETS_DIR must name the assets folder"
#endif

namespace {

using nlohmann::json;

bool isNumber3(const json& v) {
  return v.is_array() && v.size() == 3 && v[0].is_number() && v[1].is_number() && v[2].is_number();
}

/// The work cap above, on a parsed scene (anything not shaped as expected is left for the
/// loader to refuse).
void capWork(json& scene) {
  if (!scene.is_object()) return;
  json* settings = scene.contains("settings") && scene["settings"].is_object() ? &scene["settings"] : nullptr;
  float extent = 2.f;  // SceneSettings' default domain is [-1, 1]^3
  if (settings && settings->contains("domain") && (*settings)["domain"].is_object()) {
    const json& d = (*settings)["domain"];
    if (d.contains("lower") && d.contains("upper") && isNumber3(d["lower"]) && isNumber3(d["upper"])) {
      extent = 0.f;
      for (int a = 0; a < 3; ++a) extent = std::max(extent, d["upper"][a].get<float>() - d["lower"][a].get<float>());
    }
  }
  const float dx = std::isfinite(extent) && extent > 0.f ? extent / 16.f : 0.125f;
  if (settings && settings->contains("dx") && (*settings)["dx"].is_number() && (*settings)["dx"].get<float>() < dx)
    (*settings)["dx"] = dx;
  if (scene.contains("objects") && scene["objects"].is_array()) {
    json& objects = scene["objects"];
    if (objects.size() > 4) objects.erase(objects.begin() + 4, objects.end());
    for (json& o : objects)
      if (o.is_object() && o.contains("particlesPerCellAxis") && o["particlesPerCellAxis"].is_number() &&
          o["particlesPerCellAxis"].get<double>() > 2)
        o["particlesPerCellAxis"] = 2;
  }
  if (scene.contains("threads") && scene["threads"].is_array())
    for (json& t : scene["threads"])
      if (t.is_object() && t.contains("segments") && t["segments"].is_number() && t["segments"].get<double>() > 64)
        t["segments"] = 64;
  if (scene.contains("bodies") && scene["bodies"].is_array())
    for (json& b : scene["bodies"])
      if (b.is_object() && b.contains("coupling") && b["coupling"].is_object() &&
          b["coupling"].contains("sdfCellSize") && b["coupling"]["sdfCellSize"].is_number() &&
          b["coupling"]["sdfCellSize"].get<float>() < dx)
        b["coupling"]["sdfCellSize"] = dx;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string text(reinterpret_cast<const char*>(data), size);
  for (const char* device : {"/dev", "/proc", "/sys"})
    if (text.find(device) != std::string::npos) return 0;
  // malformed JSON goes to the loader as it is: refusing it is the loader's job
  json parsed = json::parse(text, nullptr, /*allow_exceptions*/ false);
  if (!parsed.is_discarded()) {
    capWork(parsed);
    text = parsed.dump();
  }
  try {
    auto loaded = mpm::bullet::LoadedScene::fromString(text, MPM_FUZZ_ASSETS_DIR);
    const float tick = 1e-4f;
    if (tick <= 100.f * loaded->scene().maxSubstep()) {
      loaded->world().stepSimulation(tick, 1, tick);
      loaded->coupler().rethrowError();
    }
  } catch (const mpm::Error&) {
  }
  return 0;
}
