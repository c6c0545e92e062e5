#!/usr/bin/env bash
# Fresh Debian 12 machine: installs everything, builds, and meshes the default input (the AAL
# brain atlas of Debian's mricron-data) into ./aal.vtu with a timing summary.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$root/scripts/install-deps.sh"
bash "$root/scripts/build.sh"
"${SPACETREEMESH_BUILD_DIR:-$root/build}/bin/stmesh" -o "$root/aal.vtu" --summary "$root/aal-summary.json"
