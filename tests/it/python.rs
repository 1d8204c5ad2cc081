//! The Python package (python/): its wheel built by maturin into a venv
//! under the target folder, then its pytest suite (python/tests: the same
//! summaries as the command line, the per-sample rows equal to
//! samples.parquet, bad input, the GIL, Ctrl-C and progress) and the worked
//! example (python/examples/corner_study.py, which writes a PNG).
//!
//! The wheel build reuses the main build: it may compile only the pyo3
//! family and the binding crate (impactmc's Cargo.toml asks for the
//! features they switch on in shared crates).
//!
//! Without maturin and pytest the test says so and passes, unless
//! `IMPACTMC_REQUIRE_PYTHON=1` (set by .ci/run), where it fails.

use crate::support;

use std::path::{Path, PathBuf};
use std::process::Command;

use support::repo;

/// Crates the wheel build may compile on top of the main build.
const WHEEL_ONLY: [&str; 7] = [
    "pyo3",
    "pyo3-ffi",
    "pyo3-macros",
    "pyo3-macros-backend",
    "pyo3-build-config",
    "impactmc-python",
    "numpy",
];

fn python_tools_available() -> bool {
    let ok = |args: &[&str]| {
        Command::new("python3")
            .args(args)
            .output()
            .map(|o| o.status.success())
            .unwrap_or(false)
    };
    ok(&["-m", "maturin", "--version"]) && ok(&["-c", "import pytest"])
}

fn target_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo("target"))
}

fn run(cmd: &mut Command, what: &str) -> String {
    let out = cmd
        .output()
        .unwrap_or_else(|e| panic!("{what}: cannot start: {e}"));
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "{what} failed:\n{text}");
    text
}

/// Builds the wheel and installs it into the venv; returns the venv's
/// python.
fn install(target: &Path) -> PathBuf {
    let wheels = target.join("python-wheels");
    let _ = std::fs::remove_dir_all(&wheels);
    let log = run(
        Command::new("python3")
            .args(["-m", "maturin", "build", "--release", "--manifest-path"])
            .arg(repo("python/Cargo.toml"))
            .arg("--out")
            .arg(&wheels)
            .env("CARGO_TARGET_DIR", target),
        "maturin build",
    );
    let compiled: Vec<&str> = log
        .lines()
        .filter_map(|l| l.trim_start().strip_prefix("Compiling "))
        .filter_map(|l| l.split_whitespace().next())
        .collect();
    eprintln!("the wheel build compiled: {compiled:?}");
    let again: Vec<&&str> = compiled
        .iter()
        .filter(|c| !WHEEL_ONLY.contains(c))
        .collect();
    assert!(
        again.is_empty(),
        "the wheel build compiled crates of the main build again (a feature \
         set differs; see Cargo.toml): {again:?}"
    );
    let wheel = std::fs::read_dir(&wheels)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|x| x == "whl"))
        .expect("maturin wrote a wheel");
    let venv = target.join("python-venv");
    let python = venv.join("bin/python");
    if !python.exists() {
        // The test tools (pytest, the readers) come from the system site.
        run(
            Command::new("python3")
                .args(["-m", "venv", "--system-site-packages"])
                .arg(&venv),
            "python3 -m venv",
        );
    }
    run(
        Command::new(&python)
            .args([
                "-m",
                "pip",
                "install",
                "--quiet",
                "--disable-pip-version-check",
                "--no-deps",
                "--force-reinstall",
            ])
            .arg(&wheel),
        "pip install the wheel",
    );
    python
}

#[test]
fn python_package_builds_and_passes_its_tests() {
    if !support::available_or_skip(
        python_tools_available(),
        "IMPACTMC_REQUIRE_PYTHON",
        "maturin and pytest",
        "pip install -r .ci/requirements-python.txt",
    ) {
        return;
    }
    let target = target_dir();
    let python = install(&target);
    let report = run(
        Command::new(&python)
            .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
            .arg(repo("python/tests"))
            .env("IMPACTMC_BIN", env!("CARGO_BIN_EXE_impactmc"))
            .current_dir(repo("")),
        "pytest python/tests",
    );
    eprintln!("{report}");
    assert!(
        report.contains(" passed") && !report.contains(" failed"),
        "{report}"
    );
    let has = |m: &str| {
        Command::new(&python)
            .args(["-c", &format!("import {m}")])
            .output()
            .map(|o| o.status.success())
            .unwrap_or(false)
    };
    if !(has("polars") && has("matplotlib")) {
        assert!(
            std::env::var_os("IMPACTMC_REQUIRE_PYTHON").is_none(),
            "IMPACTMC_REQUIRE_PYTHON is set but the example's polars and matplotlib are missing"
        );
        eprintln!("skipped the example: polars and matplotlib are not installed");
        return;
    }
    let out = support::tmpdir("python-example");
    run(
        Command::new(&python)
            .arg(repo("python/examples/corner_study.py"))
            .arg("--samples")
            .arg("20000")
            .arg("--out")
            .arg(&out)
            .current_dir(repo("")),
        "python/examples/corner_study.py",
    );
    let png = out.join("corner_study.png");
    let bytes = std::fs::read(&png).unwrap_or_else(|e| panic!("{}: {e}", png.display()));
    assert!(
        bytes.starts_with(b"\x89PNG") && bytes.len() > 10_000,
        "not a figure"
    );
}
