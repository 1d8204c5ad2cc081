"""The package against the command line: the same scenes give the same
summaries, and the per-sample rows equal samples.parquet column by
column."""

import json

import pytest

import impactmc
from conftest import strip_timing

SCENES = [
    # (scene file, samples, extra CLI flags, replace())
    ("configs/floor.toml", 20_000, [], {}),
    ("configs/corner3.toml", 20_000, [], {}),
    ("configs/sweep_aspect_ratio.toml", 2_000, [], {}),
    ("configs/drop_corner.toml", 2_000, [], {}),
    ("configs/floor_friction.toml", 20_000, [], {}),
    ("configs/corner3.toml", 5_000, ["--precision", "f64", "--law", "newton", "--law", "paper"],
     {"precision": "f64", "laws": ["newton", "paper"]}),
    # RQMC: sampling and replicates are scene fields like any other.
    ("configs/corner3.toml", 20_000, ["--sampling", "rqmc", "--replicates", "8"],
     {"sampling": "rqmc", "replicates": 8}),
    ("configs/drop_corner.toml", 2_000, ["--sampling", "rqmc"], {"sampling": "rqmc"}),
]


@pytest.mark.parametrize("path,samples,flags,fields", SCENES)
def test_summary_equals_the_cli(repo, cli_summary, path, samples, flags, fields):
    scene = impactmc.Scene.from_toml(repo / path)
    if fields:
        scene = scene.replace(**fields)
    result = scene.run(samples=samples, threads=2, progress=False)
    want = cli_summary(str(repo / path), "--samples", str(samples), *flags)
    assert strip_timing(result.summary) == want
    assert result.out is None and result.manifest is None


def test_per_sample_rows_equal_the_parquet_file(repo, cli, tmp_path):
    pl = pytest.importorskip("polars")
    import subprocess

    out = tmp_path / "cli"
    subprocess.run(
        [cli, "run", str(repo / "configs/corner3.toml"), "--samples", "30000", "--per-sample",
         "--out", str(out)],
        check=True, capture_output=True,
    )
    want = pl.read_parquet(out / "samples.parquet")
    rows = impactmc.Scene.from_toml(repo / "configs/corner3.toml").run(
        samples=30_000, per_sample=True, progress=False
    ).samples()
    assert rows.num_rows == len(rows) == want.height
    got = rows.to_polars()
    assert got.columns == want.columns
    for name in want.columns:
        assert got[name].equals(want[name]), name


def test_a_folder_is_written_as_the_cli_writes_it(repo, cli_summary, tmp_path):
    scene = impactmc.Scene.from_toml(repo / "configs/corner3.toml")
    out = tmp_path / "run"
    result = scene.run(samples=10_000, out=out, per_sample=True, progress=False)
    assert result.out == str(out)
    files = set(result.manifest["files"])
    assert {"summary.json", "summary.parquet", "samples.parquet"} <= files
    on_disk = json.loads((out / "summary.json").read_text())
    assert strip_timing(on_disk) == strip_timing(result.summary)
    assert strip_timing(on_disk) == cli_summary(str(repo / "configs/corner3.toml"), "--samples",
                                                "10000")
    # The rows come back from the file.
    assert result.samples().num_rows == 10_000
    with pytest.raises(impactmc.OutputExistsError):
        scene.run(samples=1_000, out=out, progress=False)
    with pytest.raises(FileExistsError):
        scene.run(samples=1_000, out=out, progress=False)
    scene.run(samples=1_000, out=out, force=True, progress=False)


def test_tables_read_without_a_copy_where_pyarrow_is(repo):
    pa = pytest.importorskip("pyarrow")
    result = impactmc.Scene.from_toml(repo / "configs/drop_corner.toml").run(
        samples=2_000, progress=False
    )
    assert "summary" in result.table_names and "bounces" in result.table_names
    summary = pa.table(result.table("summary"))
    laws = result.summary["laws"]
    assert sorted(set(summary.column("law").to_pylist())) == sorted(laws)
    with pytest.raises(KeyError, match="summary"):
        result.table("nonsense")
    with pytest.raises(ValueError, match="per_sample"):
        result.samples()


def test_rows_go_into_polars_and_pyarrow_without_a_copy(repo):
    pl = pytest.importorskip("polars")
    pa = pytest.importorskip("pyarrow")
    rows = impactmc.Scene.from_toml(repo / "configs/corner3.toml").run(
        samples=300_000, per_sample=True, progress=False
    ).samples()
    column = "energy_ratio_newton"
    # Two imports of the stream see the same buffers: the run's own.
    first = [c.buffers()[1].address for c in pa.table(rows).column(column).chunks]
    second = [c.buffers()[1].address for c in pa.table(rows).column(column).chunks]
    assert len(first) > 1 and first == second
    # polars keeps them as its chunks (each chunk's export is zero-copy).
    chunks = pl.DataFrame(rows)[column].get_chunks()
    assert [c.to_arrow().buffers()[1].address for c in chunks] == first


