#!/usr/bin/env bash
# Per-sample export side by side with the disk, end to end, in one script.
# For each codec: `impactmc run` of configs/corner3.toml (Newton and paper,
# all 47 columns, f32, two threads) with --per-sample; `dd` writing as many
# bytes as that samples.parquet holds (conv=fdatasync); the same run with
# --columns keeping 11 columns. First, the run without export. With
# BASELINE=path/to/impactmc, that build's export (its default codec) too.
#
# usage: bash benches/export.sh [ROWS] [SCRATCH_DIR]
# Prints one line per run: rows/s, seconds (and the export's share: the
# run's time less the run without export), file size, the disk's seconds
# for those bytes, the ratio of the two, peak RSS. Runs as root drop the
# page cache before each command, so every write starts from the same state.
set -euo pipefail
cd "$(dirname "$0")/.."
rows=${1:-4000000}
out=${2:-/tmp/impactmc-export}
threads=${THREADS:-2}
mkdir -p "$out"
cargo build --release --quiet
bin=target/release/impactmc

settle() {
    sync
    if [ -w /proc/sys/vm/drop_caches ]; then echo 3 > /proc/sys/vm/drop_caches; fi
}

# "seconds peak-RSS-KB" of a command, from /usr/bin/time
timed() {
    settle
    /usr/bin/time -f "%e %M" -o "$out/time" "$@" > /dev/null 2>&1
    cat "$out/time"
}

plain=$(timed "$bin" run configs/corner3.toml --samples "$rows" --precision f32 \
    --threads "$threads" --format json --out "$out/plain" --force)
plain_s=${plain% *}
echo "no export: $plain_s s, peak RSS $(( ${plain#* } / 1024 )) MB ($rows samples, $threads threads)"

# One export: LABEL BINARY SCENE [extra flags]
export_run() {
    local label=$1 binary=$2 scene=$3
    shift 3
    rm -rf "$out/run"
    local run secs bytes disk
    run=$(timed "$binary" run "$scene" --samples "$rows" --precision f32 --per-sample \
        --threads "$threads" --format json --out "$out/run" --force "$@")
    secs=${run% *}
    bytes=$(stat -c %s "$out/run/samples.parquet")
    disk=$(timed dd if=/dev/zero of="$out/dd" bs=16M count=$(( (bytes + 16777215) / 16777216 )) \
        conv=fdatasync)
    rm -f "$out/dd"
    rm -rf "$out/run"
    awk -v l="$label" -v n="$rows" -v s="$secs" -v p="$plain_s" -v b="$bytes" \
        -v d="${disk% *}" -v r="${run#* }" 'BEGIN {
        printf "%-12s %.3g rows/s  %.2f s (export %.2f s)  %4.0f MB  disk %.2f s  ratio %.2f  peak RSS %d MB\n",
            l, n / s, s, s - p, b / 1e6, d, s / d, r / 1024 }'
}

if [ -n "${BASELINE:-}" ]; then
    export_run "baseline" "$BASELINE" configs/corner3.toml
fi
cols="v_x,v_y,v_z,omega_x,omega_y,omega_z,energy_before,energy_ratio_newton,energy_ratio_paper,impulse_newton_floor"
for codec in lz4 zstd none; do
    scene="$out/corner3-$codec.toml"
    { cat configs/corner3.toml; printf '\n[output]\ncompression = "%s"\n' "$codec"; } > "$scene"
    export_run "$codec" "$bin" "$scene"
    export_run "$codec 11 col" "$bin" "$scene" --columns "$cols"
done
