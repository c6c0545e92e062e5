#!/usr/bin/env bash
# The VTK-free core built with clang, AddressSanitizer and UndefinedBehaviorSanitizer in
# ./build-fuzz (no ParaView needed): runs the core unit tests and the seed corpus, then fuzzes
# FuzzCorePipeline with libFuzzer for FUZZ_SECONDS (default 120) from a copy of the seed corpus.
# New inputs stay in build-fuzz/corpus; a failing input is written to build-fuzz/crash-* and
# fails the script. docs/reliability.md records longer runs.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${SPACETREEMESH_FUZZ_BUILD_DIR:-$root/build-fuzz}"
seconds="${FUZZ_SECONDS:-120}"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DSPACETREEMESH_CORE_ONLY=ON -DSPACETREEMESH_FUZZ=ON "-DSPACETREEMESH_SANITIZE=address;undefined"
cmake --build "$build" -j "$(nproc)"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
ctest --test-dir "$build" --output-on-failure -j "$(nproc)" --timeout 900
mkdir -p "$build/corpus"
cp -n "$root/Testing/Fuzz/corpus/core/"* "$build/corpus/" 2>/dev/null || true
# Fork mode, a child per core, stops at the first failure; -timeout: one input may take at most
# 20 s (a hang fails).
cd "$build"
"$build/bin/FuzzCorePipeline" -fork="$(nproc)" -max_total_time="$seconds" -timeout=20 \
  -rss_limit_mb=4096 -max_len=512 -print_final_stats=1 corpus > fuzz.log 2>&1 || {
  tail -n 60 fuzz.log
  echo "fuzz: FuzzCorePipeline failed (the input: crash-*, timeout-* or oom-* in $build)"
  exit 1
}
grep -E "^#[0-9]+: cov|DONE|INFO: fuzzed" fuzz.log | tail -n 3
echo "fuzz: FuzzCorePipeline ran ${seconds} s on $(nproc) jobs without a failure"
