#!/usr/bin/env bash
# Speed-up of tetlod-mpi (docs/distributed.md §2): `tetlod convert` and
# `mpirun -n 1|2 tetlod-mpi convert` on a generated volume, alternated, with
# threads (--bind-to none) and at one core per rank (--bind-to core),
# REPEAT times each; prints every run (wall, user CPU of the job), the minimum
# of each, the speed-up of -n 2 over -n 1 and over the serial tool, the load
# (uptime) before each run, the bytes each rank read, sent and wrote (-v), and checks
# that every container is byte-identical to the serial one.
# Then the same for decoding that container to HDF5: `tetlod decode` against
# `mpirun -n 1|2 --bind-to core tetlod-mpi decode` (a new file each run), each
# dataset checked against the serial one (h5dump's binary dump of the values).
#
# Then (WHAT=extract) extraction of a uniform and a box mesh from it: `tetlod
# extract` against `mpirun -n 1|2 --bind-to core tetlod-mpi extract`, each
# file checked with cmp against the serial one, with each rank's peak RSS.
#
#   bench/bench_mpi.sh BUILD_DIR [SIZE=513] [REPEAT=2] [WORKDIR=/tmp/tetlod_bench_mpi] [WHAT=convert,decode]
set -euo pipefail
build=$(cd "$1" && pwd) size=${2:-513} repeat=${3:-2} work=${4:-/tmp/tetlod_bench_mpi} what=${5:-convert,decode}
tetlod=$build/tools/tetlod tetlod_mpi=$build/mpi/tetlod-mpi
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl=self,vader OMPI_MCA_plm_rsh_agent=false
export SOURCE_DATE_EPOCH=0
mkdir -p "$work" && cd "$work"
if [ ! -f "ms$size.h5" ]; then
    "$tetlod" -q sample multiscale "ms$size.raw" --size "$size"
    "$tetlod" -q decode "ms$size.raw" "ms$size.h5:/volume" --dims "$size,$size,$size" --dtype u8
    rm -f "ms$size.raw"
fi
in="ms$size.h5:/volume"

best() { sort -g "$1.walls" | head -1; }
# run LABEL CMD...: wall and user CPU (children) seconds into $wall $user.
run() {
    local label=$1; shift
    local load; load=$(uptime | sed 's/.*load average: //')
    local t0 t1 u; t0=$(date +%s.%N)
    /usr/bin/time -f '%U %M' -o "$label.time" "$@" > /dev/null 2> "$label.err" || { cat "$label.err"; exit 1; }
    t1=$(date +%s.%N)
    u=$(tail -1 "$label.time" | cut -d' ' -f1) rss=$(tail -1 "$label.time" | cut -d' ' -f2)
    wall=$(echo "$t1 - $t0" | bc -l)
    printf '%-8s wall %7.2f s  user CPU (all processes) %7.2f s  largest peak RSS %5d MB  load before: %s\n' \
        "$label" "$wall" "$u" "$((rss / 1024))" "$load"
    echo "$wall" >> "$label.walls"
}
if [[ $what == *convert* ]]; then
rm -f serial.walls n1.walls n2.walls n1c.walls n2c.walls
for i in $(seq "$repeat"); do
    run serial "$tetlod" -q convert "$in" serial.tlod -f
    run n1 mpirun -n 1 --bind-to none "$tetlod_mpi" -v -f convert "$in" n1.tlod
    run n2 mpirun -n 2 --bind-to none "$tetlod_mpi" -v -f convert "$in" n2.tlod
    # One core per rank: the strong scaling of the ranks themselves. With
    # threads (above) one rank already keeps both cores of this machine busy.
    run n1c mpirun -n 1 --bind-to core "$tetlod_mpi" -v -f convert "$in" n1c.tlod
    run n2c mpirun -n 2 --bind-to core "$tetlod_mpi" -v -f convert "$in" n2c.tlod
    for f in n1 n2 n1c n2c; do cmp serial.tlod $f.tlod || { echo "FAIL: containers differ ($f)"; exit 1; }; done
done
s=$(best serial) a=$(best n1) b=$(best n2) ac=$(best n1c) bc=$(best n2c)
echo "per rank, last -n 1 run:"; grep -A2 '^rank' n1.err | head -3
echo "per rank, last -n 2 run:"; grep -A3 '^rank' n2.err | head -4
for f in n1 n2; do
    grep -A3 '^rank' "$f.err" | awk -v run="$f" 'NR > 1 && $1 ~ /^[0-9]+$/ {
        printf "%s rank %s: bytes read %s, sent %s, written %s\n", run, $1, $2, $3, $5 }'
