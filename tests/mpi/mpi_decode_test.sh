#!/usr/bin/env bash
# ctest driver for `tetlod-mpi decode` (tests/mpi/CMakeLists.txt): the HDF5
# dataset written by `mpirun -n N tetlod-mpi decode IN.tlod OUT.h5:/volume`
# must be the one `tetlod decode` writes (type, shape, values, attributes: read
# back with h5dump, not compared as file bytes) for every N; an existing file
# keeps its other datasets; a failure on any rank ends every rank with the
# right exit code, a message naming the file, and nothing left behind.
#
#   mpi_decode_test.sh CASE TETLOD TETLOD_MPI MPIRUN WORKDIR
# CASE: awkward | keep | failures
set -uo pipefail
case_name=$1 tetlod=$2 tetlod_mpi=$3 mpirun=$4 work=$5

source "$(dirname "${BASH_SOURCE[0]}")/mpi_test_env.sh"
command -v h5dump > /dev/null || { echo "SKIP: h5dump (hdf5-tools) is absent"; exit 0; }

# A container made with the serial tools from a sample volume, with geometry
# and user metadata so that every attribute the writer knows is exercised.
make_tlod() {  # NAME DIMS DTYPE OUT
    "$tetlod" -q sample "$1" "$4.raw" --dims "$2" --dtype "$3" || fail "sample $1"
    "$tetlod" -q convert "$4.raw" "$4.tlod" --dims "$2" --dtype "$3" --spacing 0.5,1,2 --origin 1,-2,3 \
        --meta who=test --meta "note=a b" || fail "convert $4"
    rm -f "$4.raw"
}

# same_dataset A.h5 B.h5 [DATASET]: same type, shape and attributes (h5dump's
# header and attributes, the file name line dropped) and the same values (the
# binary dump of each, so floats are compared exactly, not as printed text).
same_dataset() {
    local a=$1 b=$2 d=${3:-/volume}
    diff <(h5dump -A -d "$d" "$a" | tail -n +2) <(h5dump -A -d "$d" "$b" | tail -n +2) > /dev/null ||
        { diff <(h5dump -A -d "$d" "$a" | tail -n +2) <(h5dump -A -d "$d" "$b" | tail -n +2); return 1; }
    h5dump -d "$d" -b NATIVE -o "$a.bin" "$a" > /dev/null && h5dump -d "$d" -b NATIVE -o "$b.bin" "$b" > /dev/null ||
        return 1
    cmp -s "$a.bin" "$b.bin"; local r=$?
    rm -f "$a.bin" "$b.bin"
    return $r
}

# decode_and_compare TLOD LABEL RANKS...: serial once, then each rank count.
decode_and_compare() {
    local tlod=$1 label=$2; shift 2
    "$tetlod" -q decode "$tlod" "serial_$label.h5:/volume" || fail "serial decode of $tlod"
    for n in "$@"; do
        run_mpi "$n" -q decode "$tlod" "mpi${n}_$label.h5:/volume" || fail "mpirun -n $n tetlod-mpi decode $tlod"
        same_dataset "serial_$label.h5" "mpi${n}_$label.h5" || fail "$label: -n $n differs from the serial dataset"
        echo "ok: $label, -n $n: same dataset as tetlod decode"
    done
}

# only FILES...: the folder holds exactly these (no temporary file left).
only() {
    local want have
    want=$(printf '%s\n' "$@" | sort) have=$(ls -A | sort)
    [ "$want" = "$have" ] || fail "files: expected [$(echo $want)], found [$(echo $have)]"
}

