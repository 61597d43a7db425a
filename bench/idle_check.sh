# Shared by the benchmark scripts (source it): wait until the CPU is idle before timing.
#
#   source bench/idle_check.sh
#   wait_for_idle run_peers.sh     # the name prefixes its messages
#
# Environment:
#   MPM_BENCH_IDLE_MIN    idle CPU percentage wanted before timing (default: 85)
#   MPM_BENCH_IDLE_TRIES  idle checks before running anyway (default: 5)
#   MPM_BENCH_IDLE_WAIT   seconds between idle checks (default: 30)

# Idle percentage of the second top sample (the first one covers the time since boot).
idle_percent() {
  LC_ALL=C top -bn2 -d1 | awk '/^%Cpu/ { n++; if (n == 2) { for (i = 2; i <= NF; i++)
    if ($i ~ /^id/) { v = $(i - 1); sub(/,$/, "", v); print v; exit } } }'
}

# Waits until the CPU is at least MPM_BENCH_IDLE_MIN % idle, checking MPM_BENCH_IDLE_TRIES
# times; then runs anyway with a warning. Sets BENCH_IDLE to the last idle percentage read
# (empty if top could not be read).
wait_for_idle() {
  local who="${1:-benchmark}"
  local idle_min="${MPM_BENCH_IDLE_MIN:-85}"
  local idle_tries="${MPM_BENCH_IDLE_TRIES:-5}"
  local idle_wait="${MPM_BENCH_IDLE_WAIT:-30}"
  local try idle
  BENCH_IDLE=""
  if ! command -v top >/dev/null 2>&1; then
    echo "$who: warning: top not found; cannot check that the CPU is idle" >&2
    return 0
  fi
  for ((try = 1; ; try++)); do
    idle="$(idle_percent || true)"
    BENCH_IDLE="$idle"
    if [[ -z "$idle" ]]; then
      echo "$who: warning: could not read the idle share from top" >&2
      return 0
    fi
    if awk -v i="$idle" -v m="$idle_min" 'BEGIN { exit !(i >= m) }'; then
      echo "$who: CPU ${idle}% idle" >&2
      return 0
    fi
    if ((try >= idle_tries)); then
      echo "$who: warning: CPU only ${idle}% idle after ${try} checks;" \
           "running anyway, the times will be inflated" >&2
      return 0
    fi
    echo "$who: warning: CPU only ${idle}% idle (want >= ${idle_min}%);" \
         "check ${try}/${idle_tries}, waiting ${idle_wait} s" >&2
    ps -eo pcpu,pid,comm --sort=-pcpu | head -4 >&2
    sleep "$idle_wait"
  done
}
