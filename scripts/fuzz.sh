#!/usr/bin/env bash
# The fuzz targets built with clang, AddressSanitizer and UndefinedBehaviorSanitizer in
# ./build-fuzz: the VTK-free core with its unit tests, and stmesh's image input (against
# ParaView's VTK, not instrumented). Runs the core unit tests and the seed corpora, then fuzzes
# each target with libFuzzer from a copy of its seed corpus and its regressions:
# FuzzCorePipeline and FuzzImageReading. By default (CI) the fuzzing is reproducible: one
# process, seed 1, FUZZ_RUNS (default 200) core inputs and FUZZ_READER_RUNS (default 5000)
# files. With FUZZ_SECONDS set, each target runs that long with a process per core
# (development). New inputs stay in build-fuzz/corpus-<target>; a failing input is written to
# build-fuzz/crash-* (or timeout-*, oom-*) and fails the script. docs/reliability.md records
# the runs.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${SPACETREEMESH_FUZZ_BUILD_DIR:-$root/build-fuzz}"
seconds="${FUZZ_SECONDS:-}"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DSPACETREEMESH_CORE_ONLY=ON -DSPACETREEMESH_FUZZ=ON -DSPACETREEMESH_FUZZ_READERS=ON \
  "-DSPACETREEMESH_SANITIZE=address;undefined"
cmake --build "$build" -j "$(nproc)"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1"
# Leaks inside third-party libraries we cannot mend (each explained in the file).
export LSAN_OPTIONS="suppressions=$root/Testing/Fuzz/lsan-suppressions.txt:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
ctest --test-dir "$build" --output-on-failure -j "$(nproc)" --timeout 900

# fuzz <target> <corpus name> <runs> <largest input>
fuzz() {
  local target="$1" name="$2" runs="$3" max_len="$4"
  local corpus="$build/corpus-$name" mode what
  mkdir -p "$corpus"
  if [ -n "$seconds" ]; then
    # A child per core, stopping at the first failure; the corpus grows from run to run.
    mode=(-fork="$(nproc)" -max_total_time="$seconds")
    what="${seconds} s on $(nproc) processes"
  else
    rm -rf "$corpus" && mkdir "$corpus"
    mode=(-seed=1 -runs="$runs")
    what="${runs} inputs, seed 1"
  fi
  cp -n "$root/Testing/Fuzz/corpus/$name/"* "$corpus/"
  if [ -d "$root/Testing/Fuzz/regressions/$name" ]; then
    cp -n "$root/Testing/Fuzz/regressions/$name/"* "$corpus/"
  fi
  # -timeout: one input may take at most 20 s (a hang fails).
  (cd "$build" && "$build/bin/$target" "${mode[@]}" -timeout=20 -rss_limit_mb=4096 \
    -max_len="$max_len" -print_final_stats=1 "$corpus" > "fuzz-$name.log" 2>&1) || {
    tail -n 60 "$build/fuzz-$name.log"
    echo "fuzz: $target failed (the input: crash-*, timeout-* or oom-* in $build)"
    exit 1
  }
  grep -E "stat::number_of_executed_units|DONE|INFO: fuzzed" "$build/fuzz-$name.log" | tail -n 3
  echo "fuzz: $target ran ${what} without a failure"
}

fuzz FuzzCorePipeline core "${FUZZ_RUNS:-200}" 512
# VTK's readers print to stderr on every corrupt file; the log keeps it.
fuzz FuzzImageReading reading "${FUZZ_READER_RUNS:-5000}" 4096
