#!/usr/bin/env bash
# Builds the libFuzzer target for the .tlod reader with clang under AddressSanitizer
# and UndefinedBehaviorSanitizer (every library it links is instrumented too) and
# runs it for a bounded time on a scratch copy of the seed corpus.
#   bash scripts/fuzz.sh [SECONDS]   (default 60)
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
san="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer"
generator=()
if command -v ninja >/dev/null 2>&1; then generator=(-G Ninja); fi
if [ ! -f build-fuzz/CMakeCache.txt ]; then
  CC=clang CXX=clang++ cmake -S . -B build-fuzz "${generator[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DTETLOD_BUILD_FUZZERS=ON -DTETLOD_BUILD_TESTS=OFF -DTETLOD_BUILD_BENCH=OFF \
    -DTETLOD_WITH_OPENVDB=OFF -DTETLOD_WITH_HDF5=OFF -DTETLOD_WITH_OPENMESH=OFF \
    -DCMAKE_C_FLAGS="$san" -DCMAKE_CXX_FLAGS="$san" >/dev/null
fi
cmake --build build-fuzz --target fuzz_tlod_reader --parallel "$(nproc)"
corpus=$(mktemp -d)
trap 'rm -rf "$corpus"' EXIT
cp fuzz/corpus/reader/* "$corpus"/
echo "fuzz: running fuzz_tlod_reader for ${seconds}s"
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ./build-fuzz/fuzz/fuzz_tlod_reader -max_total_time="$seconds" -rss_limit_mb=2048 \
  -print_final_stats=1 "$corpus" 2>&1 | tail -n 25
echo "fuzz: no crash in ${seconds}s"
