#!/usr/bin/env bash
# Sets up, checks the text (scripts/check_history_words.sh), builds (Release, tests on)
# and runs every test with CTest.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
scripts/setup.sh
scripts/check_history_words.sh
[ -d /usr/local/cuda/bin ] && export PATH="/usr/local/cuda/bin:$PATH"
jobs="$(nproc)"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release -DMPM_BUILD_TESTS=ON
cmake --build build -j "$jobs"
# The API reference (docs/Doxyfile.in): the target exists only where CMake found Doxygen
command -v doxygen > /dev/null ||
  { echo "test.sh: ERROR: doxygen not found (scripts/setup.sh installs it); no API reference" >&2; exit 1; }
cmake --build build --target docs
ctest --test-dir build --output-on-failure -j "$jobs" "$@"

# The Python module (tests/python, pytest): built above when CMake found pybind11 and the
# python3 headers (MPM_BUILD_PYTHON); run in a virtual environment kept in the build tree,
# made with the interpreter the module was built for, numpy, pytest and pybullet from PyPI, and
# for the learning environments (mpm_bullet.envs) gymnasium, Ray RLlib and the torch its env
# runners' module needs (about 6 GB; none of them is a dependency of the library).
if grep -q '^MPM_BUILD_PYTHON:BOOL=ON' build/CMakeCache.txt; then
  python="$(sed -n 's/^_Python_EXECUTABLE:INTERNAL=//p' build/CMakeCache.txt)"
  venv=build/pyvenv
  [ -x "$venv/bin/python" ] || "$python" -m venv "$venv"
  "$venv/bin/python" -c 'import numpy, pytest, pybullet, gymnasium, ray.rllib, torch' 2>/dev/null ||
    "$venv/bin/pip" install -q --disable-pip-version-check numpy pytest pybullet gymnasium "ray[rllib]" torch
  PYTHONPATH="$root/build/python" "$venv/bin/python" -m pytest -q -p no:cacheprovider tests/python
else
  echo "test.sh: Python module not built (MPM_BUILD_PYTHON off: pybind11-dev or the python3 headers missing)"
fi
