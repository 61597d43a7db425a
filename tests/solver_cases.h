#pragma once
// Shared pieces of the solver-parameterised tests: every physics test of the foundation
// and coupling suites runs once per SolverType (MLS-MPM, standard MPM, PB-MPM), with a
// per-solver tolerance written down in the test where a solver is inherently less
// accurate, and why.
#include <gtest/gtest.h>

#include <string>
#include <tuple>

#include "mpm/settings.h"

namespace mpm::test {

/// The solver's name as it appears in test names: MlsMpm, StandardMpm, PbMpm.
inline std::string solverName(SolverType t) {
  switch (t) {
    case SolverType::MlsMpm: return "MlsMpm";
    case SolverType::StandardMpm: return "StandardMpm";
    case SolverType::PbMpm: return "PbMpm";
    case SolverType::Mtled: return "Mtled";
  }
  return "?";
}

/// The three grid solvers, for INSTANTIATE_TEST_SUITE_P (alone or inside ::testing::Combine).
inline auto allSolvers() { return ::testing::Values(SolverType::MlsMpm, SolverType::StandardMpm, SolverType::PbMpm); }
/// The three grid solvers and MTLED, for suites every solver can run.
inline auto everySolver() {
  return ::testing::Values(SolverType::MlsMpm, SolverType::StandardMpm, SolverType::PbMpm, SolverType::Mtled);
}

/// Test-name generator for a suite parameterised by the solver alone: "PbMpm".
inline auto solverParamName() {
  return [](const ::testing::TestParamInfo<SolverType>& info) { return solverName(info.param); };
}

/// Test-name generator for a suite parameterised by (something, solver): "<name>_<solver>",
/// with `name` naming the first parameter, e.g. "Cpu_PbMpm".
template <class First>
auto pairParamName(std::string (*name)(First)) {
  return [name](const ::testing::TestParamInfo<std::tuple<First, SolverType>>& info) {
    return name(std::get<0>(info.param)) + "_" + solverName(std::get<1>(info.param));
  };
}

/// Picks the value that applies to `solver`: the MLS-MPM one unless the solver has its own.
template <class T>
T perSolver(SolverType solver, T mls, T standard, T pb) {
  return solver == SolverType::StandardMpm ? standard : solver == SolverType::PbMpm ? pb : mls;
}

}  // namespace mpm::test
