#!/usr/bin/env bash
# Builds every libFuzzer target (fuzz/CMakeLists.txt) with clang under
# AddressSanitizer and UndefinedBehaviorSanitizer (every library they link is
# instrumented too) and runs EACH for a bounded time on a scratch copy of its
# seed corpus, printing libFuzzer's final stats (executions, coverage).
#   bash scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET...]   (default 60; all targets)
# Targets: tlod_reader ht_sections mt metadata nrrd metaimage hdf5_reader vdb_reader
# (the last two read through the isolated child process; a library crash there is
# a clean error, and libFuzzer's handler in the child may leave a crash-* file in
# the scratch artifact folder: only a fuzzer that stops early is a failure).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
shift || true
all=(tlod_reader ht_sections mt metadata nrrd metaimage hdf5_reader vdb_reader)
if [ "$#" -eq 0 ]; then targets=("${all[@]}"); else targets=("$@"); fi
declare -A corpus_of=([tlod_reader]=reader [ht_sections]=ht_sections [mt]=mt [metadata]=metadata
                      [nrrd]=nrrd [metaimage]=metaimage [hdf5_reader]=hdf5 [vdb_reader]=vdb)
declare -A timeout_of=([hdf5_reader]=30 [vdb_reader]=30)
# TETLOD_BUILD_FUZZERS instruments every library (ASan, UBSan, coverage). UBSan
# stays recoverable so scripts/ubsan.supp can silence reports inside system
# headers (oneTBB); halt_on_error=1 below makes every other report fatal.
generator=()
if command -v ninja >/dev/null 2>&1; then generator=(-G Ninja); fi
# FUZZ_BUILD_DIR reuses a tree configured with TETLOD_BUILD_FUZZERS=ON, e.g. the
# sanitized test tree (scripts/test-sanitized.sh builds the fuzz targets too; CI
# fuzzes there). Without it, ./build-fuzz is configured for fuzzing alone.
build="${FUZZ_BUILD_DIR:-build-fuzz}"
if [ ! -f "$build/CMakeCache.txt" ]; then
  CC=clang CXX=clang++ cmake -S . -B "$build" "${generator[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DTETLOD_BUILD_FUZZERS=ON -DTETLOD_BUILD_TESTS=OFF -DTETLOD_BUILD_BENCH=OFF \
    -DTETLOD_WITH_OPENVDB=ON -DTETLOD_WITH_HDF5=ON -DTETLOD_WITH_OPENMESH=OFF \
    -DTETLOD_WITH_PYTHON=OFF -DTETLOD_WITH_MPI=OFF >/dev/null
elif ! grep -q '^TETLOD_BUILD_FUZZERS:BOOL=ON' "$build/CMakeCache.txt"; then
  echo "fuzz: $build is not configured with TETLOD_BUILD_FUZZERS=ON" >&2
  exit 2
fi
cmake --build "$build" --parallel "${FUZZ_BUILD_JOBS:-$(nproc)}" --target "${targets[@]/#/fuzz_}"
# FUZZ_WORK_DIR keeps the corpora, logs and artifacts of a longer campaign.
if [ -n "${FUZZ_WORK_DIR:-}" ]; then
  work="$FUZZ_WORK_DIR"
  mkdir -p "$work"
else
  work=$(mktemp -d)
  trap 'rm -rf "$work"' EXIT
fi
for t in "${targets[@]}"; do
  c="${corpus_of[$t]}"
  mkdir -p "$work/$t" "$work/$t.artifacts"
  cp fuzz/corpus/"$c"/* "$work/$t"/
  echo "fuzz: running fuzz_$t for ${seconds}s"
  # -timeout: an input taking longer is reported as a hang (a failure).
  ASAN_OPTIONS=detect_leaks=1 \
  UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1:suppressions="$(pwd)/scripts/ubsan.supp" \
    "$build"/fuzz/fuzz_"$t" -max_total_time="$seconds" -rss_limit_mb=2048 \
    -timeout="${timeout_of[$t]:-10}" -artifact_prefix="$work/$t.artifacts/" \
    -print_final_stats=1 "$work/$t" >"$work/$t.log" 2>&1 || { tail -n 60 "$work/$t.log"; echo "fuzz: fuzz_$t FAILED"; exit 1; }
  # The last stats line is the fuzzer's own (isolated children of the HDF5/VDB
  # targets print theirs too when a library crashes in them).
  grep -E "^stat::(number_of_executed_units|peak_rss_mb)" "$work/$t.log" | tail -n 2 || true
  grep -E "cov: [0-9]+" "$work/$t.log" | tail -n 1
  echo "fuzz: no crash in fuzz_$t (${seconds}s)"
done
