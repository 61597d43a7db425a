#!/usr/bin/env bash
# Sets up, builds (Release) and runs the main demo: a needle and thread close a wound
# between two soft tissue blocks (Bullet + MPM), the scene assets/scenes/suturing.json.
# Frames (PNG, PLY; --no-ply: none), frames.csv, suturing.csv and
# summary.txt go to out/suturing/.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
scripts/setup.sh
[ -d /usr/local/cuda/bin ] && export PATH="/usr/local/cuda/bin:$PATH"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j "$(nproc)" --target demo_suturing
# idle OpenMP threads sleep rather than spin: much faster on a shared machine
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
build/demos/demo_suturing --out out/suturing "$@"
