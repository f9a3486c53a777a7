#!/usr/bin/env bash
# ctest driver for `tetlod-mpi extract` (tests/mpi/CMakeLists.txt): the mesh
# file written by `mpirun -n N tetlod-mpi extract IN.tlod OUT --error E ...`
# must be the file `tetlod extract` writes, byte for byte (cmp), for every N:
# uniform errors, --error 0, --error -1 (full), box queries, .vtu/.vtk/.msh.
# A failure on any rank ends every rank with the right exit code, a message
# naming the file, and no output left; an existing output needs -f.
#
#   mpi_extract_test.sh CASE TETLOD TETLOD_MPI MPIRUN WORKDIR
# CASE: uniform-u8 | uniform-float | box | failures
set -uo pipefail
case_name=$1 tetlod=$2 tetlod_mpi=$3 mpirun=$4 work=$5

source "$(dirname "${BASH_SOURCE[0]}")/mpi_test_env.sh"

make_tlod() {  # NAME DIMS DTYPE OUT [convert flags]
    local name=$1 dims=$2 type=$3 out=$4; shift 4
    "$tetlod" -q sample "$name" "$out.raw" --dims "$dims" --dtype "$type" || fail "sample $name"
    "$tetlod" -q convert "$out.raw" "$out.tlod" --dims "$dims" --dtype "$type" --spacing 0.5,1,2 --origin 1,-2,3 "$@" ||
        fail "convert $out"
    rm -f "$out.raw"
}

# same_mesh TLOD OUT_EXT RANKS -- EXTRACT FLAGS...: serial once, then each rank count, cmp.
same_mesh() {
    local tlod=$1 ext=$2 ranks=$3; shift 4
    "$tetlod" -q -f extract "$tlod" "serial.$ext" "$@" || fail "serial extract $tlod $*"
    for n in $ranks; do
        run_mpi "$n" -q -f extract "$tlod" "mpi$n.$ext" "$@" || fail "mpirun -n $n tetlod-mpi extract $tlod $*"
        cmp -s "serial.$ext" "mpi$n.$ext" || fail "$tlod $* (.$ext): -n $n differs from tetlod extract"
        rm -f "mpi$n.$ext"
    done
    echo "ok: $tlod $* (.$ext), -n $ranks: the file tetlod extract writes ($(stat -c %s "serial.$ext") bytes)"
    rm -f "serial.$ext"
}

# only FILES...: the folder holds exactly these (no temporary file left).
only() {
    local want have
    want=$(printf '%s\n' "$@" | sort) have=$(ls -A | sort)
    [ "$want" = "$have" ] || fail "files: expected [$(echo $want)], found [$(echo $have)]"
}

case "$case_name" in
uniform-u8)
    make_tlod multiscale 13,7,5 u8 u8
    for e in 1% 0 -1 inf; do same_mesh u8.tlod vtu "1 2 4" -- --error $e; done
    same_mesh u8.tlod vtu "3" -- --error 0 --compress none
    ;;
uniform-float)
    make_tlod noisy 29,23,19 f32 f32
    make_tlod noisy 21,17,11 i16 pad --pad
    for e in 1% -1; do same_mesh f32.tlod vtu "1 2 4" -- --error $e; done
    for e in 0 5; do same_mesh pad.tlod vtu "2 4" -- --error $e; done
    same_mesh f32.tlod vtk "3" -- --error 2%
    same_mesh f32.tlod msh "3" -- --error 2%
    ;;
box)
    make_tlod multiscale 13,7,5 u8 u8
    make_tlod noisy 29,23,19 f32 f32
    make_tlod noisy 21,17,11 i16 pad --pad
    same_mesh u8.tlod vtu "1 2 4" -- --error 0 --box 2,1,1,6,4,3 --error-out 10%
    same_mesh f32.tlod vtu "1 2 4" -- --error 0 --box 5,5,5,20,15,12
    same_mesh f32.tlod vtu "1 2 4" -- --error -1 --box 22,0,0,28,22,18 --error-out 5%
    same_mesh pad.tlod vtu "1 2 4" -- --error 1% --box 0,0,0,4,4,4 --error-out inf
    ;;
