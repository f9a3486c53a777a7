#!/usr/bin/env bash
# ctest driver for tetlod-mpi (tests/mpi/CMakeLists.txt): containers written by
# `mpirun -n N tetlod-mpi convert` must be byte-identical to `tetlod convert`'s
# for every N, and a failure on any rank must end every rank with the right
# exit code, a message naming the file, and no output left behind.
#
#   mpi_convert_test.sh CASE TETLOD TETLOD_MPI MPIRUN WORKDIR [DATA_DIR]
# CASE: awkward-u8 | awkward-f32 | bricks | real | failures
set -uo pipefail
case_name=$1 tetlod=$2 tetlod_mpi=$3 mpirun=$4 work=$5 data=${6:-}

# The creation time is the only thing that would differ between two runs.
export SOURCE_DATE_EPOCH=1700000000
source "$(dirname "${BASH_SOURCE[0]}")/mpi_test_env.sh"

# convert_and_compare H5 LABEL [flags...]: serial once, then N = 1, 2, 4.
convert_and_compare() {
    local h5=$1 label=$2; shift 2
    "$tetlod" -q convert "$h5" "serial_$label.tlod" "$@" || fail "serial convert of $h5"
    for n in 1 2 4; do
        run_mpi "$n" -q convert "$h5" "mpi${n}_$label.tlod" "$@" || fail "mpirun -n $n tetlod-mpi convert $h5 $*"
        cmp "serial_$label.tlod" "mpi${n}_$label.tlod" || fail "$label: -n $n differs from the serial container"
        echo "ok: $label, -n $n: byte-identical ($(stat -c %s "mpi${n}_$label.tlod") bytes)"
    done
}

# An HDF5 volume made with the serial tools: a sample raw, decoded to .h5.
make_h5() {  # NAME DIMS DTYPE OUT
    "$tetlod" -q sample "$1" "$4.raw" --dims "$2" --dtype "$3" || fail "sample $1"
    "$tetlod" -q decode "$4.raw" "$4.h5:/volume" --dims "$2" --dtype "$3" || fail "decode to $4.h5"
}

# no_leftovers: nothing but the inputs in the folder (no output, no temporary).
no_leftovers() {
    local extra
    extra=$(ls -A | grep -v -e '\.h5$' -e '\.raw$' || true)
    [ -z "$extra" ] || fail "$1: files left behind: $extra"
}

case "$case_name" in
awkward-u8)
    make_h5 multiscale 37,29,41 u8 ms_u8
    convert_and_compare ms_u8.h5:/volume u8
    # Other container flags, and a rank count that does not divide 41 planes.
    "$tetlod" -q convert ms_u8.h5:/volume serial_pad.tlod --pad --brick-log2 2 --meta who=test || fail "serial --pad"
    run_mpi 3 -q convert ms_u8.h5:/volume mpi3_pad.tlod --pad --brick-log2 2 --meta who=test || fail "mpi --pad"
    cmp serial_pad.tlod mpi3_pad.tlod || fail "--pad --brick-log2 2 --meta, -n 3 differs"
    echo "ok: --pad --brick-log2 2 --meta, -n 3: byte-identical"
    # The full section table (a 3.0 file for older readers): the same bytes too.
    "$tetlod" -q convert ms_u8.h5:/volume serial_full.tlod --table full --meta who=test || fail "serial --table full"
    run_mpi 3 -q convert ms_u8.h5:/volume mpi3_full.tlod --table full --meta who=test || fail "mpi --table full"
    cmp serial_full.tlod mpi3_full.tlod || fail "--table full, -n 3 differs"
    "$tetlod" info serial_full.tlod | grep -q "full section table" || fail "--table full did not write the full table"
    echo "ok: --table full, -n 3: byte-identical"
    # More ranks than planes: some ranks (rank 0 among them) hold no plane.
    make_h5 sphere 13,11,3 u8 thin
    "$tetlod" -q convert thin.h5:/volume serial_thin.tlod || fail "serial thin"
    run_mpi 4 -q convert thin.h5:/volume mpi4_thin.tlod || fail "mpi thin"
    cmp serial_thin.tlod mpi4_thin.tlod || fail "13x11x3, -n 4 differs"
    echo "ok: 13x11x3 (3 planes), -n 4: byte-identical"
    ;;
