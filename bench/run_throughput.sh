#!/usr/bin/env bash
# Builds bench_throughput in Release and runs it on an idle machine; arguments are passed
# through (see `bench_throughput --help`). Results go to bench/results/<machine>/throughput.{md,csv}
# (bench/machine.sh)
# unless --out says otherwise, and the plot of time per frame against particle count to
# <out>.png (matplotlib from PyPI in bench/.venv, made on first use; plotting only).
#
#   bench/run_throughput.sh                       # the full table (tens of minutes on 2 cores)
#   bench/run_throughput.sh --sizes 1,2.5 --frames 20
#
# Environment:
#   MPM_BENCH_BUILD_DIR   build directory (default: build)
#   MPM_BENCH_JOBS        parallel build jobs (default: 2)
#   MPM_BENCH_IDLE_MIN, MPM_BENCH_IDLE_TRIES, MPM_BENCH_IDLE_WAIT: the idle check
#     (bench/idle_check.sh)
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
source "$repo/bench/run_common.sh"
build_bench bench_throughput

source "$repo/bench/idle_check.sh"
wait_for_idle run_throughput.sh

"$build/bench/bench_throughput" "$@"

plot_results run_throughput.sh "$(results_dir)/throughput" bench/plot_throughput.py "$@"
