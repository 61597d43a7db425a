#!/usr/bin/env bash
# Builds bench_throughput in Release and runs it on an idle machine; arguments are passed
# through (see `bench_throughput --help`). Results go to bench/results/throughput.{md,csv}
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
build="${MPM_BENCH_BUILD_DIR:-build}"
jobs="${MPM_BENCH_JOBS:-2}"

cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release
cmake --build "$build" -j"$jobs" --target bench_throughput

source "$repo/bench/idle_check.sh"
wait_for_idle run_throughput.sh

"$build/bench/bench_throughput" "$@"

# the results' path stem, as bench_throughput took it
out="bench/results/throughput"
args=("$@")
for ((i = 0; i < ${#args[@]}; i++)); do
  case "${args[i]}" in
    --out) out="${args[i + 1]:-$out}" ;;
    --out=*) out="${args[i]#--out=}" ;;
  esac
done
venv="$repo/bench/.venv"
if [[ ! -x "$venv/bin/python" ]]; then
  python3 -m venv "$venv" && "$venv/bin/pip" install --quiet matplotlib ||
    { echo "run_throughput.sh: warning: no matplotlib (needs python3-venv and PyPI); no plot" >&2; exit 0; }
fi
"$venv/bin/python" bench/plot_throughput.py "$out.csv" "$out.png"
echo "run_throughput.sh: wrote $out.png" >&2