awkward-f32)
    make_h5 noisy 37,29,41 f32 noisy_f32
    convert_and_compare noisy_f32.h5:/volume f32
    # Padding: B has 65 planes, the source 41; ranks 2 and 3 of 4 hold only
    # padded planes (the last source plane repeated) and a slab of 16 planes
    # is thinner than the 32-plane reach of the largest diamonds.
    "$tetlod" -q convert noisy_f32.h5:/volume serial_pad.tlod --pad || fail "serial --pad"
    for n in 3 4; do
        run_mpi "$n" -q convert noisy_f32.h5:/volume "mpi${n}_pad.tlod" --pad || fail "mpi --pad -n $n"
        cmp serial_pad.tlod "mpi${n}_pad.tlod" || fail "f32 --pad, -n $n differs"
        echo "ok: f32 --pad, -n $n: byte-identical"
    done
    ;;
bricks)
    # Encoding on every rank (step 3): 130 planes give cycle 0 five rows of
    # bricks (two or three per rank at -n 2, several bricks per row), cycle 1
    # a row of planes 64..127 that spans ranks 0 and 1 at -n 2 (and three
    # ranks at -n 4), the coarse cycles rows spanning every rank; --brick-log2 2
    # at -n 3 gives rows of 8 planes, many per rank, and windows across slabs.
    make_h5 multiscale 70,66,130 u8 bricks_u8
    convert_and_compare bricks_u8.h5:/volume bricks
    "$tetlod" -q convert bricks_u8.h5:/volume serial_b2.tlod --brick-log2 2 || fail "serial --brick-log2 2"
    run_mpi 3 -q convert bricks_u8.h5:/volume mpi3_b2.tlod --brick-log2 2 || fail "mpi --brick-log2 2"
    cmp serial_b2.tlod mpi3_b2.tlod || fail "--brick-log2 2, -n 3 differs"
    echo "ok: 70x66x130 --brick-log2 2, -n 3: byte-identical"
    # To standard output: the ranks write a temporary file rank 0 copies out.
    run_mpi 2 -q convert bricks_u8.h5:/volume - > mpi2_stdout.tlod || fail "mpi to stdout"
    cmp serial_bricks.tlod mpi2_stdout.tlod || fail "-n 2 to standard output differs"
    [ -z "$(ls -A | grep '\.tmp$')" ] || fail "temporary file left after writing to stdout"
    echo "ok: -n 2 to standard output: byte-identical"
    ;;
real)
    raw="$data/headsq_64x64x93_int16.raw"
    if [ ! -f "$raw" ]; then
        echo "SKIP: $raw is absent (shared data not available)"
        exit 0
    fi
    "$tetlod" -q decode "$raw" headsq.h5:/volume || fail "decode $raw to .h5"
    convert_and_compare headsq.h5:/volume headsq
    ;;
