#pragma once
// The C API's errors in the C header's names: the library names fields as its C++ structs
// spell them ("SceneSettings.dx", "ShapeDesc.parts[0].radius"); a C caller wrote
// mpm_scene_settings.dx and mpm_shape_desc.radius.
#include <string>

namespace mpm::c_api {

/// `message` with every C++ field name in it given as the C field that set it, for an
/// error of `call` (a single shape's parts[0] is its mpm_shape_desc, a compound's parts[i]
/// its mpm_shape_part array `parts`).
std::string cNames(const std::string& message, const std::string& call);

}  // namespace mpm::c_api
