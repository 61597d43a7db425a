#!/usr/bin/env bash
# Our MLS-MPM against the Taichi peer (bench/peers/taichi_cressim.py) on the CRESSim scene,
# CPU, in one invocation: builds bench_throughput (Release), makes the Taichi virtual
# environment bench/peers/.venv (taichi and numpy from PyPI, first use only), waits for an
# idle CPU (bench/idle_check.sh), measures the memory bandwidth, checks that both run the
# same physics (centre of mass over 250 frames at 8k particles), then times ours and Taichi
# alternately, one process per run, `--repeats` times per particle count and thread count,
# and writes bench/results/<machine>/peers.{md,csv} with the medians and the ratio per row.
#
#   bench/run_peers.sh                                   # 8k, 125k, 1M x 1, 2 threads x 3 runs:
#                                                        # about 20-25 min on 2 idle cores
#   bench/run_peers.sh --sizes 1 --threads 2 --repeats 1 # a quick look
#
# Options: --sizes (box half-sizes, default 1,2.5,5), --threads (default 1,2), --repeats
# (default 3), --grid (Taichi grid: dense, pointer or bitmasked; default dense), --out
# (path stem, default bench/results/<machine>/peers, bench/machine.sh), --no-physics (skip the physics check).
# Frames per run: 2.5e6 / particles, clamped to [5, 50] (50 at 8k, 20 at 125k, 5 at 1M),
# the same for both, after untimed warm-up frames (ours 2; Taichi 1, which holds its JIT
# compilation: only the first substep compiles).
#
# Environment: MPM_BENCH_BUILD_DIR (default build), MPM_BENCH_JOBS (default 2) and the idle
# check's MPM_BENCH_IDLE_MIN / _TRIES / _WAIT (bench/idle_check.sh).
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"
build="${MPM_BENCH_BUILD_DIR:-build}"
jobs="${MPM_BENCH_JOBS:-2}"
sizes="1,2.5,5"
threads="1,2"
repeats=3
grid=dense
out="bench/results/$(bench/machine.sh)/peers"
physics=1
while (($#)); do
  case "$1" in
    --sizes) sizes="$2"; shift 2 ;;
    --threads) threads="$2"; shift 2 ;;
    --repeats) repeats="$2"; shift 2 ;;
    --grid) grid="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --no-physics) physics=0; shift ;;
    -h|--help) sed -n '2,21p' "$0"; exit 0 ;;
    *) echo "run_peers.sh: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
done
IFS=, read -ra size_list <<<"$sizes"
IFS=, read -ra thread_list <<<"$threads"

cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j"$jobs" --target bench_throughput
ours="$build/bench/bench_throughput"

venv="$repo/bench/peers/.venv"
if [[ ! -x "$venv/bin/python" ]] || ! "$venv/bin/python" -c "import taichi" 2>/dev/null; then
  echo "run_peers.sh: installing Taichi into $venv (first use)" >&2
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet "taichi==1.7.4" numpy
fi
py="$venv/bin/python"
peer=(env TI_LOG_LEVEL=warn "$py" bench/peers/taichi_cressim.py --grid "$grid" --warmup 1)

run_dir="$(mktemp -d "${TMPDIR:-/tmp}/run_peers.XXXXXX")"
echo "run_peers.sh: raw results in $run_dir" >&2
start=$(date +%s)

source "$repo/bench/idle_check.sh"
wait_for_idle run_peers.sh
taichi_version="$("$py" -c 'import taichi as ti; print(".".join(map(str, ti.__version__)))' 2>/dev/null | tail -1)"
{
  echo "- Date: $(date '+%Y-%m-%d %H:%M:%S %Z')"
  echo "- CPU: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//') ($(nproc) hardware threads)"
  echo "- Command: \`bench/run_peers.sh --sizes $sizes --threads $threads --repeats $repeats --grid $grid\`"
  echo "- Idle CPU before the runs (top): ${BENCH_IDLE:-?}%; load average (1 min): $(cut -d' ' -f1 /proc/loadavg)"
  echo "- Ours: $(git -C "$repo" log -1 --format='%h' 2>/dev/null); Taichi $taichi_version, grid \`$grid\`"
} >"$run_dir/info.txt"

