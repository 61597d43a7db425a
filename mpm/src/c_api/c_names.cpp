#include "c_api/c_names.h"

#include <cctype>
#include <utility>

namespace mpm::c_api {

namespace {

/// C++ field prefixes and the C fields they come from (mpm_c.h); the longest that matches
/// applies, the rest of the name is made snake_case.
const std::pair<const char*, const char*> kPrefixes[] = {
    {"SceneSettings.domain.lower", "mpm_scene_settings.domain_lower"},
    {"SceneSettings.domain.upper", "mpm_scene_settings.domain_upper"},
    {"SceneSettings.pbMpm.iterations", "mpm_scene_settings.pb_iterations"},
    {"SceneSettings.substeps.cflNumber", "mpm_scene_settings.cfl_number"},
    {"SceneSettings.", "mpm_scene_settings."},
    {"ParticleObjectDesc.", "mpm_object_desc."},
    {"ShapeDesc.contact.mode", "mpm_shape_desc.contact_mode"},
    {"ShapeDesc.contact.", "mpm_shape_desc."},
    {"ShapeDesc.pose", "mpm_shape_desc.state.pose"},
    {"ShapeDesc.linearVelocity", "mpm_shape_desc.state.linear_velocity"},
    {"ShapeDesc.angularVelocity", "mpm_shape_desc.state.angular_velocity"},
    {"ShapeDesc.", "mpm_shape_desc."},
    {"ShapeState.", "mpm_body_state."},
    {"QuadSlicerDesc.pose", "mpm_quad_slicer_desc.state.pose"},
    {"QuadSlicerDesc.linearVelocity", "mpm_quad_slicer_desc.state.linear_velocity"},
    {"QuadSlicerDesc.angularVelocity", "mpm_quad_slicer_desc.state.angular_velocity"},
    {"QuadSlicerDesc.", "mpm_quad_slicer_desc."},
    {"MeshSlicerDesc.pose", "mpm_mesh_slicer_desc.state.pose"},
    {"MeshSlicerDesc.linearVelocity", "mpm_mesh_slicer_desc.state.linear_velocity"},
    {"MeshSlicerDesc.angularVelocity", "mpm_mesh_slicer_desc.state.angular_velocity"},
    {"MeshSlicerDesc.", "mpm_mesh_slicer_desc."},
    {"ArcDesc.pose", "mpm_arc_desc.state.pose"},
    {"ArcDesc.linearVelocity", "mpm_arc_desc.state.linear_velocity"},
    {"ArcDesc.angularVelocity", "mpm_arc_desc.state.angular_velocity"},
    {"ArcDesc.", "mpm_arc_desc."},
    {"LineSegmentsDesc.", "mpm_line_segments_desc."},
};

bool nameChar(char c) { return std::isalnum((unsigned char)c) || c == '_' || c == '.' || c == '[' || c == ']'; }

std::string snakeCase(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (std::isupper((unsigned char)c)) {
      out += '_';
      out += (char)std::tolower((unsigned char)c);
    } else {
      out += c;
    }
  }
  return out;
}

/// One name, from its first character to its end: its C spelling, or itself.
std::string cName(std::string name, const std::string& call) {
  // a shape's parts: one part is the mpm_shape_desc itself, a compound's the array `parts`
  const std::string parts = "ShapeDesc.parts[";
  if (name.compare(0, parts.size(), parts) == 0) {
    const size_t close = name.find("].");
    if (close != std::string::npos) {
      const std::string rest = snakeCase(name.substr(close + 2));
      return call == "mpm_scene_add_compound_shape" ? "parts" + name.substr(parts.size() - 1, close + 2 - (parts.size() - 1)) + rest
                                                    : "mpm_shape_desc." + rest;
    }
  }
  size_t best = 0;
  const char* to = nullptr;
  for (const auto& [from, c] : kPrefixes) {
    const std::string f = from;
    // a prefix of the name (so name[f.size()] exists or is its end) that ends where a name part does
    if (f.size() <= best || name.compare(0, f.size(), f) != 0) continue;
    const bool whole = name.size() == f.size() || f.back() == '.' || !std::isalnum((unsigned char)name[f.size()]);
    if (whole) best = f.size(), to = c;
  }
  return to ? to + snakeCase(name.substr(best)) : name;
}

}  // namespace

std::string cNames(const std::string& message, const std::string& call) {
  std::string out;
  for (size_t i = 0; i < message.size();) {
    // a name starts with a capital after something that is no part of a name
    if (std::isupper((unsigned char)message[i]) && (i == 0 || !nameChar(message[i - 1]))) {
      size_t end = i;
      while (end < message.size() && nameChar(message[end])) ++end;
      while (end > i && message[end - 1] == '.') --end;  // a sentence's full stop
      out += cName(message.substr(i, end - i), call);
      i = end;
    } else {
      out += message[i++];
    }
  }
  return out;
}

}  // namespace mpm::c_api
