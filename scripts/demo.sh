#!/usr/bin/env bash
# Sets up, builds (Release) and runs the main demo: an elastic block dropped onto the
# ground. Frames (PLY) and pictures (PNG) go to out/block_drop/.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
scripts/setup.sh
[ -d /usr/local/cuda/bin ] && export PATH="/usr/local/cuda/bin:$PATH"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j "$(nproc)" --target demo_block_drop
# idle OpenMP threads sleep rather than spin: much faster on a shared machine
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
build/demos/demo_block_drop --out out/block_drop "$@"