echo "run_peers.sh: memory bandwidth" >&2
"$ours" --bandwidth-only --threads "$threads" | tee "$run_dir/bandwidth.csv" >&2

frames_for() {  # frames per run for a particle count: 2.5e6 / n in [5, 50]
  awk -v n="$1" 'BEGIN { f = int(2.5e6 / n + 0.5); if (f > 50) f = 50; if (f < 5) f = 5; print f }'
}
particles_for() {  # the library's lattice: (round(2 h / 0.1))^3
  awk -v h="$1" 'BEGIN { n = int(2 * h / 0.1 + 0.5); print n * n * n }'
}

for ((rep = 1; rep <= repeats; rep++)); do
  for h in "${size_list[@]}"; do
    frames="$(frames_for "$(particles_for "$h")")"
    for t in "${thread_list[@]}"; do
      tag="h${h}_t${t}_r${rep}"
      run_ours() {  # a failed run leaves its row out of the table
        "$ours" --solvers mls --sizes "$h" --threads "$t" --repeats 1 --frames "$frames" \
          --frames-large "$frames" --retries 0 --bandwidth-mib 0 --out "$run_dir/ours_$tag" >/dev/null 2>"$run_dir/ours_$tag.log" ||
          echo "run_peers.sh: our run $tag failed: $run_dir/ours_$tag.log" >&2
      }
      run_peer() {
        "${peer[@]}" --half-size "$h" --threads "$t" --frames "$frames" >"$run_dir/taichi_$tag.json" \
          2>"$run_dir/taichi_$tag.log" || echo "run_peers.sh: Taichi run $tag failed: $run_dir/taichi_$tag.log" >&2
      }
      # alternate which goes first, so a drift in load does not favour one
      if ((rep % 2)); then run_ours; run_peer; else run_peer; run_ours; fi
      o="$(awk -F, 'NR == 2 { print $9 }' "$run_dir/ours_$tag.csv" 2>/dev/null || true)"
      p="$("$py" -c 'import json,sys; print(json.loads(open(sys.argv[1]).read().splitlines()[-1])["ms_per_frame"])' \
             "$run_dir/taichi_$tag.json" 2>/dev/null || echo "? (failed: $run_dir/taichi_$tag.log)")"
      printf 'run_peers.sh: run %d/%d, half-size %s, %s thread(s), %s frames: ours %s ms/frame, Taichi %s ms/frame (%ds)\n' \
        "$rep" "$repeats" "$h" "$t" "$frames" "$o" "$p" "$(($(date +%s) - start))" >&2
    done
  done
done

if ((physics)); then
  echo "run_peers.sh: physics check (8k particles, 250 frames, 1 thread each)" >&2
  "$ours" --trajectory "$run_dir/com_ours.csv" --sizes 1 --threads 1 --frames 250 2>/dev/null
  "${peer[@]}" --half-size 1 --threads 1 --frames 250 --trajectory "$run_dir/com_taichi.csv" >/dev/null 2>&1
  "$py" bench/peers/tabulate.py compare "$run_dir/com_ours.csv" "$run_dir/com_taichi.csv" |
    "$py" -c 'import json,sys; d=json.load(sys.stdin); d.update(half_size=1, particles=8000, tolerance_m=1e-4); print(json.dumps(d))' \
      >"$run_dir/physics.json"
fi

mkdir -p "$(dirname "$out")"
"$py" bench/peers/tabulate.py table "$run_dir" "$out"
echo "run_peers.sh: wrote $out.md and $out.csv in $(($(date +%s) - start)) s (raw runs in $run_dir)" >&2
