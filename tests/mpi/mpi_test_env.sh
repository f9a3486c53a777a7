# Sourced by the tests/mpi drivers (mpi_convert_test.sh, mpi_decode_test.sh,
# mpi_extract_test.sh) after they set $tetlod, $tetlod_mpi, $mpirun and $work:
# the Open MPI environment, a fresh work folder, `fail`, `run_mpi N ARGS...`
# and `corrupt_field_section first|last IN OUT`.

# As root (CI, this machine) Open MPI refuses to start without these.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
# The shared-memory transport needs no network set-up: fast and quiet in containers.
export OMPI_MCA_btl=self,vader OMPI_MCA_plm_rsh_agent=false
rm -rf "$work" && mkdir -p "$work" && cd "$work" || exit 1

fail() { echo "FAIL: $*"; exit 1; }
# --bind-to none: rank 0 encodes with threads (see tetlod-mpi's note on pinning).
run_mpi() { local n=$1; shift; "$mpirun" -n "$n" --oversubscribe --bind-to none "$tetlod_mpi" "$@"; }
if [ -n "${TETLOD_MPI_SANITIZED:-}" ]; then
    # Open MPI unloads its plugins before LeakSanitizer runs, so their one-time
    # allocations show up as leaks in "<unknown module>" that no suppression can
    # name. Leak checking is off for the MPI processes only; ASan and UBSan
    # errors still fail the test (and the serial tetlod runs keep it).
    echo "note: sanitized build: leak checking off for the MPI processes (Open MPI's unloaded plugins)"
    run_mpi() {
        local n=$1; shift
        ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0" "$mpirun" -n "$n" --oversubscribe --bind-to none \
            -x ASAN_OPTIONS -x UBSAN_OPTIONS "$tetlod_mpi" "$@"
    }
fi

# corrupt_field_section first|last IN OUT: OUT is IN with 4 bytes overwritten in
# the middle of its first HT_FIELD section (the coarsest cycle, which every rank
# reads) or its last (cycle 0's last bricks, read by the last rank only).
corrupt_field_section() {
    local off
    off=$("$tetlod" info "$2" --json | /usr/bin/python3 -c '
import json, sys
f = [s for s in json.load(sys.stdin)["sections"] if s["type"] == "HT_FIELD"]
s = f[0] if sys.argv[1] == "first" else f[-1]
print(s["offset"] + s["stored_size"] // 2)' "$1") || fail "tetlod info --json $2"
    cp "$2" "$3" || fail "cp $2"
    printf '\xff\x00\xff\x00' | dd of="$3" bs=1 seek="$off" conv=notrunc status=none || fail "dd $3"
}
