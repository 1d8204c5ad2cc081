"""A corner study from Python: how the floor's restitution changes which
walls take the blow and how much energy the impact keeps.

Sweeps the floor's restitution of S3 (configs/corner3.toml), keeps every
sample's row in memory (no files), groups the rows with polars by the set
of walls that took an impulse, and draws the energy ratio against the
restitution per set with matplotlib.

    python python/examples/corner_study.py [--samples N] [--out DIR]
"""

import argparse
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import polars as pl  # noqa: E402

import impactmc  # noqa: E402

REPO = pathlib.Path(__file__).resolve().parents[2]
WALLS = ["wall_x", "wall_y", "floor"]


def main() -> None:
    args = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    args.add_argument("--samples", type=int, default=200_000)
    args.add_argument("--out", type=pathlib.Path, default=pathlib.Path("results/corner_study"))
    opts = args.parse_args()

    base = impactmc.Scene.from_toml(REPO / "configs/corner3.toml").replace(laws=["newton"])
    print(base.effects)
    frames = []
    for e in [0.1, 0.3, 0.5, 0.7, 0.9]:
        planes = base.to_dict()["planes"]
        planes[2]["restitution"] = e
        scene = base.replace(planes=planes)
        rows = scene.run(samples=opts.samples, per_sample=True).samples().to_polars()
        frames.append(rows.with_columns(pl.lit(e).alias("restitution_floor")))
    rows = pl.concat(frames)

    # The walls that took an impulse, as a name ("wall_x+floor").
    active = pl.col("active_newton")
    names = [
        pl.when((active & (1 << i)) != 0).then(pl.lit(w)).otherwise(pl.lit(None))
        for i, w in enumerate(WALLS)
    ]
    rows = rows.with_columns(pl.concat_str(names, separator="+", ignore_nulls=True).alias("walls"))
    table = (
        rows.filter(pl.col("walls") != "")
        .group_by("restitution_floor", "walls")
        .agg(
            pl.len().alias("samples"),
            pl.col("energy_ratio_newton").mean().alias("energy_ratio"),
        )
        .sort("restitution_floor", "walls")
    )
    print(table)

    opts.out.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    common = (
        table.group_by("walls").agg(pl.col("samples").sum()).sort("samples", descending=True)
    )
    for walls in common["walls"].head(5):
        part = table.filter(pl.col("walls") == walls)
        ax.plot(part["restitution_floor"], part["energy_ratio"], marker="o", label=walls)
    ax.set_xlabel("restitution of the floor")
    ax.set_ylabel("mean energy ratio T⁺/T⁻ (newton)")
    ax.set_title(f"S3 corner, {opts.samples:,} samples per point")
    ax.legend(title="walls that took the blow", fontsize=8)
    fig.tight_layout()
    path = opts.out / "corner_study.png"
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
