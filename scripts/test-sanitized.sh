#!/usr/bin/env bash
# The whole test suite built with clang under AddressSanitizer + UndefinedBehaviorSanitizer
# (every tetlod library and test; system libraries stay uninstrumented), in ./build-asan.
# Any sanitizer report fails the test that triggered it. Benchmarks are not built.
#   bash scripts/test-sanitized.sh
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
generator=()
if command -v ninja >/dev/null 2>&1; then generator=(-G Ninja); fi
if [ ! -f build-asan/CMakeCache.txt ]; then
  CC=clang CXX=clang++ cmake -S . -B build-asan "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
    -DTETLOD_SANITIZE=ON -DTETLOD_BUILD_BENCH=OFF
fi
cmake --build build-asan --parallel "$(nproc)"
cd build-asan
# halt_on_error: a report ends the process with an error exit code, so the test fails.
export ASAN_OPTIONS=detect_leaks=1:halt_on_error=1:abort_on_error=0:detect_stack_use_after_return=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1:suppressions="$(pwd)/../scripts/ubsan.supp"
export LSAN_OPTIONS=suppressions="$(pwd)/../scripts/lsan.supp":print_suppressions=0
ctest --output-on-failure --parallel "$(nproc)" --timeout 1500
