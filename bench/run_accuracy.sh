#!/usr/bin/env bash
# Builds bench_accuracy in Release, runs it (arguments are passed through; see
# `bench_accuracy --help`) and plots error against CPU time to <out>.png (matplotlib from
# PyPI in bench/.venv, made on first use; plotting only). Results go to
# bench/results/<machine>/accuracy.{md,csv,png} and accuracy_curves.csv unless --out says otherwise.
#
#   bench/run_accuracy.sh                   # the full study (about an hour on 2 busy cores)
#   bench/run_accuracy.sh --quick           # 1 cm only, every solver and case (~3 min)
#   bench/run_accuracy.sh --solvers Mtled,MlsMpm --cases compression-bonded
#
# Environment:
#   MPM_BENCH_BUILD_DIR   build directory (default: build)
#   MPM_BENCH_JOBS        parallel build jobs (default: 2)
# The wall times are the machine's as it was: no idle check (bench/idle_check.sh) here;
# the report's header records the load average before and after.
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
source "$repo/bench/run_common.sh"
build_bench bench_accuracy

"$build/bench/bench_accuracy" "$@"

plot_results run_accuracy.sh "$(results_dir)/accuracy" bench/plot_accuracy.py "$@"
