#!/usr/bin/env bash
# What RQMC buys, end to end, two threads, on the machine it runs on:
#
# 1. The gain over independent seeds: S3 `corner3`, newton, f32, at 16
#    replicates of 2^20 points (16 777 216 samples), SEEDS runs with
#    `--sampling rqmc` and SEEDS with MC at the same sample count. The
#    measured gain is the variance of the MC runs' mean energy ratio over
#    that of the RQMC runs' (an F ratio: with 20 + 20 seeds its 95 % range
#    is about ×/÷ 2.5); beside it, the median of the gains the RQMC runs
#    report themselves, and the same for the three-wall share.
# 2. Throughput side by side: S1 and S3, f32, MC and RQMC, in SERIES
#    interleaved series; medians, and the MC-equivalent rate (throughput ×
#    the energy ratio's gain).
#
# usage: bash benches/rqmc.sh [SEEDS] [SERIES] [SCRATCH_DIR]
seeds=${1:-20}
series=${2:-3}
# shellcheck source=benches/lib.sh
source "$(dirname "$0")/lib.sh" "${3:-/tmp/impactmc-rqmc}"

n=16777216
: > "$out/gain"
for s in $(seq "$seeds"); do
    for m in mc rqmc; do
        "$bin" run configs/corner3.toml --law newton --precision f32 --samples "$n" \
            --seed "$((1000 + s))" --sampling "$m" --threads "$threads" --format json \
            --out "$out/run" --force > "$out/summary.json" 2> /dev/null
        python3 - "$out/summary.json" "$m" >> "$out/gain" <<'EOF'
import json, sys
s = json.load(open(sys.argv[1]))
g = s["laws"]["newton"]["groups"]["all"]
er = g["stats"]["energy_ratio"]
share = "wall_x+wall_y+floor"
print(sys.argv[2], s["samples"], er["mean"], er.get("gain"), g["active_sets"][share],
      (g.get("active_sets_gain") or {}).get(share))
EOF
    done
    echo "seed $s done" >&2
done

rows=(
    "S1 \`floor\`|configs/floor.toml|mc"
    "S1 \`floor\`|configs/floor.toml|rqmc"
    "S3 \`corner3\`|configs/corner3.toml|mc"
    "S3 \`corner3\`|configs/corner3.toml|rqmc"
)
: > "$out/rates"
for s in $(seq "$series"); do
    for i in "${!rows[@]}"; do
        IFS='|' read -r label scene m <<< "${rows[$i]}"
        "$bin" run "$scene" --law newton --precision f32 --samples 200000000 \
            --sampling "$m" --threads "$threads" --format json --out "$out/run" --force \
            > "$out/summary.json" 2> /dev/null
        r=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["throughput"]["samples_per_second"])' "$out/summary.json")
        echo "$i $r" >> "$out/rates"
        echo "series $s: $label $m: $r /s" >&2
    done
done

describe_machine
printf '%s\n' "${rows[@]}" > "$out/rows"
python3 - "$out/gain" "$out/rows" "$out/rates" "$seeds" "$series" "$threads" "$cpu" "${simd:-none}" "$version" "$commit" <<'EOF'
import datetime, statistics, sys
gain_path, rows_path, rates_path, seeds, series, threads, cpu, simd, version, commit = sys.argv[1:]
runs = {"mc": [], "rqmc": []}
for line in open(gain_path):
    m, n, er, g, share, sg = line.split()
    f = lambda x: None if x == "None" else float(x)
    runs[m].append((int(n), float(er), f(g), float(share), f(sg)))
var = lambda xs: statistics.variance(xs)
date = datetime.date.today().isoformat()
print(f"Measured {date} by `bash benches/rqmc.sh {seeds} {series}`: impactmc {version} "
      f"(`{commit}`), {cpu} (SIMD: {simd}), {threads} threads, end to end.")
print()
n = runs["rqmc"][0][0]
print(f"S3 `corner3`, newton, f32, {n} samples (16 replicates of 2^20 points), "
      f"{seeds} seeds of each method:")
print()
print("| statistic | sd of the mean over seeds, MC | sd, RQMC | measured gain (variance ratio) | reported gain, median over the RQMC runs |")
print("|---|---|---|---|---|")
measured = {}
for name, k, kg in [("energy_ratio mean", 1, 2), ("three-wall share", 3, 4)]:
    mc = [r[k] for r in runs["mc"]]
    rq = [r[k] for r in runs["rqmc"]]
    g = var(mc) / var(rq)
    measured[name] = g
    rep = statistics.median(r[kg] for r in runs["rqmc"] if r[kg] is not None)
    print(f"| {name} | {var(mc) ** 0.5:.3e} | {var(rq) ** 0.5:.3e} | {g:.1f} | {rep:.1f} |")
print()
rows = [l.rstrip("\n").split("|") for l in open(rows_path)]
rates = {}
for line in open(rates_path):
    i, r = line.split()
    rates.setdefault(int(i), []).append(float(r))
print(f"Throughput, f32, newton, 2·10⁸ samples requested (RQMC runs 16 × 2^24), "
      f"median of {series} interleaved series:")
print()
print("| scene | sampling | samples/s | each run | RQMC / MC |")
print("|---|---|---|---|---|")
for i, (label, scene, m) in enumerate(rows):
    med = statistics.median(rates[i])
    each = ", ".join(f"{r:.3e}" for r in rates[i])
    ratio = "" if m == "mc" else f"{med / statistics.median(rates[i - 1]):.3f}"
    print(f"| {label} | {m} | {med:.3e} | {each} | {ratio} |")
s3 = statistics.median(rates[3])
print()
print(f"MC-equivalent rate of S3's mean energy ratio with RQMC: {s3:.3e} samples/s × "
      f"measured gain {measured['energy_ratio mean']:.1f} = {s3 * measured['energy_ratio mean']:.2e} samples/s.")
EOF
