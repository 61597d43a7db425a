#!/usr/bin/env bash
# Fuzzes the loaders with libFuzzer (clang, from Debian's clang package): builds the fuzz
# targets with ASan + UBSan in build-fuzz/ and runs each for its own number of inputs (the
# table below: about 35 s each here; MPM_FUZZ_RUNS overrides it for all) and at most
# MPM_FUZZ_SECONDS (default 90) from seed MPM_FUZZ_SEED (default 1), so a CI run is
# reproducible (set another seed, or MPM_FUZZ_RUNS=-1 and a longer MPM_FUZZ_SECONDS, to
# explore), on a copy of its committed seed corpus (tests/fuzz/corpus/CORPUS: small inputs,
# and each input that once found a bug). A crash, a sanitizer report, a timeout or running
# out of memory fails the script; the input that did it is left in build-fuzz/ (NAME-crash-*,
# -timeout-*, -oom-*) to reproduce: build-fuzz/tests/fuzz/NAME FILE. MPM_FUZZ_TARGETS="a b"
# runs only those targets.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
seconds="${MPM_FUZZ_SECONDS:-90}" seed="${MPM_FUZZ_SEED:-1}"

# Every target: its name (tests/fuzz/NAME.cpp, built by mpm_fuzz_target in
# tests/fuzz/CMakeLists.txt), its corpus folder and its inputs in CI (chosen from its rate
# here so that each takes at most about 90 s: docs/testing.md's Fuzzing table). A new loader's
# target is one more line.
table=(
  "fuzz_checkpoint  checkpoint 300000"
  "fuzz_mesh_import mesh       40000"
  "fuzz_scene_file  scene_file 100000"
)
declare -A corpus_of runs_of
targets=()
for row in "${table[@]}"; do
  read -r t c r <<< "$row"
  if [[ -n "${MPM_FUZZ_TARGETS:-}" && " $MPM_FUZZ_TARGETS " != *" $t "* ]]; then continue; fi
  targets+=("$t") corpus_of[$t]=$c runs_of[$t]="${MPM_FUZZ_RUNS:-$r}"
done
(( ${#targets[@]} )) || { echo "fuzz: no target matches MPM_FUZZ_TARGETS='${MPM_FUZZ_TARGETS:-}'"; exit 1; }

start=$(date +%s)
mkdir -p build-fuzz
cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
      -DMPM_BUILD_FUZZERS=ON -DMPM_BUILD_TESTS=OFF -DMPM_BUILD_DEMOS=OFF -DMPM_BUILD_BENCH=OFF \
      -DMPM_WITH_CUDA=OFF -DMPM_WITH_OPENMP=OFF -DMPM_NATIVE_ARCH=OFF \
      -DMPM_SANITIZE=address,undefined,fuzzer-no-link > build-fuzz/build.log 2>&1 || { cat build-fuzz/build.log; exit 1; }
cmake --build build-fuzz -j "$(nproc)" --target "${targets[@]}" >> build-fuzz/build.log 2>&1 || { tail -50 build-fuzz/build.log; exit 1; }
echo "fuzz: built in $(( $(date +%s) - start )) s"

# third-party leaks only (each entry says why it is not ours)
export LSAN_OPTIONS="suppressions=$root/scripts/sanitizers/lsan.supp:print_suppressions=0"
status=0
for t in "${targets[@]}"; do
  corpus="build-fuzz/corpus-$t"
  rm -rf "$corpus" && cp -r "tests/fuzz/corpus/${corpus_of[$t]}" "$corpus"
  t0=$(date +%s)
  if "build-fuzz/tests/fuzz/$t" "$corpus" -runs="${runs_of[$t]}" -max_total_time="$seconds" -seed="$seed" -timeout=20 -rss_limit_mb=4096 \
       -artifact_prefix="build-fuzz/$t-" -print_final_stats=1 > "build-fuzz/$t.log" 2>&1; then
    echo "fuzz: $t clean (seed $seed): $(grep -o 'stat::number_of_executed_units: *[0-9]*' "build-fuzz/$t.log" | grep -o '[0-9]*$') executions in $(( $(date +%s) - t0 )) s"
  else
    echo "fuzz: $t FAILED (build-fuzz/$t.log):"
    tail -40 "build-fuzz/$t.log"
    status=1
  fi
done
exit $status
