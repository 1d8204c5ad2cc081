"""Recomputes a sweep's paired difference of the mean energy ratio from its
samples.parquet, with polars alone, and checks the run's summary against it.
Called by tests/it/paired_points.rs.

The mean energy ratio of a point is a ratio of sums over the impacting
samples, R = sum(x w) / sum(w) (w = impacted_LAW). Every point runs the
same samples, so the rows pair by `sample`:

- MC: the per-sample linearised terms u = (x - R) w / mean(w) give
  R1 - R0 - delta ~ mean(u1 - u0), so the paired half-width is
  t(N - 1) s(u1 - u0) / sqrt(N) over the N samples. The run's interval
  comes from clusters of samples, not from single samples: it must agree
  to the noise of a variance estimate from its clusters (a few percent).
- RQMC: per replicate, R of each point; the half-width is Student t over
  the R paired replicate differences, which is what the run computes, so
  it must agree to rounding.

usage: check_paired.py SAMPLES_PARQUET SUMMARY_JSON LAW POINT
prints the two half-widths; exits 1 on a disagreement.
"""
import json
import math
import sys

import polars as pl
import pyarrow.parquet as pq

# scipy.stats.t.ppf(0.975, 15)
T975_15 = 2.131449545559323


def main():
    path, summary_path, law, point = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
    summary = json.load(open(summary_path))
    pair = summary["points"][point]["summary"]["paired_points"]
    reference = pair["reference_point"]
    got = pair["laws"][law]["energy_ratio"]
    x, w = f"energy_ratio_{law}", f"impacted_{law}"
    # Read by pyarrow, computed in polars: both readers see the same file.
    rows = pl.from_arrow(pq.read_table(path, columns=["point", "sample", x, w] + (
        ["replicate"] if pair["method"] == "replicates" else [])))
    assert rows.equals(pl.read_parquet(path, columns=rows.columns)), "pyarrow and polars differ"
    rows = rows.filter(pl.col("point").is_in([reference, point])).with_columns(
        pl.col(w).cast(pl.Float64).alias("w"),
        pl.when(pl.col(w)).then(pl.col(x)).otherwise(0.0).alias("xw"),
    )
    ratios = rows.group_by("point").agg(
        (pl.col("xw").sum() / pl.col("w").sum()).alias("R"), pl.col("w").mean().alias("wbar")
    )
    r = {p: (R, wbar) for p, R, wbar in ratios.iter_rows()}
    difference = r[point][0] - r[reference][0]
    if pair["method"] == "clusters":
        u = rows.with_columns(
            ((pl.col("xw") - pl.col("point").replace_strict(
                {p: v[0] for p, v in r.items()}) * pl.col("w"))
             / pl.col("point").replace_strict({p: v[1] for p, v in r.items()})).alias("u")
        )
        wide = u.filter(pl.col("point") == point).select("sample", pl.col("u").alias("u1")).join(
            u.filter(pl.col("point") == reference).select("sample", pl.col("u").alias("u0")),
            on="sample",
        )
        d = wide.select((pl.col("u1") - pl.col("u0")).alias("d"))["d"]
        n = len(d)
        # Student t with N - 1 dof is the normal quantile to 1e-4 at
        # N >= 10^4.
        want = 1.959963984540054 * d.std() / math.sqrt(n)
        tolerance = 0.05
    else:
        per_rep = rows.group_by("point", "replicate").agg(
            (pl.col("xw").sum() / pl.col("w").sum()).alias("R")
        )
        wide = per_rep.filter(pl.col("point") == point).select("replicate", pl.col("R").alias("R1")).join(
            per_rep.filter(pl.col("point") == reference).select("replicate", pl.col("R").alias("R0")),
            on="replicate",
        )
        d = wide.select((pl.col("R1") - pl.col("R0")).alias("d"))["d"]
        assert len(d) == 16, len(d)
        want = T975_15 * d.std() / math.sqrt(len(d))
        tolerance = 1e-6
    print(f"{pair['method']}: difference {got['difference']} (rows {difference}), "
          f"ci95 {got['ci95']} (rows {want}), unpaired {got['unpaired_ci95']}")
    ok = True
    if abs(got["difference"] - difference) > 1e-9 * max(1.0, abs(difference)):
        print("the difference disagrees with the rows'")
        ok = False
    if abs(got["ci95"] - want) > tolerance * want:
        print(f"the paired ci95 disagrees with the rows' beyond {tolerance:.0e} relative")
        ok = False
    if not got["ci95"] < got["unpaired_ci95"]:
        print("the paired ci95 is not narrower than the unpaired one")
        ok = False
    sys.exit(0 if ok else 1)


main()
