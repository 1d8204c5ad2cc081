"""The Python package against the command line, end to end, two threads:

1. S3 (`configs/corner3.toml`, newton, f32, 10^7 samples, summary only):
   the CLI's samples/s against `Scene.run()`'s, in SERIES interleaved
   series. For both, the engine's own figure (`summary.json`'s throughput)
   and, for Python, samples over the wall time of the whole `run()` call
   (validation, threads, the wait and the summary).
2. S3 with `per_sample=True`, 10^7 rows into a polars DataFrame with no
   disk, in a fresh process: the peak resident memory over the table's own
   bytes (`DataFrame.estimated_size()`), both as the process's whole peak
   and as its growth over the interpreter with polars loaded.

Run with the interpreter that has the package (`pip install ./python`):

    python benches/python.py [SERIES] [--bin target/release/impactmc]
"""

import argparse
import json
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

REPO = pathlib.Path(__file__).resolve().parents[1]
SCENE = REPO / "configs/corner3.toml"
SAMPLES = 10_000_000

MEMORY = r"""
import resource, sys
import polars as pl
import impactmc
def rss():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) * 1024
before = rss()
scene = impactmc.Scene.from_toml(sys.argv[1])
rows = scene.run(samples=int(sys.argv[2]), threads=2, per_sample=True, progress=False).samples()
df = rows.to_polars()
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(df.estimated_size(), before, peak, df.height)
"""


def cli(binary: str) -> float:
    with tempfile.TemporaryDirectory() as out:
        done = subprocess.run(
            [binary, "run", str(SCENE), "--law", "newton", "--precision", "f32",
             "--samples", str(SAMPLES), "--threads", "2", "--format", "json",
             "--out", out, "--force"],
            check=True, capture_output=True, text=True,
        )
    return json.loads(done.stdout)["throughput"]["samples_per_second"]


def python() -> tuple:
    import impactmc

    scene = impactmc.Scene.from_toml(SCENE).replace(laws=["newton"], precision="f32")
    t0 = time.perf_counter()
    result = scene.run(samples=SAMPLES, threads=2, progress=False)
    wall = time.perf_counter() - t0
    return result.summary["throughput"]["samples_per_second"], SAMPLES / wall


def main() -> None:
    args = argparse.ArgumentParser()
    args.add_argument("series", nargs="?", type=int, default=3)
    args.add_argument("--bin", default=str(REPO / "target/release/impactmc"))
    opts = args.parse_args()
    rows = {"cli": [], "python (engine)": [], "python (whole call)": []}
    for s in range(opts.series):
        rows["cli"].append(cli(opts.bin))
        engine, whole = python()
        rows["python (engine)"].append(engine)
        rows["python (whole call)"].append(whole)
        print(f"series {s + 1}: " + ", ".join(f"{k} {v[-1]:.3e}" for k, v in rows.items()),
              file=sys.stderr)
    base = statistics.median(rows["cli"])
    print(f"S3 newton f32, {SAMPLES:.0e} samples, 2 threads, median of {opts.series} "
          "interleaved series:")
    print("| run | samples/s | against the CLI | each series |")
    print("|---|---|---|---|")
    for k, v in rows.items():
        m = statistics.median(v)
        each = ", ".join(f"{x:.3e}" for x in v)
        print(f"| {k} | {m:.3e} | {m / base - 1:+.1%} | {each} |")
    done = subprocess.run(
        [sys.executable, "-c", MEMORY, str(SCENE), str(SAMPLES)],
        check=True, capture_output=True, text=True,
    )
    table, before, peak, height = map(int, done.stdout.split())
    print(f"\nper_sample=True, {height:,} rows into polars, no disk: the table "
          f"{table / 2**30:.2f} GiB; peak RSS {peak / 2**30:.2f} GiB = "
          f"{peak / table:.2f}x the table; growth over the interpreter with "
          f"polars loaded ({before / 2**20:.0f} MiB) {(peak - before) / table:.2f}x")


if __name__ == "__main__":
    main()
