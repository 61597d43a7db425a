#!/usr/bin/env bash
# Prints the name of this machine's results folder, bench/results/<name>/: $MPM_MACHINE when
# set, else the CPU's family and hardware thread count (xeon-2core, epyc-2core) or, with
# --gpu, the first NVIDIA GPU's model (h100, h200). The one place this name is made: the run
# scripts and the benchmarks' default --out (bench_report.h) both ask it.
set -euo pipefail
if [[ -n "${MPM_MACHINE:-}" ]]; then
  echo "$MPM_MACHINE"
elif [[ "${1:-}" == --gpu ]]; then
  # "NVIDIA H100 80GB HBM3" -> h100
  name=$(nvidia-smi --query-gpu=name --format=csv,noheader 2> /dev/null | head -1 || true)
  word=$(sed -E 's/^NVIDIA //; s/^(GeForce|Tesla|Quadro) //' <<< "$name" | awk '{print tolower($1)}')
  echo "${word:-gpu}"
else
  # "Intel(R) Xeon(R) Processor @ 2.50GHz" -> xeon, "AMD EPYC 9B14" -> epyc
  model=$(grep -m1 '^model name' /proc/cpuinfo 2> /dev/null | cut -d: -f2 || true)
  word=$(sed -E 's/\((R|TM|r|tm)\)//g; s/\b(Intel|AMD|Processor|CPU)\b//g' <<< "$model" | awk '{print tolower($1)}')
  echo "${word:-cpu}-$(nproc)core"
fi