failures)
    make_h5 sphere 21,17,19 u8 s
    # A missing dataset: every rank finds it missing; exit 3, the file named.
    run_mpi 2 convert s.h5:/nope out.tlod 2> err.txt
    code=$?
    [ "$code" -eq 3 ] || fail "missing dataset: exit $code, expected 3"
    grep -q "s.h5" err.txt && grep -q "nope" err.txt || fail "missing dataset: message: $(cat err.txt)"
    echo "ok: missing dataset: exit 3: $(head -1 err.txt)"; rm -f err.txt
    no_leftovers "missing dataset"
    # A rank that cannot read (rank 1 of 2, then rank 2 of 4): every rank ends.
    for spec in "2 1" "4 2"; do
        set -- $spec
        TETLOD_MPI_TEST_FAIL_RANK=$2 run_mpi "$1" convert s.h5:/volume out.tlod 2> err.txt
        code=$?
        [ "$code" -eq 3 ] || fail "rank $2 of $1 failing: exit $code, expected 3"
        grep -q "rank $2" err.txt && grep -q "s.h5" err.txt || fail "rank $2 of $1: message: $(cat err.txt)"
        echo "ok: rank $2 of $1 fails to read: exit 3: $(head -1 err.txt)"; rm -f err.txt
        no_leftovers "failing rank"
    done
    # A rank failing in the distributed phases (its first pass, its errors,
    # the encode on rank 0 or serving planes and errors on the others).
    for spec in "2 1 scan" "4 0 scan" "2 0 errors" "4 3 errors" "2 0 encode" "4 2 encode"; do
        set -- $spec
        TETLOD_MPI_TEST_FAIL_RANK=$2 TETLOD_MPI_TEST_FAIL_PHASE=$3 run_mpi "$1" convert s.h5:/volume out.tlod 2> err.txt
        code=$?
        [ "$code" -eq 3 ] || fail "rank $2 of $1 failing in $3: exit $code, expected 3: $(cat err.txt)"
        grep -q "s.h5" err.txt && grep -q "injected" err.txt || fail "rank $2 of $1 in $3: message: $(cat err.txt)"
        if [ "$2" -ne 0 ]; then grep -q "rank $2" err.txt || fail "rank $2 of $1 in $3: no rank named: $(cat err.txt)"; fi
        echo "ok: rank $2 of $1 fails in $3: exit 3: $(head -1 err.txt)"; rm -f err.txt
        no_leftovers "rank failing in $3"
    done
    # Not HDF5 at all: refused before any collective call.
    run_mpi 2 convert s.raw out.tlod 2> err.txt
    code=$?
    [ "$code" -eq 4 ] && grep -q "s.raw" err.txt || fail "not HDF5: exit $code: $(cat err.txt)"
    echo "ok: not an HDF5 file: exit 4: $(head -1 err.txt)"; rm -f err.txt
    # A missing file: exit 3.
    run_mpi 2 convert missing.h5:/volume out.tlod 2> err.txt
    code=$?
    [ "$code" -eq 3 ] && grep -q "missing.h5" err.txt || fail "missing file: exit $code: $(cat err.txt)"
    echo "ok: missing file: exit 3: $(head -1 err.txt)"; rm -f err.txt
    no_leftovers "not HDF5"
    # Bad dims (a 4-D dataset) and a NaN sample (refused by the encoder on rank 0).
    if /usr/bin/python3 -c "import h5py, numpy" 2> /dev/null; then
        /usr/bin/python3 - <<'PY'
import h5py, numpy as np
with h5py.File("bad.h5", "w") as f:
    f["four"] = np.zeros((2, 3, 4, 5), np.uint8)
    v = np.zeros((9, 7, 5), np.float32); v[6, 3, 2] = np.nan
    f["nan"] = v
PY
        run_mpi 2 convert bad.h5:/four out.tlod 2> err.txt
        code=$?
        [ "$code" -eq 4 ] && grep -q "rank 4" err.txt || fail "4-D dataset: exit $code: $(cat err.txt)"
        echo "ok: 4-D dataset: exit 4: $(head -1 err.txt)"; rm -f err.txt
        run_mpi 2 convert bad.h5:/nan out.tlod 2> err.txt
        code=$?
        [ "$code" -eq 4 ] || fail "NaN: exit $code: $(cat err.txt)"
        echo "ok: NaN sample: exit 4: $(head -1 err.txt)"; rm -f err.txt
        no_leftovers "bad data"
    else
        echo "note: python3 h5py/numpy absent: 4-D and NaN cases skipped"
    fi
    # An existing output is kept without -f (exit 2), replaced with it.
    echo keep > out.tlod
    run_mpi 2 convert s.h5:/volume out.tlod 2> err.txt
    code=$?
    [ "$code" -eq 2 ] && [ "$(cat out.tlod)" = keep ] || fail "existing output: exit $code"
    echo "ok: existing output kept: exit 2: $(head -1 err.txt)"
    run_mpi 2 -q -f convert s.h5:/volume out.tlod || fail "-f"
    "$tetlod" -q convert s.h5:/volume serial.tlod && cmp serial.tlod out.tlod || fail "-f output differs"
    echo "ok: -f replaces it"
    ;;
*) fail "unknown case $case_name" ;;
esac
echo "PASS: $case_name"
