#!/usr/bin/env bash
# The GPU checks as one prepared run, for a machine with an NVIDIA GPU but none of the
# library's build dependencies: the executables are built elsewhere (sm_90 for Hopper:
# `cmake -DMPM_WITH_CUDA=ON -DCMAKE_CUDA_ARCHITECTURES=90 -DMPM_NATIVE_ARCH=OFF`) and
# handed over as a tarball with the shared libraries they need beside them.
#
#   bench/run_gpu.sh --pack BUILD_DIR BINARIES.tar.xz [BASE_BUILD_DIR]   # here
#   bench/run_gpu.sh BINARIES.tar.xz [OUTDIR [TAICHI_SITE.tar.xz]]       # there
#
# OUTDIR (or "-") defaults to bench/results/<gpu>/gpu_run, the GPU named by bench/machine.sh.
#
# --pack takes BUILD_DIR's bench_throughput and the test binaries with CUDA cases, and the
# shared libraries they need that a bare CUDA image lacks (Bullet, assimp, libpng: what
# ldd finds under /usr/lib but not libc, libstdc++ or libgomp), and with BASE_BUILD_DIR that
# build's bench_throughput as bench_throughput.base (an A/B in one run).
#
# Steps, each written to OUTDIR and packed there into run.tgz at the end (a failing step is
# reported and the next one runs):
#   1. the device (nvidia-smi) and the GPU test cases (every test binary in the tarball,
#      its CUDA cases only: gtest filter *Cuda*);
#   2. bench_throughput --backend cuda: MLS-MPM, standard MPM and PB-MPM (20 iterations) at
#      8k, 125k and 1M particles (the CRESSim scene), medians of 3 runs;
#   3. each kernel's device time over one MLS-MPM frame at 1M particles (ncu, clocks left as
#      they are), summed by kernel: where a substep's time goes (with MPM_GPU_NCU_DETAIL=REGEX
#      also ncu's sections for two launches of the kernels matching it);
#   4. bench_batch_throughput --backend cuda: 16 copies of the embedding scene against one;
#   5. the peer: the same scene and substep in Taichi on its CUDA backend
#      (bench/peers/taichi_cressim.py --arch cuda), when a Taichi site-packages tarball is
#      given (Taichi's wheel unpacked; nothing can be installed on the device machine).
# Binaries named with a suffix (bench_throughput.base) are timed too, alternating with the
# plain ones, so that an A/B of two builds shares one run.
set -uo pipefail
if [[ "${1:-}" == "--pack" ]]; then
  set -e
  build="$2" tarball="$3" base="${4:-}"
  stage=$(mktemp -d)
  mkdir -p "$stage/lib"
  cp "$build/bench/bench_throughput" "$stage/"
  [[ -x "$build/bench/bench_batch_throughput" ]] && cp "$build/bench/bench_batch_throughput" "$stage/"
  [[ -n "$base" ]] && cp "$base/bench/bench_throughput" "$stage/bench_throughput.base"
  for t in test_backend test_shapes test_contact test_hertz test_checkpoint; do
    [[ -x "$build/tests/$t" ]] && cp "$build/tests/$t" "$stage/"
  done
  for f in "$stage"/bench_* "$stage"/test_*; do
    ldd "$f" | awk '/=> \//{print $3}'
  done | sort -u | grep -Ev '/(libc|libm|libstdc\+\+|libgcc_s|libgomp|libpthread|libdl|librt|libz)\.so' |
    while read -r lib; do cp -L "$lib" "$stage/lib/"; done
  strip "$stage"/bench_* "$stage"/test_* 2> /dev/null || true
  tar -cf - -C "$stage" . | xz -T2 -6 > "$tarball"
  rm -rf "$stage"
  ls -la "$tarball"
  exit 0
fi
tarball="$1"
taichi="${3:-}"
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
out="${2:--}"
[[ "$out" == - ]] && out="$repo/bench/results/$("$repo/bench/machine.sh" --gpu)/gpu_run"
mkdir -p "$out" /tmp/mpm_gpu
tar -xJf "$tarball" -C /tmp/mpm_gpu
bin=/tmp/mpm_gpu
export LD_LIBRARY_PATH="$bin/lib:${LD_LIBRARY_PATH:-}"
cd "$repo"