case "$case_name" in
awkward)
    make_tlod multiscale 13,7,5 u8 u8
    decode_and_compare u8.tlod u8 1 2 4
    make_tlod noisy 37,29,41 f32 f32
    decode_and_compare f32.tlod f32 1 2 4
    make_tlod multiscale 19,11,70 i16 i16
    decode_and_compare i16.tlod i16 1 2 3 4
    # More ranks than rows of bricks (3 planes, one row): ranks 0..2 hold no
    # plane and join the collective writes with empty selections.
    make_tlod sphere 13,11,3 u8 thin
    decode_and_compare thin.tlod thin 4
    # Small rows (--brick-log2 1: rows of 4 planes), 3 ranks on 41 planes.
    "$tetlod" -q sample noisy b1.raw --dims 21,9,41 --dtype u8 || fail "sample b1"
    "$tetlod" -q convert b1.raw b1.tlod --dims 21,9,41 --dtype u8 --brick-log2 1 || fail "convert b1"
    decode_and_compare b1.tlod b1 3
    # A padded container (--pad: the HT's box is 65^3, the volume 37x29x41),
    # f64, 5 ranks on 2 rows of bricks.
    "$tetlod" -q sample noisy pad.raw --dims 37,29,41 --dtype f64 || fail "sample pad"
    "$tetlod" -q convert pad.raw pad.tlod --dims 37,29,41 --dtype f64 --pad || fail "convert --pad"
    decode_and_compare pad.tlod pad 5
    # FILE.h5 alone: the serial default /volume.
    run_mpi 2 -q decode u8.tlod plain.h5 || fail "decode to plain.h5"
    same_dataset serial_u8.h5 plain.h5 || fail "FILE.h5 alone differs"
    echo "ok: FILE.h5 alone writes /volume"
    ;;
keep)
    make_tlod multiscale 23,17,37 u8 v
    "$tetlod" -q sample sphere other.raw --dims 5,6,7 --dtype i16 || fail "sample other"
    "$tetlod" -q decode other.raw f.h5:/group/other --dims 5,6,7 --dtype i16 || fail "decode other"
    cp f.h5 before.h5
    "$tetlod" -q decode v.tlod serial.h5:/volume || fail "serial decode"
    run_mpi 3 -q decode v.tlod f.h5:/volume || fail "decode into an existing file"
    same_dataset before.h5 f.h5 /group/other || fail "the other dataset changed"
    same_dataset serial.h5 f.h5 || fail "the decoded dataset differs"
    echo "ok: -n 3 into an existing file: /group/other kept, /volume as serial"
    # A new dataset in a new group of that file, then both kept.
    run_mpi 2 -q decode v.tlod f.h5:/run2/volume || fail "decode to /run2/volume"
    same_dataset before.h5 f.h5 /group/other && same_dataset serial.h5 f.h5 /volume || fail "earlier datasets changed"
    "$tetlod" -q decode v.tlod serial.h5:/run2/volume || fail "serial decode to /run2/volume"
    same_dataset serial.h5 f.h5 /run2/volume || fail "/run2/volume differs"
    echo "ok: -n 2 to /run2/volume: every other dataset kept"
    # An existing dataset is refused without -f (exit 2, the file untouched)...
    cp f.h5 now.h5
    run_mpi 2 decode v.tlod f.h5:/volume 2> err.txt
    code=$?
    [ "$code" -eq 2 ] && cmp -s f.h5 now.h5 || fail "existing dataset without -f: exit $code: $(cat err.txt)"
    grep -q "f.h5" err.txt && grep -q -- "--force" err.txt || fail "existing dataset: message: $(cat err.txt)"
    echo "ok: existing dataset refused without -f: exit 2: $(head -1 err.txt)"; rm -f err.txt now.h5
    # ... and replaced with it (the tetlod -f decode result, others kept).
    make_tlod noisy 23,17,37 f32 w
    run_mpi 4 -q -f decode w.tlod f.h5:/volume || fail "-f"
    "$tetlod" -q -f decode w.tlod serial.h5:/volume || fail "serial -f"
    same_dataset serial.h5 f.h5 && same_dataset before.h5 f.h5 /group/other || fail "-f result differs"
    echo "ok: -f replaces the dataset (u8 by f32), the others kept"
    # A group is never replaced, even with -f; an existing non-HDF5 file only with -f.
    run_mpi 2 -f decode v.tlod f.h5:/group 2> err.txt
    code=$?
    [ "$code" -eq 2 ] || fail "group: exit $code: $(cat err.txt)"
    echo "ok: a group is never replaced: exit 2: $(head -1 err.txt)"
    echo text > text.h5
    run_mpi 2 decode v.tlod text.h5:/volume 2> err.txt
    code=$?
    [ "$code" -eq 2 ] && [ "$(cat text.h5)" = text ] || fail "non-HDF5 file without -f: exit $code: $(cat err.txt)"
    echo "ok: a non-HDF5 file is kept without -f: exit 2"
    rm -f err.txt
    only before.h5 f.h5 other.raw serial.h5 text.h5 v.tlod w.tlod
    ;;
