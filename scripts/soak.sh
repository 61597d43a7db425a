#!/usr/bin/env bash
# Soak: builds bench_soak (Release, in build/ unless MPM_SOAK_BUILD_DIR says otherwise) if
# needed and runs random valid scenes, each in a forked child, for a wall time; prints the
# per-scene outcomes and a summary table. Not run in CI. Exits non-zero if any scene
# crashed, hung or collapsed silently (bench/soak.cpp).
#
#   scripts/soak.sh [MINUTES [THREADS [SEED]]] [bench_soak options...]
#   scripts/soak.sh                   # 30 minutes, cpuThreads 1..2, a seed from the clock
#   scripts/soak.sh 2 2 7 --out /tmp/soak.md   # default: bench/results/<machine>/soak.md
#                                                (bench/machine.sh)
#   scripts/soak.sh 1 2 7 --scene 0x1f2e3d4c5b6a7980 --verbose   # one printed scene again
#
# Environment: MPM_SOAK_BUILD_DIR (default build), MPM_SOAK_JOBS (build jobs, default nproc).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
minutes="${1:-30}" threads="${2:-2}" seed="${3:-0}"
shift $(( $# < 3 ? $# : 3 ))
scripts/setup.sh
[ -d /usr/local/cuda/bin ] && export PATH="/usr/local/cuda/bin:$PATH"
build="${MPM_SOAK_BUILD_DIR:-build}"
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DMPM_BUILD_BENCH=ON > /dev/null
cmake --build "$build" -j "${MPM_SOAK_JOBS:-$(nproc)}" --target bench_soak
out=()
[[ " $* " == *" --out "* || " $* " == *" --out="* ]] || out=(--out "bench/results/$(bench/machine.sh)/soak.md")
mkdir -p "bench/results/$(bench/machine.sh)"
exec "$build/bench/bench_soak" --minutes "$minutes" --threads "$threads" --seed "$seed" "${out[@]}" "$@"
