#pragma once
// Private to mpm_bullet: the format pre-checks (mesh_format_checks.cpp) that mesh_import.cpp
// runs on a mesh file's bytes before assimp reads them.
#include <cstddef>
#include <cstdint>
#include <string>

namespace mpm::bullet::detail {

/// Refuses (mpm::Error, "loadTriangleMesh: WHAT: ...") bytes that assimp 5.2.5's readers
/// would crash or leak on: a malformed PLY, ASCII STL, glTF base64 data URI, or OBJ (the OBJ
/// check on a file named .obj, or named .stl, .ply, .gltf or .glb without that format's
/// signature). `extension` is the file's extension or format hint, any case, without the
/// dot; `what` names the source in errors. Other input passes unchecked.
void checkBeforeAssimp(const uint8_t* data, size_t size, std::string extension, const std::string& what);

}  // namespace mpm::bullet::detail