step() { echo; echo "=== $* ($(date -u +%H:%M:%S))"; }

step device
nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.sm,clocks.max.sm --format=csv | tee "$out/device.txt"

step "GPU tests"
: > "$out/tests.txt"
for t in "$bin"/test_*; do
  [[ -x "$t" ]] || continue
  timeout 300 "$t" --gtest_filter='*Cuda*:*cuda*:*Gpu*' --gtest_brief=1 >> "$out/tests.txt" 2>&1
  echo "$(basename "$t"): rc $?" | tee -a "$out/tests.txt"
done
grep -E "FAILED|PASSED|SKIPPED" "$out/tests.txt" | sort | uniq -c | sort -rn | head -40

step "throughput"
for b in "$bin"/bench_throughput*; do
  name=$(basename "$b")
  timeout 600 "$b" --backend cuda --solvers mls,standard,pb20 --sizes 1,2.5,5 --threads 1 --repeats 3 \
    --bandwidth-mib 0 --max-other-load 4 --retries 0 --out "$out/${name}_cuda" > "$out/${name}.log" 2>&1
  echo "$name: rc $?"
  grep -E "^\| (MLS|standard|PB)" "$out/${name}_cuda.md" | cut -d'|' -f2,5,8,9,10
done

step "kernel times, MLS-MPM 1M, one frame"
if command -v ncu > /dev/null; then
  timeout 300 ncu --clock-control none --metrics gpu__time_duration.sum --csv --print-units base \
    "$bin/bench_throughput" --backend cuda --solvers mls --sizes 5 --threads 1 --repeats 1 --frames-large 1 \
    --bandwidth-mib 0 --max-other-load 16 --retries 0 --out /tmp/mpm_gpu/ncu_run > "$out/ncu.csv" 2> "$out/ncu.err"
  echo "ncu: rc $?"
  python3 bench/peers/kernel_times.py "$out/ncu.csv" --frames 3 | tee "$out/kernel_times.md"
else
  echo "no ncu"
fi

if [[ -x "$bin/bench_batch_throughput" ]]; then
  step "batch: 16 copies of the embedding scene against one, CUDA"
  timeout 300 "$bin/bench_batch_throughput" --backend cuda --threads 1,16 --out "$out/batch_cuda" > "$out/batch.log" 2>&1
  echo "batch: rc $?"
  grep -E "^\| [0-9]" "$out/batch_cuda.md"
fi

if [[ -n "${MPM_GPU_NCU_DETAIL:-}" ]] && command -v ncu > /dev/null; then
  step "ncu detail: kernels matching $MPM_GPU_NCU_DETAIL, one launch each, MLS-MPM 1M"
  timeout 300 ncu --clock-control none -k "regex:$MPM_GPU_NCU_DETAIL" --launch-skip 12 --launch-count 2 \
    --section SpeedOfLight --section WarpStateStats --section MemoryWorkloadAnalysis --section Occupancy \
    --section LaunchStats --section ComputeWorkloadAnalysis \
    "$bin/bench_throughput" --backend cuda --solvers mls --sizes 5 --threads 1 --repeats 1 --frames-large 1 \
    --bandwidth-mib 0 --max-other-load 16 --retries 0 --out /tmp/mpm_gpu/ncu_detail > "$out/ncu_detail.txt" 2>&1
  echo "ncu detail: rc $?"
  grep -E "^  [a-z_:]+.*\(|Duration|Throughput|Stall|Warp Cycles|Achieved Occupancy|Registers|Local" "$out/ncu_detail.txt" | head -60
fi

if [[ -n "$taichi" ]]; then
  step "Taichi CUDA peer"
  mkdir -p /tmp/ti_site && tar -xJf "$taichi" -C /tmp/ti_site
  for hs in 1 2.5 5; do
    PYTHONPATH=/tmp/ti_site TI_LOG_LEVEL=warn timeout 300 python3 bench/peers/taichi_cressim.py --arch cuda \
      --half-size "$hs" --frames 50 --warmup 2 2>> "$out/taichi.err" | tee -a "$out/taichi.jsonl"
  done
fi
step done
# everything in one archive (the device tool brings back at most 8 files)
tar -czf /tmp/mpm_gpu/run.tgz -C "$out" . && find "$out" -mindepth 1 -delete && mv /tmp/mpm_gpu/run.tgz "$out/"
