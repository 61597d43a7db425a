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
#   MPM_BENCH_IDLE_MIN    idle CPU percentage wanted before timing (default: 85)
#   MPM_BENCH_IDLE_TRIES  idle checks before running anyway (default: 5)
#   MPM_BENCH_IDLE_WAIT   seconds between idle checks (default: 30)
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
build="${MPM_BENCH_BUILD_DIR:-build}"
jobs="${MPM_BENCH_JOBS:-2}"
idle_min="${MPM_BENCH_IDLE_MIN:-85}"
idle_tries="${MPM_BENCH_IDLE_TRIES:-5}"
idle_wait="${MPM_BENCH_IDLE_WAIT:-30}"

cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release
cmake --build "$build" -j"$jobs" --target bench_throughput

# Idle percentage of the second top sample (the first one covers the time since boot).
idle_percent() {
  LC_ALL=C top -bn2 -d1 | awk '/^%Cpu/ { n++; if (n == 2) { for (i = 2; i <= NF; i++)
    if ($i ~ /^id/) { v = $(i - 1); sub(/,$/, "", v); print v; exit } } }'
}

if ! command -v top >/dev/null 2>&1; then
  echo "run_throughput.sh: warning: top not found; cannot check that the CPU is idle" >&2
else
  for ((try = 1; ; try++)); do
    idle="$(idle_percent || true)"
    if [[ -z "$idle" ]]; then
      echo "run_throughput.sh: warning: could not read the idle share from top" >&2
      break
    fi
    if awk -v i="$idle" -v m="$idle_min" 'BEGIN { exit !(i >= m) }'; then
      echo "run_throughput.sh: CPU ${idle}% idle" >&2
      break
    fi
    if ((try >= idle_tries)); then
      echo "run_throughput.sh: warning: CPU only ${idle}% idle after ${try} checks;" \
           "running anyway, the times will be inflated" >&2
      break
    fi
    echo "run_throughput.sh: warning: CPU only ${idle}% idle (want >= ${idle_min}%);" \
         "check ${try}/${idle_tries}, waiting ${idle_wait} s" >&2
    ps -eo pcpu,pid,comm --sort=-pcpu | head -4 >&2
    sleep "$idle_wait"
  done
fi

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
