#!/usr/bin/env bash
# The test suite built with clang under AddressSanitizer + UndefinedBehaviorSanitizer
# (every tetlod library and test; system libraries stay uninstrumented), in ./build-asan.
# Any sanitizer report fails the test that triggered it. Benchmarks, the Python
# module and tetlod-mpi are not built here (the release suite tests them).
#
# The same tree builds the libFuzzer targets (TETLOD_BUILD_FUZZERS: coverage
# instrumentation on top of the sanitizers), so that CI fuzzes without compiling
# every library a third time: FUZZ_BUILD_DIR=build-asan bash scripts/fuzz.sh 20.
#
# A few equivalence and oracle tests that repeat the same code paths on larger
# volumes (the release suite runs them in seconds; here, under ASan with the
# fuzzers' coverage instrumentation, each takes minutes) are left out; smaller
# tests of the same paths run, and so does every hostile-input, corrupt-file
# and decoder test. TETLOD_SANITIZED_ALL=1 runs them too.
#   bash scripts/test-sanitized.sh
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
generator=()
if command -v ninja >/dev/null 2>&1; then generator=(-G Ninja); fi
configure=()  # the generator only on the first configure (CMake refuses a change)
if [ ! -f build-asan/CMakeCache.txt ]; then configure=("${generator[@]}"); fi
# -O1: the usual level for sanitizer builds; compiles faster than -O3 and keeps
# the reports' stacks readable.
CC=clang CXX=clang++ cmake -S . -B build-asan "${configure[@]}" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_C_FLAGS_RELEASE="-O1 -DNDEBUG" -DCMAKE_CXX_FLAGS_RELEASE="-O1 -DNDEBUG" \
  -DTETLOD_SANITIZE=ON -DTETLOD_BUILD_FUZZERS=ON -DTETLOD_BUILD_BENCH=OFF \
  -DTETLOD_WITH_PYTHON=OFF -DTETLOD_WITH_MPI=OFF >/dev/null
cmake --build build-asan --parallel "$(nproc)"
cd build-asan
# halt_on_error: a report ends the process with an error exit code, so the test fails.
export ASAN_OPTIONS=detect_leaks=1:halt_on_error=1:abort_on_error=0:detect_stack_use_after_return=0
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1:suppressions="$(pwd)/../scripts/ubsan.supp"
export LSAN_OPTIONS=suppressions="$(pwd)/../scripts/lsan.supp":print_suppressions=0
heavy=(
  'Awkward/LazyExtractCases.SameMeshAsTheFullDecodeForEveryCache/(33x29x31|40x9x23|21x13x6) '
  'Streaming.ContainerExtractionWritesTheSameBytes'
  'Streaming.InMemoryModelsWriteTheSameBytes'
  'Dims/HtSynthetic.QueriesPassTheOracle/(33x33x33_u8_noisy|40x33x20_u8_plateau|33x33x33_i16_smooth|40x33x20_f64_smooth)'
  'MtExtract.MatchesTheExplicitDagOracle'
  'MtExtract.QueriesPassTheIndependentChecker'
  'VolumePlanes.ContainerPlanesEqualTheWholeDecodeInAnyOrderAndCache'
  'MtSpec.AnExtractorWrittenFromTheSpecGivesTheSameMeshes'
  'StreamEncode.(SameBytesAsInMemory|RowsEncodedInPartsGiveTheSameBytes|ErrorsComputedInPartsGiveTheSameBytes)'
  'LazyExtract.LossyLatticeChunks'
  'CliReproducible.ContainersAndMeshesAreIdenticalForAnyThreadCount'
  'MtPassCaps\.'
  'CliMeshOutputs.(CompareOnAContainerMeasuresItsStoredModels|CompareWritesAReportWithItsPlots)'
  'Lossy.BoundedMemoryStreamsTwoCandidates'
  'CliMeshOutputs.StatsJsonIsConsistent'
  'CliReproducible.PlaneByPlaneConversionGivesTheInMemoryBytes'
  'MtBuildProgress.OneLargeBrickMovesBeforeItEnds'
  # The real volumes of ../shared/data (when present): HT and MT oracles at size.
  'SharedData/HtRealData\.'
  'MtRealData\.'
  # Reads headsq.vdb in a forked child under ASan with another test running: in 2 of
  # the last 4 sanitized CI runs the child never finished (stopped at 11.3 s, then at
  # 56.5 s; 0.8 s alone), which looks like a lock held across fork under ASan, not
  # slowness. The release suite runs it; the hostile-VDB tests still run here.
  'VolumeFormats.RealFilesGiveTheSameVolumeAsTheirRawOriginals'
)
exclude=()
if [ "${TETLOD_SANITIZED_ALL:-0}" != 1 ]; then
  exclude=(-E "^($(IFS='|'; echo "${heavy[*]}"))")
  echo "test-sanitized: leaving out ${#heavy[@]} patterns of heavy equivalence tests (TETLOD_SANITIZED_ALL=1 runs them)"
fi
ctest --output-on-failure --parallel "$(nproc)" --timeout 1500 "${exclude[@]}"
