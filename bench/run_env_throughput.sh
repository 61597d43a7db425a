#!/usr/bin/env bash
# Environment steps per second of mpm_bullet.envs (bench/env_throughput.py) into this
# machine's results folder, env_throughput.md. Needs the Python module built in build/ and
# the test environment build/pyvenv (scripts/test.sh makes both).
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
source bench/run_common.sh
source bench/idle_check.sh
wait_for_idle run_env_throughput.sh
out="$(results_dir)"
mkdir -p "$out"
model=$(grep -m1 '^model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')
PYTHONPATH="$repo/build/python" build/pyvenv/bin/python bench/env_throughput.py --out "$out/env_throughput.md" \
  --idle "${BENCH_IDLE:-}"
sed -i "s|^Machine: [^,]*,|Machine: ${model},|" "$out/env_throughput.md"
echo "run_env_throughput.sh: wrote $out/env_throughput.md"