failures)
    make_tlod multiscale 40,30,70 u8 s
    "$tetlod" -q sample sphere other.raw --dims 5,6,7 --dtype u8 || fail "sample other"
    "$tetlod" -q decode other.raw f.h5:/other --dims 5,6,7 --dtype u8 || fail "decode other"
    cp f.h5 before.h5
    # A corrupt chunk: the last HT_FIELD section (cycle 0, the last bricks:
    # decoded by the last rank only) or the first (the coarsest cycle, which
    # every rank decodes). Every rank ends, the existing file is untouched and
    # no temporary file is left.
    for spec in "2 last" "4 last" "3 first"; do
        set -- $spec
        corrupt_field_section "$2" s.tlod bad.tlod
        run_mpi "$1" decode bad.tlod f.h5:/volume 2> err.txt
        code=$?
        [ "$code" -eq 4 ] || fail "corrupt $2 chunk, -n $1: exit $code, expected 4: $(cat err.txt)"
        grep -q "bad.tlod" err.txt || fail "corrupt $2 chunk, -n $1: message: $(cat err.txt)"
        cmp -s f.h5 before.h5 || fail "corrupt $2 chunk, -n $1: f.h5 changed"
        echo "ok: corrupt $2 chunk, -n $1: exit 4: $(head -1 err.txt)"
        rm -f err.txt bad.tlod
        only before.h5 f.h5 other.raw s.tlod
    done
    # A corrupt header: every rank refuses to open it.
    cp s.tlod bad.tlod
    printf '\x00\x00\x00\x00' | dd of=bad.tlod bs=1 seek=8 conv=notrunc status=none
    run_mpi 3 decode bad.tlod new.h5:/volume 2> err.txt
    code=$?
    [ "$code" -ne 0 ] && grep -q "bad.tlod" err.txt || fail "corrupt header: exit $code: $(cat err.txt)"
    echo "ok: corrupt header, -n 3: exit $code: $(head -1 err.txt)"
    rm -f err.txt bad.tlod
    only before.h5 f.h5 other.raw s.tlod
    # A rank failing while it decodes (rank 1 of 2, rank 3 of 4, rank 0 of 4).
    for spec in "2 1" "4 3" "4 0"; do
        set -- $spec
        TETLOD_MPI_TEST_FAIL_RANK=$2 TETLOD_MPI_TEST_FAIL_PHASE=decode run_mpi "$1" decode s.tlod f.h5:/volume 2> err.txt
        code=$?
        [ "$code" -eq 3 ] || fail "rank $2 of $1 failing: exit $code, expected 3: $(cat err.txt)"
        grep -q "s.tlod" err.txt && grep -q "injected" err.txt || fail "rank $2 of $1: message: $(cat err.txt)"
        if [ "$2" -ne 0 ]; then grep -q "rank $2" err.txt || fail "rank $2 of $1: no rank named: $(cat err.txt)"; fi
        cmp -s f.h5 before.h5 || fail "rank $2 of $1 failing: f.h5 changed"
        echo "ok: rank $2 of $1 fails to decode: exit 3: $(head -1 err.txt)"; rm -f err.txt
        only before.h5 f.h5 other.raw s.tlod
    done
    # A missing container (exit 3), an output that is not HDF5 (exit 2), a
    # missing folder (exit 3).
    run_mpi 2 decode missing.tlod out.h5:/volume 2> err.txt
    code=$?
    [ "$code" -eq 3 ] && grep -q "missing.tlod" err.txt || fail "missing container: exit $code: $(cat err.txt)"
    echo "ok: missing container: exit 3: $(head -1 err.txt)"
    run_mpi 2 decode s.tlod out.nrrd 2> err.txt
    code=$?
    [ "$code" -eq 2 ] && grep -q "out.nrrd" err.txt || fail "not HDF5 output: exit $code: $(cat err.txt)"
    echo "ok: output not HDF5: exit 2: $(head -1 err.txt)"
    run_mpi 2 decode s.tlod nodir/out.h5:/volume 2> err.txt
    code=$?
    [ "$code" -eq 3 ] && grep -q "nodir/out.h5" err.txt || fail "missing folder: exit $code: $(cat err.txt)"
    echo "ok: missing folder: exit 3: $(head -1 err.txt)"
    rm -f err.txt
    only before.h5 f.h5 other.raw s.tlod
    ;;
*) fail "unknown case $case_name" ;;
esac
echo "PASS: $case_name"
