#!/usr/bin/env bash
# Builds all of SpacetreeMesh with AddressSanitizer and UndefinedBehaviorSanitizer (gcc) in
# ./build-asan and runs the whole test suite there (after scripts/install-deps.sh). Every finding
# aborts its test. The C++ tests and stmesh are instrumented executables and also check for leaks
# (LeakSanitizer); pvpython, pvbatch and the GUI are not, so for the Python tests the sanitizer
# runtimes are preloaded and leak checking is off (Python and ParaView keep their allocations to
# the end on purpose). Extra arguments go to ctest. About 15 minutes to build on 2 cores (-O1,
# line tables only) and 40 to test, every time limit scaled by 5: a development job
# (docs/reliability.md), not CI's.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${SPACETREEMESH_ASAN_BUILD_DIR:-$root/build-asan}"
SPACETREEMESH_BUILD_DIR="$build" bash "$root/scripts/build.sh" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -DNDEBUG" "-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O1 -DNDEBUG" \
  "-DSPACETREEMESH_SANITIZE=address;undefined" -DSPACETREEMESH_BUILD_BENCHMARKS=OFF
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
# Leaks inside third-party libraries we cannot mend (each explained in the file).
export LSAN_OPTIONS="suppressions=$root/Testing/Fuzz/lsan-suppressions.txt:print_suppressions=0"
status=0
# stmesh --report runs python3 on the wrapped (instrumented) classes: it goes with the Python tests.
python_cli="^stmesh[.]report[.]directory$"
ASAN_OPTIONS="detect_leaks=1" ctest --test-dir "$build" --output-on-failure -j 2 \
  --timeout 1800 -LE python -E "$python_cli" "$@" || status=1
preload="$(gcc -print-file-name=libasan.so):$(gcc -print-file-name=libubsan.so)"
for selection in "-L python" "-R $python_cli"; do
  # shellcheck disable=SC2086 # the selection is two words
  LD_PRELOAD="$preload" ASAN_OPTIONS="detect_leaks=0" ctest --test-dir "$build" \
    --output-on-failure -j 2 --timeout 1800 $selection "$@" || status=1
done
exit $status
