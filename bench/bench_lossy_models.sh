#!/usr/bin/env bash
# Lossless against lossy containers holding both models (docs/archival.md, "Lossy
# containers with the MT"): for each real volume, `tetlod convert --model ht,mt`
# without and with `--max-error PCT`, the bytes of the whole file and of each
# model's sections (`info --json`), the convert's wall seconds, and the E stated.
#
#   bench/bench_lossy_models.sh BUILD_DIR [DATA_DIR=../shared/data] [PCT=1%] [WORKDIR=/tmp/tetlod_bench_lossy]
set -euo pipefail
build=$(cd "$1" && pwd) data=$(cd "${2:-../shared/data}" && pwd) pct=${3:-1%} work=${4:-/tmp/tetlod_bench_lossy}
tetlod=$build/tools/tetlod
mkdir -p "$work" && cd "$work"
printf "%-36s %10s %10s %10s %8s | %10s %10s %10s %8s %10s\n" volume total HT MT conv_s "lossy $pct" HT MT conv_s E
for f in bucky_32x32x32_uint8 head_mr_48x62x42_uint8 neghip_64x64x64_uint8 iron_protein_68x68x68_uint8 \
         headsq_64x64x93_int16 m4_total_density_25x22x31_float32; do
    [ -f "$data/$f.raw" ] || { echo "$f: not in $data, skipped"; continue; }
    row=()
    for mode in lossless lossy; do
        extra=()
        [ "$mode" = lossy ] && extra=(--max-error "$pct")
        start=$(date +%s%N)
        "$tetlod" -T 2 -q convert "$data/$f.raw" "$f.$mode.tlod" --model ht,mt -f --no-progress "${extra[@]}"
        seconds=$(awk -v a="$start" -v b="$(date +%s%N)" 'BEGIN { print (b - a) / 1e9 }')
        read -r total ht mt e < <("$tetlod" info --json "$f.$mode.tlod" | python3 -c "
import json, sys
d = json.load(sys.stdin)
m = {x['type']: x['section_bytes'] for x in d['models']}
print(d['file_size'], m.get('HT', 0), m.get('MT', 0), d['max_error'])")
        row+=("$total" "$ht" "$mt" "$(printf %.2f "$seconds")")
        [ "$mode" = lossy ] && row+=("$e")
    done
    printf "%-36s %10s %10s %10s %8s | %10s %10s %10s %8s %10s\n" "$f" "${row[@]}"
done
