"""Shared fixtures: the repository, the command line built beside the
package (``IMPACTMC_BIN``, set by the Rust test that runs this suite), and
the CLI's JSON summary of a scene."""

import json
import os
import pathlib
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def repo() -> pathlib.Path:
    return REPO


@pytest.fixture(scope="session")
def cli() -> str:
    path = os.environ.get("IMPACTMC_BIN")
    if not path:
        target = os.environ.get("CARGO_TARGET_DIR", str(REPO / "target"))
        path = os.path.join(target, "release", "impactmc")
    if not os.path.exists(path):
        pytest.fail(f"the command line is not built: {path} (cargo build --release)")
    return path


def strip_timing(value):
    """A summary without what depends on the machine and the thread count."""
    if isinstance(value, dict):
        return {
            k: strip_timing(v)
            for k, v in value.items()
            if k not in ("throughput", "threads")
        }
    if isinstance(value, list):
        return [strip_timing(v) for v in value]
    return value


@pytest.fixture(scope="session")
def cli_summary(cli, tmp_path_factory):
    """The CLI's ``--format json`` summary of a run, without timing."""

    def run(scene: str, *args: str) -> dict:
        out = tmp_path_factory.mktemp("cli")
        done = subprocess.run(
            [cli, "run", scene, *args, "--format", "json", "--out", str(out), "--force"],
            check=True,
            capture_output=True,
            text=True,
        )
        return strip_timing(json.loads(done.stdout))

    return run
