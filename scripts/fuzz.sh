#!/usr/bin/env bash
# Fuzzes the loaders with libFuzzer (clang, from Debian's clang package): builds the fuzz
# targets with ASan + UBSan in build-fuzz/ and runs each for MPM_FUZZ_RUNS inputs (default
# 300000, about 35 s; at most MPM_FUZZ_SECONDS, default 120) from seed MPM_FUZZ_SEED
# (default 1), so a CI run is reproducible (set another seed, or MPM_FUZZ_RUNS=-1 and a
# longer MPM_FUZZ_SECONDS, to explore), on a copy of its committed seed corpus
# (tests/fuzz/corpus/NAME: small scenes, and each input that once found a bug). A crash, a sanitizer
# report, a timeout or running out of memory fails the script; the input that did it is
# left in build-fuzz/ (crash-*, timeout-*, oom-*) to reproduce: build-fuzz/tests/fuzz/NAME FILE.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
seconds="${MPM_FUZZ_SECONDS:-120}" runs="${MPM_FUZZ_RUNS:-300000}" seed="${MPM_FUZZ_SEED:-1}"
targets=(fuzz_checkpoint)

start=$(date +%s)
mkdir -p build-fuzz
cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
      -DMPM_BUILD_FUZZERS=ON -DMPM_BUILD_TESTS=OFF -DMPM_BUILD_DEMOS=OFF -DMPM_BUILD_BENCH=OFF \
      -DMPM_WITH_CUDA=OFF -DMPM_WITH_OPENMP=OFF -DMPM_NATIVE_ARCH=OFF \
      -DMPM_SANITIZE=address,undefined,fuzzer-no-link > build-fuzz/build.log 2>&1 || { cat build-fuzz/build.log; exit 1; }
cmake --build build-fuzz -j "$(nproc)" --target "${targets[@]}" >> build-fuzz/build.log 2>&1 || { tail -50 build-fuzz/build.log; exit 1; }
echo "fuzz: built in $(( $(date +%s) - start )) s"

status=0
for t in "${targets[@]}"; do
  corpus="build-fuzz/corpus-$t"
  rm -rf "$corpus" && cp -r "tests/fuzz/corpus/${t#fuzz_}" "$corpus"
  if "build-fuzz/tests/fuzz/$t" "$corpus" -runs="$runs" -max_total_time="$seconds" -seed="$seed" -timeout=20 -rss_limit_mb=4096 \
       -artifact_prefix="build-fuzz/$t-" -print_final_stats=1 > "build-fuzz/$t.log" 2>&1; then
    echo "fuzz: $t clean (seed $seed): $(grep -o 'stat::number_of_executed_units: *[0-9]*' "build-fuzz/$t.log" | grep -o '[0-9]*$') executions"
  else
    echo "fuzz: $t FAILED (build-fuzz/$t.log):"
    tail -40 "build-fuzz/$t.log"
    status=1
  fi
done
exit $status
