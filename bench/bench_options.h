#pragma once
// Command-line pieces the benchmarks share: --backend, and the solvers by their names
// (the SolverType enumerators' names: MlsMpm, StandardMpm, PbMpm, Mtled).
#include <map>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "mpm/settings.h"

namespace mpm::bench {

inline CLI::Option* addBackendOption(CLI::App& app, mpm::Backend& backend) {
  return app
      .add_option("--backend", backend, "backend of every run: cpu or cuda")
      ->transform(CLI::CheckedTransformer(
          std::map<std::string, mpm::Backend>{{"cpu", mpm::Backend::Cpu}, {"cuda", mpm::Backend::Cuda}},
          CLI::ignore_case))
      ->capture_default_str();
}

inline const std::map<std::string, mpm::SolverType>& solverTypes() {
  static const std::map<std::string, mpm::SolverType> types{{"MlsMpm", mpm::SolverType::MlsMpm},
                                                             {"StandardMpm", mpm::SolverType::StandardMpm},
                                                             {"PbMpm", mpm::SolverType::PbMpm},
                                                             {"Mtled", mpm::SolverType::Mtled}};
  return types;
}

/// The name of a solver, as --solvers takes it.
inline std::string solverName(mpm::SolverType type) {
  for (const auto& [name, t] : solverTypes())
    if (t == type) return name;
  return "?";
}

/// --solvers: names of solvers to run, in the order given (checked against solverTypes()).
inline CLI::Option* addSolversOption(CLI::App& app, std::vector<std::string>& solvers) {
  std::vector<std::string> names;
  for (const auto& [name, t] : solverTypes()) names.push_back(name);
  return app.add_option("--solvers", solvers, "solvers to run: MlsMpm, StandardMpm, PbMpm, Mtled")
      ->delimiter(',')
      ->check(CLI::IsMember(names))
      ->capture_default_str();
}

}  // namespace mpm::bench
