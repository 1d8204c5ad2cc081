#!/usr/bin/env bash
# The "now" table of the README and docs/performance.md, measured on the
# machine it runs on: end to end, two threads, summary statistics only (and
# one per-sample export), SERIES interleaved series, medians; a drop row
# also gives its lanes' pose evaluations per flight and per sample (the
# summary's lane_search, the same in every series). Prints the table as
# Markdown, headed by the date, the version and commit, the CPU
# model and its SIMD flags; progress goes to stderr.
#
# usage: bash benches/now.sh [SERIES] [SCRATCH_DIR]
series=${1:-3}
# shellcheck source=benches/lib.sh
source "$(dirname "$0")/lib.sh" "${2:-/tmp/impactmc-now}"

# Each row: LABEL|SCENE|LAW|PRECISION|SAMPLES|EXTRA FLAGS
rows=(
    "S1 \`floor\`|configs/floor.toml|newton|f32|200000000|"
    "S1 \`floor\`|configs/floor.toml|newton|f64|100000000|"
    "S3 \`corner3\`|configs/corner3.toml|newton|f32|200000000|"
    "S3 \`corner3\`|configs/corner3.toml|newton|f64|100000000|"
    "S3 \`corner3\`, \`--sampling rqmc\` (its default 10⁷ samples: 16 × 2²⁰)|configs/corner3.toml|newton|f32|10000000|--sampling rqmc"
    "\`drop_corner\`, 5 impacts|configs/drop_corner.toml|newton|f32|600000|"
    "\`drop_corner\`, 5 impacts|configs/drop_corner.toml|newton|f64|400000|"
    "\`drop_corner\`, first impact only (\`bounces = 1\`)|$out/drop_corner_1.toml|newton|f32|2000000|"
    "\`floor_friction\`, μ = 0.5|configs/floor_friction.toml|newton|f32|40000000|"
    "S3 \`corner3_friction\`, μ = 0.3 on every wall|configs/corner3_friction.toml|newton|f32|400000|"
    "S3 \`corner3_friction\`, μ = 0.3 on every wall|configs/corner3_friction.toml|newton|f64|400000|"
    "S3 \`corner3\` with \`--per-sample\` (every column; rows/s, whole command)|configs/corner3.toml|newton|f32|4000000|--per-sample"
)

# samples/s of one run: SCENE LAW PRECISION SAMPLES [FLAGS...]
rate() {
    local scene=$1 law=$2 precision=$3 samples=$4
    shift 4
    rm -rf "$out/run"
    local t0 t1
    t0=$(date +%s.%N)
    "$bin" run "$scene" --law "$law" --precision "$precision" --samples "$samples" \
        --threads "$threads" --format json --out "$out/run" --force "$@" \
        > "$out/summary.json" 2> /dev/null
    t1=$(date +%s.%N)
    if [[ " $* " == *" --per-sample "* ]]; then
        # With export the rate is the wall time of the whole command, so
        # that writing and renaming the file count.
        awk -v n="$samples" -v a="$t0" -v b="$t1" 'BEGIN { printf "%.6e\n", n / (b - a) }'
    else
        python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["throughput"]["samples_per_second"])' \
            "$out/summary.json"
    fi
}

: > "$out/rates"
: > "$out/gains"
: > "$out/poses"
for s in $(seq "$series"); do
    for i in "${!rows[@]}"; do
        IFS='|' read -r label scene law precision samples flags <<< "${rows[$i]}"
        # shellcheck disable=SC2086
        r=$(rate "$scene" "$law" "$precision" "$samples" $flags)
        echo "$i $r" >> "$out/rates"
        # An RQMC row's gain on the mean energy ratio, as the run reports it.
        python3 -c 'import json,sys; s=json.load(open(sys.argv[1])); g=s["laws"][sys.argv[2]]["groups"]["all"]["stats"]["energy_ratio"].get("gain"); print(sys.argv[3], g) if g else None' \
            "$out/summary.json" "$law" "$i" >> "$out/gains"
        # A drop row's pose evaluations per flight and per sample.
        python3 -c 'import json,sys; d=json.load(open(sys.argv[1])).get("drops", {}).get(sys.argv[2]); q=d and d["lane_search"]; print(sys.argv[3], q["poses_per_flight"], q["poses_per_sample"]) if q and q["poses_per_flight"] else None' \
            "$out/summary.json" "$law" "$i" >> "$out/poses"
        echo "series $s: $label $precision: $r /s" >&2
    done
done

describe_machine
printf '%s\n' "${rows[@]}" > "$out/rows"
python3 - "$out/rows" "$out/rates" "$out/gains" "$out/poses" "$series" "$threads" "$cpu" "${simd:-none}" "$version" "$commit" <<'EOF'
import datetime, statistics, sys
rows_path, rates_path, gains_path, poses_path, series, threads, cpu, simd, version, commit = sys.argv[1:]
rows = [l.rstrip("\n").split("|") for l in open(rows_path)]
rates = {}
for line in open(rates_path):
    i, r = line.split()
    rates.setdefault(int(i), []).append(float(r))
gains = {}
for line in open(gains_path):
    i, g = line.split()
    gains.setdefault(int(i), []).append(float(g))
poses = {}
for line in open(poses_path):
    i, per_flight, per_sample = line.split()
    poses[int(i)] = (float(per_flight), float(per_sample))

def sci(x):
    e = len(str(int(x))) - 1 if x >= 1 else 0
    m = x / 10**e
    sup = str(e).translate(str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹"))
    return f"{m:.2f}·10{sup}"

date = datetime.date.today().isoformat()
print(f"Measured {date} by `bash benches/now.sh {series}`: impactmc {version} "
      f"(`{commit}`), {cpu} (SIMD: {simd}), {threads} threads, end to end, "
      f"summary statistics only unless the row says otherwise; the median of "
      f"{series} interleaved series, each run's figure in the last column.")
print()
print("| scene | law | precision | samples/s | each run, same power of ten |")
print("|---|---|---|---|---|")
for i, (label, scene, law, precision, samples, flags) in enumerate(rows):
    rs = rates.get(i, [])
    runs = ", ".join(f"{r / 10 ** (len(str(int(statistics.median(rs)))) - 1):.2f}" for r in rs)
    if i in gains:
        label += f"; the mean energy ratio's reported gain {statistics.median(gains[i]):.0f}"
    if i in poses:
        label += f"; {poses[i][0]:.1f} poses per flight, {poses[i][1]:.1f} per sample"
    print(f"| {label} | {law} | {precision} | {sci(statistics.median(rs))} | {runs} |")
EOF
