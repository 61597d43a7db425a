# Sourced by the bench run scripts (after `cd "$repo"`).
#
# build_bench TARGET: configures and builds TARGET in Release into $build
#   (MPM_BENCH_BUILD_DIR, default build) with MPM_BENCH_JOBS jobs (default 2).
# results_dir [--gpu]: this machine's results folder, bench/results/<machine> (bench/machine.sh).
# plot_results NAME DEFAULT_OUT PLOT_SCRIPT ARGS...: finds the results' path stem as the
#   benchmark took it (--out), makes the plotting environment bench/.venv (matplotlib from
#   PyPI, first use only; plotting is never a dependency of the library) and writes
#   <out>.png from <out>.csv.
build="${MPM_BENCH_BUILD_DIR:-build}"

results_dir() {
  echo "bench/results/$("$repo/bench/machine.sh" "$@")"
}

build_bench() {
  cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release
  cmake --build "$build" -j"${MPM_BENCH_JOBS:-2}" --target "$1"
}

plot_results() {
  local name="$1" out="$2" script="$3"
  shift 3
  local args=("$@") i
  for ((i = 0; i < ${#args[@]}; i++)); do
    case "${args[i]}" in
      --out) out="${args[i + 1]:-$out}" ;;
      --out=*) out="${args[i]#--out=}" ;;
    esac
  done
  local venv="$repo/bench/.venv"
  if [[ ! -x "$venv/bin/python" ]] || ! "$venv/bin/python" -c "import matplotlib" 2>/dev/null; then
    python3 -m venv "$venv" && "$venv/bin/pip" install --quiet matplotlib ||
      { echo "$name: warning: no matplotlib (needs python3-venv and PyPI); no plot" >&2; return 0; }
  fi
  "$venv/bin/python" "$script" "$out.csv" "$out.png"
  echo "$name: wrote $out.png" >&2
}
