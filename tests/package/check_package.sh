#!/usr/bin/env bash
# The installable package: installs BUILD_DIR into a scratch prefix, then configures,
# builds and runs tests/package/consumer against it with find_package(mpm_bullet). Then
# configures the same consumer with add_subdirectory of the source tree (configure and
# generate only: the library itself is what the first part built).
# Usage: check_package.sh SOURCE_DIR BUILD_DIR WORK_DIR
set -euo pipefail
src="$1" build="$2" work="$3"
rm -rf "$work"
mkdir -p "$work"
cmake --install "$build" --prefix "$work/prefix" > "$work/install.log"
test -f "$work/prefix/share/doc/mpm_bullet/LICENSE"

echo "== find_package(mpm_bullet) from $work/prefix"
cmake -S "$src/tests/package/consumer" -B "$work/installed" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_PREFIX_PATH="$work/prefix"
cmake --build "$work/installed" -j 2
"$work/installed/consumer"

if [ -x "$build/demos/mpm_run" ]; then  # built with MPM_BUILD_DEMOS
  echo "== installed bin/mpm_run"
  test -x "$work/prefix/bin/mpm_run"
  "$work/prefix/bin/mpm_run" --help > "$work/mpm_run_help.txt"
  grep -q -- "--frames" "$work/mpm_run_help.txt"
  "$work/prefix/bin/mpm_run" "$src/assets/scenes/coupling.json" --frames 1 --threads 2 --out "$work/mpm_run_out"
  test -f "$work/mpm_run_out/frame_0000.png" && test -s "$work/mpm_run_out/frames.csv"
fi

echo "== C-only project (LANGUAGES C) from $work/prefix"
cmake -S "$src/tests/package/c_consumer" -B "$work/c_installed" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_PREFIX_PATH="$work/prefix"
cmake --build "$work/c_installed" -j 2
"$work/c_installed/c_consumer"

echo "== add_subdirectory($src)"
cmake -S "$src/tests/package/consumer" -B "$work/subdirectory" -DCMAKE_BUILD_TYPE=Release \
      -DMPM_BULLET_SOURCE_DIR="$src" -DMPM_WITH_CUDA=OFF > "$work/subdirectory.log"
# only the library's targets are there: no tests, demos or benchmarks of ours
if grep -q "test_suturing\|demo_suturing\|bench_throughput" "$work/subdirectory/Makefile"; then
  echo "check_package: add_subdirectory built our tests, demos or benchmarks" >&2
  exit 1
fi
echo "check_package: both ways work"
