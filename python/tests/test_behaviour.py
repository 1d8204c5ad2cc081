"""Bad input, the GIL, Ctrl-C, progress, and solve()."""

import json
import os
import signal
import subprocess
import threading
import time

import pytest

import impactmc

FLOOR = """
name = "floor"
samples = 1000
seed = 1
laws = ["newton"]
[body]
semi_axes = [1.0, 1.0, 2.0]
mass = 500.0
[[planes]]
name = "floor"
normal = [0.0, 0.0, 1.0]
offset = 0.0
restitution = 0.8
[placement]
touching = ["floor"]
[orientation]
distribution = "uniform"
[velocity]
distribution = "normal"
mean = [0.0, 0.0, -1.0]
sd = [0.5, 0.5, 0.5]
[angular_velocity]
distribution = "normal"
mean = [0.0, 0.0, 0.0]
sd = [1.0, 1.0, 1.0]
"""


def test_a_scene_from_text_and_from_a_dict():
    s = impactmc.Scene.from_str(FLOOR)
    assert s.name == "floor"
    assert "effects:" in s.effects and "kernel:" in s.kernel
    d = impactmc.Scene.from_dict(s.to_dict())
    assert d.to_dict() == s.to_dict()
    assert s.to_dict()["body"]["mass"] == 500.0
    a = s.run(progress=False).summary
    b = d.run(progress=False).summary
    assert a["laws"] == b["laws"]
    assert "Scene(" in repr(s)
    # At the prompt a result shows what it is, then the CLI's summary.
    result = s.run(progress=False)
    assert str(result) == result.text
    head, text = repr(result).split("\n", 1)
    assert head.startswith("Result(scene=\"floor\", points=1, samples=1000, in memory")
    assert text == result.text.rstrip() and "[newton]" in text


@pytest.mark.parametrize(
    "fields,field,words",
    [
        ({"body": {"mass": -1.0}}, "body.mass", "-1"),
        ({"planes": [{"name": "floor", "normal": [0.0, 0.0, 0.0], "offset": 0.0, "restitution": 0.8}]},
         "normal", "normal"),
        ({"laws": ["nonsense"]}, "laws", "nonsense"),
        ({"unknown_field": 1}, "unknown_field", "unknown"),
        ({"body.semi_axes": [1.0, float("nan"), 2.0]}, "semi_axes", ""),
    ],
)
def test_bad_input_raises_input_error_naming_the_field(fields, field, words):
    s = impactmc.Scene.from_str(FLOOR)
    with pytest.raises(impactmc.InputError) as e:
        s.replace(**fields)
    assert isinstance(e.value, ValueError)
    assert field in (e.value.field or "") or field in str(e.value), (e.value.field, str(e.value))
    assert words in str(e.value)


def test_solve_of_a_missing_file_raises_file_not_found(tmp_path):
    with pytest.raises(FileNotFoundError):
        impactmc.solve(str(tmp_path / "typo.toml"))


def test_replace_takes_a_sweep_s_paths():
    """A plane by name, as a sweep addresses it, and by index."""
    s = impactmc.Scene.from_str(FLOOR)
    by_name = s.replace(**{"planes.floor.restitution": 0.3})
    assert "restitution = 0.3" in by_name.toml
    by_index = s.replace(**{"planes[0].restitution": 0.4})
    assert "restitution = 0.4" in by_index.toml
    with pytest.raises(impactmc.InputError):
        s.replace(**{"planes.ceiling.restitution": 0.3})


def test_input_error_has_the_cli_message_and_line(cli, tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(FLOOR.replace("restitution = 0.8", "restitution = 1.8"))
    with pytest.raises(impactmc.InputError) as e:
        impactmc.Scene.from_toml(path)
    err = e.value
    assert err.file == str(path) and err.line == FLOOR.splitlines().index("restitution = 0.8") + 1
    assert "restitution" in err.field
    done = subprocess.run([cli, "run", str(path)], capture_output=True, text=True)
    assert done.returncode == 2
    assert str(err) in done.stderr


def test_bad_run_arguments():
    s = impactmc.Scene.from_str(FLOOR)
    with pytest.raises(impactmc.InputError, match="shard"):
        s.run(shard="3/2", progress=False)
    with pytest.raises(impactmc.InputError):
        s.run(per_sample=True, columns=["no_such_column"], progress=False)
    with pytest.raises(impactmc.InputError):
        s.run(out="/proc/impactmc-cannot-write-here", progress=False)


def test_the_run_releases_the_gil():
    s = impactmc.Scene.from_str(FLOOR)
    ticks = 0
    stop = threading.Event()

    def count():
        nonlocal ticks
        while not stop.is_set():
            ticks += 1
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    start = ticks
    t0 = time.perf_counter()
    s.run(samples=40_000_000, threads=2, progress=False)
    elapsed = time.perf_counter() - t0
    stop.set()
    t.join()
    # The counter thread ran throughout the run (at ~1 kHz).
    assert elapsed > 0.05
    assert ticks - start > 0.3 * elapsed * 1000 * 0.1


def test_progress_reaches_the_callback():
    s = impactmc.Scene.from_str(FLOOR)
    seen = []
    s.run(samples=100_000_000, progress=lambda done, total: seen.append((done, total)))
    assert seen, "no progress reported"
    assert all(total == 100_000_000 for _, total in seen)
    dones = [d for d, _ in seen]
    assert dones == sorted(dones)
    # The last call comes when the run has ended.
    assert seen[-1] == (100_000_000, 100_000_000)


def test_an_exception_in_the_callback_stops_the_run():
    s = impactmc.Scene.from_str(FLOOR)

    def fail(done, total):
        raise RuntimeError("stop here")

    t0 = time.perf_counter()
    with pytest.raises(RuntimeError, match="stop here"):
        s.run(samples=2_000_000_000, progress=fail)
    assert time.perf_counter() - t0 < 5


def test_ctrl_c_stops_a_run_within_about_a_second():
    s = impactmc.Scene.from_str(FLOOR)
    timer = threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    t0 = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        # About a minute of work on two cores.
        s.run(samples=10_000_000_000, progress=False)
    assert time.perf_counter() - t0 < 2.0


def test_ctrl_c_stops_the_accuracy_ladder_at_the_end_of_a_step(repo, tmp_path):
    # 20 steps, none over about a second but the last (about 25 s on two
    # cores): about half a minute in all.
    scene = impactmc.Scene.from_toml(repo / "configs/accuracy_corner3.toml").replace(
        accuracy={"samples": 200, "sample_counts": [1000, 3_000_000_000]}
    )
    seen = []
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    t0 = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        impactmc.accuracy(scene, out=tmp_path / "acc", progress=lambda *c: seen.append(c))
    # Within a step or two of the signal (with room for a loaded machine),
    # long before the end; a ladder that had ended would have written its
    # folder.
    assert time.perf_counter() - t0 < 8.0
    assert not seen or seen[-1][0] < seen[-1][1]
    assert list((tmp_path / "acc").iterdir()) == []


def test_solve_equals_the_cli(repo, cli):
    path = repo / "configs/paper_example.json"
    want = json.loads(subprocess.run([cli, "solve", str(path)], check=True,
                                     capture_output=True, text=True).stdout)
    assert impactmc.solve(path) == want
    assert impactmc.solve(str(path)) == want
    case = json.loads(path.read_text())
    assert impactmc.solve(case) == want
    assert impactmc.solve(json.dumps(case)) == want
    case["body"]["mass"] = -2.0
    with pytest.raises(impactmc.InputError) as e:
        impactmc.solve(case)
    assert e.value.field and "mass" in e.value.field
