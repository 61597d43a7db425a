#pragma once
// Paths to the repository's data for tests: assets/ and tests/reference/. The build
// passes the source folder in MPM_SOURCE_DIR, so tests run from any working directory.
#include <string>

namespace mpm::test {

inline std::string sourcePath(const std::string& relative) { return std::string(MPM_SOURCE_DIR) + "/" + relative; }
inline std::string assetPath(const std::string& name) { return sourcePath("assets/" + name); }
inline std::string referencePath(const std::string& name) { return sourcePath("tests/reference/" + name); }

}  // namespace mpm::test
