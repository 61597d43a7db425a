// The enums' names in scene files, spelled as in the C++ source. The library has no
// name table of its own (tests/solver_cases.h and the demos each keep a partial one).
#include "mpm/settings.h"
#include "mpm/shapes.h"
#include "scene_file/json_reader.h"

namespace mpm::bullet::scene_file {

template <>
const std::vector<std::pair<const char*, SolverType>>& enumNames() {
  static const std::vector<std::pair<const char*, SolverType>> n{{"MlsMpm", SolverType::MlsMpm},
                                                                 {"StandardMpm", SolverType::StandardMpm},
                                                                 {"PbMpm", SolverType::PbMpm},
                                                                 {"Mtled", SolverType::Mtled}};
  return n;
}
template <>
const std::vector<std::pair<const char*, Backend>>& enumNames() {
  static const std::vector<std::pair<const char*, Backend>> n{
      {"Auto", Backend::Auto}, {"Cpu", Backend::Cpu}, {"Cuda", Backend::Cuda}};
  return n;
}
template <>
const std::vector<std::pair<const char*, WallMode>>& enumNames() {
  static const std::vector<std::pair<const char*, WallMode>> n{
      {"Sticky", WallMode::Sticky}, {"Slip", WallMode::Slip}, {"Separate", WallMode::Separate}};
  return n;
}
template <>
const std::vector<std::pair<const char*, MaterialModel>>& enumNames() {
  static const std::vector<std::pair<const char*, MaterialModel>> n{
      {"FixedCorotated", MaterialModel::FixedCorotated}, {"NeoHookeanDecoupled", MaterialModel::NeoHookeanDecoupled}};
  return n;
}
template <>
const std::vector<std::pair<const char*, PrimitiveType>>& enumNames() {
  static const std::vector<std::pair<const char*, PrimitiveType>> n{{"Box", PrimitiveType::Box},
                                                                    {"Sphere", PrimitiveType::Sphere},
                                                                    {"Cylinder", PrimitiveType::Cylinder},
                                                                    {"Mesh", PrimitiveType::Mesh}};
  return n;
}
template <>
const std::vector<std::pair<const char*, ContactMode>>& enumNames() {
  static const std::vector<std::pair<const char*, ContactMode>> n{
      {"Frictional", ContactMode::Frictional}, {"Sticky", ContactMode::Sticky}, {"Bonded", ContactMode::Bonded}};
  return n;
}

}  // namespace mpm::bullet::scene_file