done
printf 'minimum wall: serial %.2f s, -n 1 %.2f s, -n 2 %.2f s\n' "$s" "$a" "$b"
printf 'speed-up of -n 2: %.2fx over -n 1, %.2fx over tetlod convert (containers byte-identical)\n' \
    "$(echo "$a / $b" | bc -l)" "$(echo "$s / $b" | bc -l)"
echo "per rank, last -n 2 run at one core per rank:"; grep -A3 '^rank' n2c.err | head -4
printf 'one core per rank (--bind-to core): -n 1 %.2f s, -n 2 %.2f s, speed-up %.2fx\n' \
    "$ac" "$bc" "$(echo "$ac / $bc" | bc -l)"
fi

[ -f serial.tlod ] || "$tetlod" -q convert "$in" serial.tlod
if [[ $what == *extract* ]]; then
lo=$((size * 7 / 16)) hi=$((size * 9 / 16))
for q in "uniform --error 0.5%" "box --error 0 --box $lo,$lo,$lo,$hi,$hi,$hi --error-out 5%"; do
    set -- $q; name=$1; shift
    rm -f "x$name.serial.walls" "x$name.n1.walls" "x$name.n2.walls"
    echo "extract $name: $*"
    for i in $(seq "$repeat"); do
        run "x$name.serial" "$tetlod" -q -f extract serial.tlod "x$name.serial.vtu" "$@"
        run "x$name.n1" mpirun -n 1 --bind-to core "$tetlod_mpi" -v -f extract serial.tlod "x$name.n1.vtu" "$@"
        run "x$name.n2" mpirun -n 2 --bind-to core "$tetlod_mpi" -v -f extract serial.tlod "x$name.n2.vtu" "$@"
        cmp "x$name.serial.vtu" "x$name.n1.vtu" && cmp "x$name.serial.vtu" "x$name.n2.vtu" ||
            { echo "FAIL: meshes differ"; exit 1; }
    done
    echo "per rank, last -n 1 run:"; grep -A1 '^rank' "x$name.n1.err"
    echo "per rank, last -n 2 run:"; grep -A2 '^rank' "x$name.n2.err"
    printf 'extract %s minimum wall: serial %.2f s, -n 1 %.2f s, -n 2 %.2f s (%s bytes, files identical)\n' "$name" \
        "$(best "x$name.serial")" "$(best "x$name.n1")" "$(best "x$name.n2")" "$(stat -c %s "x$name.serial.vtu")"
done
fi

[[ $what == *decode* ]] || exit 0
values() { h5dump -d /volume -b NATIVE -o "$1.bin" "$1" > /dev/null; }
rm -f dserial.walls dn1.walls dn2.walls
for i in $(seq "$repeat"); do
    rm -f dserial.h5 dn1.h5 dn2.h5
    run dserial "$tetlod" -q decode serial.tlod dserial.h5:/volume
    run dn1 mpirun -n 1 --bind-to core "$tetlod_mpi" -v decode serial.tlod dn1.h5:/volume
    run dn2 mpirun -n 2 --bind-to core "$tetlod_mpi" -v decode serial.tlod dn2.h5:/volume
    values dserial.h5 && values dn1.h5 && values dn2.h5
    cmp dserial.h5.bin dn1.h5.bin && cmp dserial.h5.bin dn2.h5.bin || { echo "FAIL: datasets differ"; exit 1; }
    rm -f dserial.h5.bin dn1.h5.bin dn2.h5.bin
done
echo "decode per rank, last -n 1 run:"; grep -A1 '^rank' dn1.err
echo "decode per rank, last -n 2 run:"; grep -A2 '^rank' dn2.err
s=$(best dserial) a=$(best dn1) b=$(best dn2)
printf 'decode minimum wall: serial %.2f s, -n 1 %.2f s, -n 2 %.2f s\n' "$s" "$a" "$b"
printf 'decode speed-up of -n 2: %.2fx over -n 1, %.2fx over tetlod decode (datasets identical)\n' \
    "$(echo "$a / $b" | bc -l)" "$(echo "$s / $b" | bc -l)"
