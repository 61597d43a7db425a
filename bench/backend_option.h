#pragma once
// The benchmarks' --backend option: every run of a program on the CPU or the CUDA backend.
#include <map>
#include <string>

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

}  // namespace mpm::bench
