#!/usr/bin/env bash
# Friction side by side with the frictionless scenes, end to end, two
# threads, summary statistics only: S1 without friction and with μ = 0.5
# (configs/floor_friction.toml), S3 without friction and with μ = 0.3 on
# every wall (configs/corner3_friction.toml), and the
# frictionless scenes with the frictional kernel kept (`--keep friction`),
# in SERIES interleaved series. Prints one line per run: the scene, the
# law, the precision, samples/s, the fraction recomputed by the f64
# reference and the extra flags.
#
# usage: bash benches/friction.sh [SERIES] [SCRATCH_DIR]
series=${1:-3}
# shellcheck source=benches/lib.sh
source "$(dirname "$0")/lib.sh" "${2:-/tmp/impactmc-friction}"

# SCENE LAW PRECISION SAMPLES [FLAGS...]
one() {
    "$bin" run "$1" --law "$2" --precision "$3" --samples "$4" --threads "$threads" \
        "${@:5}" --format json --out "$out/run" --force 2>/dev/null |
        python3 -c '
import json, sys
r = json.load(sys.stdin)
rec = r["laws"][sys.argv[2]]["groups"]["all"]["fractions"]["recomputed_f64"]
rate = r["throughput"]["samples_per_second"]
print(f"{sys.argv[1]:<16} {sys.argv[2]:<8} {sys.argv[3]}  {rate:.3e} /s  recomputed {rec:.2e}  {sys.argv[4]}")
' "$(basename "$1" .toml)" "$2" "$3" "${*:5}"
}

for s in $(seq "$series"); do
    echo "# series $s"
    one configs/floor.toml newton f32 100000000
    one configs/floor.toml newton f32 20000000 --keep friction
    one configs/floor_friction.toml newton f32 40000000
    one configs/floor_friction.toml newton f64 20000000
    one configs/floor_friction.toml paper f32 40000000
    one configs/floor_friction.toml stronge f64 40000
    one configs/corner3.toml newton f32 100000000
    one configs/corner3.toml newton f64 50000000
    one configs/corner3.toml newton f32 4000000 --keep friction
    one configs/corner3_friction.toml newton f32 400000
    one configs/corner3_friction.toml newton f64 200000
    one configs/corner3_friction.toml paper f32 10000000
    one configs/corner3_friction.toml pgs8 f32 4000000
done
