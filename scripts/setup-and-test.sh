#!/usr/bin/env bash
# Fresh Debian 12 machine: installs everything, builds, and runs every test (ctest).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$root/scripts/install-deps.sh"
bash "$root/scripts/build.sh"
ctest --test-dir "${SPACETREEMESH_BUILD_DIR:-$root/build}" --output-on-failure -j 2 --timeout 900