failures)
    make_tlod multiscale 40,30,70 u8 s
    echo keep > out.vtu
    # An existing output is refused without -f (exit 2, untouched), replaced with it.
    run_mpi 2 extract s.tlod out.vtu --error 1% 2> err.txt
    code=$?
    [ "$code" -eq 2 ] && [ "$(cat out.vtu)" = keep ] || fail "existing output without -f: exit $code: $(cat err.txt)"
    grep -q "out.vtu" err.txt && grep -q -- "--force" err.txt || fail "existing output: message: $(cat err.txt)"
    echo "ok: existing output refused without -f: exit 2: $(head -1 err.txt)"
    run_mpi 2 -q -f extract s.tlod out.vtu --error 1% || fail "-f"
    "$tetlod" -q extract s.tlod serial.vtu --error 1% || fail "serial"
    cmp -s out.vtu serial.vtu || fail "-f: not the serial file"
    echo "ok: -f replaces it with the serial file"
    rm -f serial.vtu err.txt
    # A corrupt chunk (the middle of the first and of the last HT_FIELD
    # section): every rank ends with exit 4 naming the file, no output left.
    for spec in "2 last" "4 first" "1 last"; do
        set -- $spec
        corrupt_field_section "$2" s.tlod bad.tlod
        run_mpi "$1" extract bad.tlod new.vtu --error 0 2> err.txt
        code=$?
        [ "$code" -eq 4 ] || fail "corrupt $2 chunk, -n $1: exit $code, expected 4: $(cat err.txt)"
        grep -q "bad.tlod" err.txt || fail "corrupt $2 chunk, -n $1: message: $(cat err.txt)"
        echo "ok: corrupt $2 chunk, -n $1: exit 4: $(head -1 err.txt)"
        rm -f err.txt bad.tlod
        only out.vtu s.tlod
    done
    # A rank failing after its run (rank 1 of 2, rank 3 of 4, rank 0 of 3): no output.
    for spec in "2 1" "4 3" "3 0"; do
        set -- $spec
        TETLOD_MPI_TEST_FAIL_RANK=$2 TETLOD_MPI_TEST_FAIL_PHASE=extract run_mpi "$1" extract s.tlod new.vtu --error 0 2> err.txt
        code=$?
        [ "$code" -eq 4 ] || fail "rank $2 of $1 failing: exit $code, expected 4: $(cat err.txt)"
        grep -q "s.tlod" err.txt && grep -q "injected" err.txt || fail "rank $2 of $1: message: $(cat err.txt)"
        echo "ok: rank $2 of $1 fails: exit 4: $(head -1 err.txt)"; rm -f err.txt
        only out.vtu s.tlod
    done
    # A missing container (exit 3), an unknown extension (exit 2), a missing folder (exit 3).
    run_mpi 2 extract missing.tlod new.vtu --error 0 2> err.txt
    code=$?
    [ "$code" -eq 3 ] && grep -q "missing.tlod" err.txt || fail "missing container: exit $code: $(cat err.txt)"
    echo "ok: missing container: exit 3: $(head -1 err.txt)"
    run_mpi 2 extract s.tlod new.xyz --error 0 2> err.txt
    code=$?
    [ "$code" -eq 2 ] || fail "unknown extension: exit $code: $(cat err.txt)"
    echo "ok: unknown extension: exit 2: $(head -1 err.txt)"
    run_mpi 2 extract s.tlod nodir/new.vtu --error 0 2> err.txt
    code=$?
    [ "$code" -eq 3 ] && grep -q "nodir" err.txt || fail "missing folder: exit $code: $(cat err.txt)"
    echo "ok: missing folder: exit 3: $(head -1 err.txt)"
    # Flags: the same texts refused as by `tetlod extract`, with the same message.
    for flags in "--error 1e" "--error nan" "--error 0 --box 8.0,1,1,20,20,20" "--error 0 --box 1,1,1,4,4" \
                 "--error 0 --box 5,1,1,4,4,4" "--error 0 --box 1,1,1,4,4,4 --error-out 5%%"; do
        run_mpi 1 extract s.tlod new.vtu $flags 2> err.txt
        code=$?
        "$tetlod" extract s.tlod new.vtu $flags 2> serial.txt
        want=$(head -1 serial.txt | sed 's/^tetlod: //')
        [ "$code" -eq 2 ] && grep -qF -- "$want" err.txt || fail "$flags: exit $code: $(cat err.txt), tetlod: $want"
        echo "ok: $flags: exit 2: $want"
    done
    rm -f err.txt serial.txt
    rm -f err.txt
    only out.vtu s.tlod
    ;;
*) fail "unknown case $case_name" ;;
esac
echo "PASS"