def test_duckdb_reads_the_rows(repo):
    duckdb = pytest.importorskip("duckdb")
    rows = impactmc.Scene.from_toml(repo / "configs/floor.toml").run(
        samples=5_000, per_sample=True, progress=False
    ).samples()
    con = duckdb.connect()
    con.register("rows", rows.to_pyarrow())
    (n,) = con.execute("select count(*) from rows").fetchall()[0]
    assert n == 5_000


def test_the_same_seed_gives_the_same_rows_whatever_the_threads(repo):
    scene = impactmc.Scene.from_toml(repo / "configs/corner3.toml")
    a = scene.run(samples=20_000, threads=1, per_sample=True, progress=False)
    b = scene.run(samples=20_000, threads=2, per_sample=True, progress=False)
    assert strip_timing(a.summary) == strip_timing(b.summary)
    assert a.samples().to_polars().equals(b.samples().to_polars())
    c = scene.run(samples=20_000, seed=7, progress=False)
    assert strip_timing(c.summary) != strip_timing(a.summary)


def test_shards_merge_into_the_whole_run(repo, tmp_path):
    scene = impactmc.Scene.from_toml(repo / "configs/floor.toml")
    whole = scene.run(samples=200_000, progress=False).summary
    first = scene.run(samples=200_000, shard=(0, 2), out=tmp_path / "a", progress=False)
    second = scene.run(samples=200_000, shard="1/2", out=tmp_path / "b", progress=False)
    n = lambda s: s["laws"]["newton"]["groups"]["all"]["samples"]
    assert n(first.summary) + n(second.summary) == n(whole)
    seen = []
    merged = impactmc.merge([tmp_path / "b", tmp_path / "a"], tmp_path / "m",
                            progress=lambda *c: seen.append(c))
    assert strip_timing(merged.summary) == strip_timing(whole)
    assert seen[-1] == (2, 2)
    seen = impactmc.inspect(tmp_path / "m")
    assert strip_timing(seen["summary"]) == strip_timing(whole)
    assert seen["manifest"]["merge"] and "floor" in seen["text"]
    with pytest.raises(impactmc.InputError):
        impactmc.inspect(tmp_path / "nothing-here")


def test_a_sweep_gives_one_result_per_point(repo, cli_summary, tmp_path):
    pl = pytest.importorskip("polars")
    path = repo / "configs/sweep_aspect_ratio.toml"
    result = impactmc.Scene.from_toml(path).run(samples=2_000, per_sample=True, progress=False)
    want = cli_summary(str(path), "--samples", "2000")["points"]
    points = result.points
    assert result.values is None
    assert len(points) == len(want) > 1
    rows = result.samples().to_polars()
    summary = result.table("summary").to_polars()
    # The same run written to a folder: its rows come back from the file,
    # in the reader's batches, not the run's.
    folder = impactmc.Scene.from_toml(path).run(samples=2_000, per_sample=True,
                                                out=tmp_path / "run", progress=False)
    for i, (point, on_disk, cli) in enumerate(zip(points, folder.points, want)):
        assert point.values == cli["values"] and point.values
        assert strip_timing(point.summary) == cli["summary"]
        assert point.text.startswith("=== sweep point:") and point.text in result.text
        assert f"point={i}" in repr(point)
        assert len(point.points) == 1 and point.points[0].summary == point.summary
        got = point.samples().to_polars()
        assert got.height == 2_000
        assert got.equals(rows.filter(pl.col("point") == i))
        assert on_disk.samples().to_polars().equals(got)
        assert point.table("summary").to_polars().equals(summary.filter(pl.col("point") == i))
        assert point.out is None and on_disk.out == str(tmp_path / "run")


def test_a_run_without_a_sweep_is_its_one_point(repo):
    pl = pytest.importorskip("polars")
    result = impactmc.Scene.from_toml(repo / "configs/corner3.toml").run(
        samples=5_000, per_sample=True, progress=False
    )
    assert result.values == {}
    (point,) = result.points
    assert point.values == {} and point.summary == result.summary
    assert point.text == result.text.lstrip()
    assert point.samples().to_polars().equals(result.samples().to_polars())


def test_the_accuracy_ladder_writes_the_cli_folder(repo, tmp_path):
    pl = pytest.importorskip("polars")
    scene = impactmc.Scene.from_toml(repo / "configs/accuracy_corner3.toml").replace(
        accuracy={
            "samples": 40,
            "compliant_steps": [12, 25],
            "reference_steps": 100,
            "pgs_sweeps": [1],
            "sample_counts": [1000],
            "timing_samples": 2000,
        }
    )
    seen = []
    md = impactmc.accuracy(scene, out=tmp_path / "acc", progress=lambda *c: seen.append(c))
    assert "| newton |" in md
    # The reference; paper, pgs1, newton, poisson; two compliant rungs;
    # f32; one count. The last count comes when the ladder ends.
    assert seen and seen[-1] == (9, 9)
    table = pl.read_parquet(tmp_path / "acc" / "accuracy.parquet")
    assert table.height > 3
    assert (tmp_path / "acc" / "accuracy.md").read_text().endswith(md[-200:])
    with pytest.raises(impactmc.OutputExistsError):
        impactmc.accuracy(scene, out=tmp_path / "acc")
    with pytest.raises(impactmc.InputError):
        impactmc.accuracy(scene.replace(accuracy={"samples": -3}), out=tmp_path / "bad")
