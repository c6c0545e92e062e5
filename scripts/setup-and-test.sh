#!/usr/bin/env bash
# Fresh Debian 12 machine: installs everything, builds, and runs every test (ctest), then the
# core's sanitizer tests and reproducible fuzzing (scripts/fuzz.sh).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$root/scripts/install-deps.sh"
bash "$root/scripts/build.sh"
ctest --test-dir "${SPACETREEMESH_BUILD_DIR:-$root/build}" --output-on-failure -j 2 --timeout 900
# The core under AddressSanitizer and UndefinedBehaviorSanitizer (clang): its unit tests, the
# fuzz corpus, and 200 reproducible fuzz inputs (docs/reliability.md).
bash "$root/scripts/fuzz.sh"
