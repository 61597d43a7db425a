#!/usr/bin/env bash
# Installs every build and test dependency from Debian's packages (Debian 12, as root or
# with sudo). Idempotent: returns at once when everything is present.
set -euo pipefail

packages=(
  build-essential cmake pkg-config   # compiler and build
  libeigen3-dev                      # host linear algebra (tests, later MTLED and SDFs)
  libbullet-dev libbullet-extras-dev # rigid bodies the tissue couples to (bullet_bridge)
  libassimp-dev                      # mesh import (OBJ, STL, PLY, glTF)
  libgtest-dev googletest            # tests
  libpng-dev                         # PNG snapshots
  zlib1g-dev                         # CRC-32 of checkpoints
  libcli11-dev                       # command-line parsing in demos and benchmarks
  nlohmann-json3-dev                 # scene and result files
  pybind11-dev                       # the Python module mpm_bullet (python/; pip install .)
  python3-dev python3-venv           # its headers, and the virtual environments of pip install . and test.sh
  python3-jsonschema                 # the scene files' schema test (tests/scene_files)
  clang                              # libFuzzer for the loaders' fuzz targets (scripts/fuzz.sh)
  doxygen                            # the API reference (cmake --build build --target docs)
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# The CUDA backend is built when nvcc is found; it is optional.
if command -v nvcc >/dev/null 2>&1 || [ -x /usr/local/cuda/bin/nvcc ]; then
  echo "setup: CUDA toolkit found; the CUDA backend will be built"
else
  echo "setup: no CUDA toolkit (nvcc); building the CPU backend only" \
       "(Debian: nvidia-cuda-toolkit from non-free, or NVIDIA's own packages)"
fi
echo "setup: all dependencies present"
