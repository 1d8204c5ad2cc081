#!/usr/bin/env bash
# Per-sample export side by side with the disk, end to end, in one script:
# for each codec, `impactmc run configs/corner3.toml` (Newton and paper, all
# columns, f32, two threads) with --per-sample, then `dd` writing as many
# bytes as samples.parquet holds, then the same run without export, and
# with --columns keeping a quarter of the float columns.
#
# usage: bash benches/export.sh [ROWS] [SCRATCH_DIR]
# Prints one line per codec: rows/s, seconds, file size, the disk's seconds
# for those bytes, and the ratios; peak RSS from /usr/bin/time.
set -euo pipefail
cd "$(dirname "$0")/.."
rows=${1:-4000000}
out=${2:-/tmp/impactmc-export}
threads=${THREADS:-2}
mkdir -p "$out"
cargo build --release --quiet
bin=target/release/impactmc

# seconds and peak RSS (KB) of a command, from /usr/bin/time
timed() {
    /usr/bin/time -f "%e %M" -o "$out/time" "$@" > /dev/null 2>&1
    cat "$out/time"
}

plain=$(timed "$bin" run configs/corner3.toml --samples "$rows" --precision f32 \
    --threads "$threads" --format json --out "$out/plain" --force)
echo "no export: ${plain% *} s, peak RSS ${plain#* } KB ($rows samples, $threads threads)"
for codec in zstd lz4 none; do
    scene="$out/corner3-$codec.toml"
    { cat configs/corner3.toml; printf '\n[output]\ncompression = "%s"\n' "$codec"; } > "$scene"
    run=$(timed "$bin" run "$scene" --samples "$rows" --precision f32 --per-sample \
        --threads "$threads" --format json --out "$out/run-$codec" --force)
    secs=${run% *}
    rss=${run#* }
    bytes=$(stat -c %s "$out/run-$codec/samples.parquet")
    blocks=$(( (bytes + 16777215) / 16777216 ))
    disk=$(timed dd if=/dev/zero of="$out/dd" bs=16M count="$blocks" conv=fdatasync)
    disk=${disk% *}
    rm -f "$out/dd"
    # A quarter of the float columns (and the key).
    cols="v_x,v_y,v_z,omega_x,omega_y,omega_z,energy_before,energy_ratio_newton,energy_ratio_paper,impulse_newton_floor,impulse_paper_floor"
    part=$(timed "$bin" run "$scene" --samples "$rows" --precision f32 --per-sample \
        --columns "$cols" --threads "$threads" --format json --out "$out/cols-$codec" --force)
    awk -v c="$codec" -v n="$rows" -v s="$secs" -v p="${plain% *}" -v b="$bytes" -v d="$disk" \
        -v r="$rss" -v q="${part% *}" 'BEGIN {
        printf "%-4s %.3g rows/s  %.2f s (export %.2f s)  %.0f MB  disk %.2f s  ratio %.2f (export only %.2f)  peak RSS %d MB  11 columns %.2f s\n",
            c, n / s, s, s - p, b / 1e6, d, s / d, (s - p) / d, r / 1024, q }'
    rm -rf "$out/run-$codec" "$out/cols-$codec"
done
