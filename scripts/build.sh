#!/usr/bin/env bash
# Configures and builds SpacetreeMesh in ./build (Release, Ninja). Extra arguments go to cmake.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${SPACETREEMESH_BUILD_DIR:-$root/build}"
# Debian's python3 sees ParaView's vtkmodules; a pyenv or venv python3 on PATH would not.
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DPython3_EXECUTABLE=/usr/bin/python3 "$@"
cmake --build "$build" -j "$(nproc)"
