#!/usr/bin/env bash
# The VTK-free core built with clang, AddressSanitizer and UndefinedBehaviorSanitizer in
# ./build-fuzz (no ParaView needed): runs the core unit tests and the seed corpus, then fuzzes
# FuzzCorePipeline with libFuzzer from a copy of the seed corpus. By default (CI) the fuzzing is
# reproducible: one process, seed 1, FUZZ_RUNS (default 200) inputs. With FUZZ_SECONDS set it
# runs that long with a process per core (development). New inputs stay in build-fuzz/corpus; a
# failing input is written to build-fuzz/crash-* and fails the script. docs/reliability.md
# records the runs.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${SPACETREEMESH_FUZZ_BUILD_DIR:-$root/build-fuzz}"
seconds="${FUZZ_SECONDS:-}"
runs="${FUZZ_RUNS:-200}"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DSPACETREEMESH_CORE_ONLY=ON -DSPACETREEMESH_FUZZ=ON "-DSPACETREEMESH_SANITIZE=address;undefined"
cmake --build "$build" -j "$(nproc)"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
ctest --test-dir "$build" --output-on-failure -j "$(nproc)" --timeout 900
mkdir -p "$build/corpus"
cp -n "$root/Testing/Fuzz/corpus/core/"* "$build/corpus/" 2>/dev/null || true
cd "$build"
if [ -n "$seconds" ]; then
  # A child per core, stopping at the first failure.
  mode=(-fork="$(nproc)" -max_total_time="$seconds")
  what="${seconds} s on $(nproc) processes"
else
  rm -rf corpus && mkdir corpus && cp "$root/Testing/Fuzz/corpus/core/"* corpus/
  mode=(-seed=1 -runs="$runs")
  what="${runs} inputs, seed 1"
fi
# -timeout: one input may take at most 20 s (a hang fails).
"$build/bin/FuzzCorePipeline" "${mode[@]}" -timeout=20 -rss_limit_mb=4096 -max_len=512 \
  -print_final_stats=1 corpus > fuzz.log 2>&1 || {
  tail -n 60 fuzz.log
  echo "fuzz: FuzzCorePipeline failed (the input: crash-*, timeout-* or oom-* in $build)"
  exit 1
}
grep -E "stat::number_of_executed_units|DONE|INFO: fuzzed" fuzz.log | tail -n 3
echo "fuzz: FuzzCorePipeline ran ${what} without a failure"
