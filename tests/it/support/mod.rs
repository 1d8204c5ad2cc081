//! Helpers shared by the integration tests.
#![allow(dead_code)]

pub mod golden;
pub mod scenes;

use std::path::{Path, PathBuf};
use std::process::Command;

/// The `impactmc` binary of this build.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_impactmc"))
}

/// Fails the test, with the exit code, stdout and stderr, unless the
/// command succeeded.
pub fn assert_succeeded(out: &std::process::Output) {
    assert!(
        out.status.success(),
        "exit {:?}\nstdout:\n{}\nstderr:\n{}",
        out.status.code(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// [`assert_succeeded`], passing the output on.
pub fn succeeded(out: std::process::Output) -> std::process::Output {
    assert_succeeded(&out);
    out
}

/// A path inside the repository.
pub fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// A scratch path for one test (`impactmc-TAG-PID` in the temp folder),
/// not created.
pub fn scratch(tag: &str) -> PathBuf {
    std::env::temp_dir().join(format!("impactmc-{tag}-{}", std::process::id()))
}

/// A fresh, empty scratch folder for one test.
pub fn tmpdir(tag: &str) -> PathBuf {
    let d = scratch(tag);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A shipped scene (`configs/NAME.toml`) in the given precision.
pub fn shipped_scene(name: &str, precision: &str) -> impactmc::config::Scene {
    let path = repo(&format!("configs/{name}.toml"));
    impactmc::config::load_scene(
        &path,
        &impactmc::config::Overrides {
            precision: Some(precision.parse().expect("f32 or f64")),
            ..Default::default()
        },
    )
    .expect("shipped scene")
}

/// A shipped scene (`configs/NAME.toml`) with each `(from, to)` of `edits`
/// replaced once (every `from` must be there), loaded with `overrides`
/// from a scratch file tagged `tag`; the error's text if it is refused.
pub fn edited_scene(
    name: &str,
    edits: &[(&str, &str)],
    tag: &str,
    overrides: &impactmc::config::Overrides,
) -> Result<impactmc::config::Scene, String> {
    let mut text = std::fs::read_to_string(repo(&format!("configs/{name}.toml"))).unwrap();
    for (a, b) in edits {
        assert!(text.contains(a), "{name}: no {a:?}");
        text = text.replacen(a, b, 1);
    }
    let p = tmpdir(tag).join("scene.toml");
    std::fs::write(&p, text).unwrap();
    impactmc::config::load_scene(&p, overrides).map_err(|e| e.to_string())
}

/// A shipped scene with friction μ on every plane that has none, loaded
/// with `overrides` from a scratch file tagged `tag`.
pub fn rough_scene(
    name: &str,
    mu: f64,
    tag: &str,
    overrides: &impactmc::config::Overrides,
) -> impactmc::config::Scene {
    let text = std::fs::read_to_string(repo(&format!("configs/{name}.toml"))).unwrap();
    let rough: Vec<String> = text
        .lines()
        .map(|l| {
            if l.starts_with("restitution =") && !text.contains("friction =") {
                format!("{l}\nfriction = {mu}")
            } else {
                l.to_string()
            }
        })
        .collect();
    let p = tmpdir(tag).join("scene.toml");
    std::fs::write(&p, rough.join("\n")).unwrap();
    let s = impactmc::config::load_scene(&p, overrides).expect("scene");
    assert!(s.effects().friction, "{name} has friction");
    s
}

/// Whether a test that needs something outside Rust (`what`, e.g. a Slurm
/// cluster) can run: `true` when `available`; otherwise it is skipped with a
/// message saying how to get it (`false`), unless the environment variable
/// `required` is set (as `.ci/run` sets it), when the test fails.
pub fn available_or_skip(available: bool, required: &str, what: &str, how: &str) -> bool {
    if !available {
        assert!(
            std::env::var_os(required).is_none(),
            "{required} is set but {what} is not available ({how})"
        );
        eprintln!("skipped: {what} is not available ({how})");
    }
    available
}

/// A file of the test data (`tests/data/REL`), carried in the repository.
pub fn data_file(rel: &str) -> String {
    let path = repo("tests/data").join(rel);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The maintainers' copy of the golden data, `IMPACTMC_SHARED/golden`, when
/// that variable names a folder (`.ci/run` sets it). Only the drift check
/// reads it; every other test reads [`data_file`], and nothing looks beside
/// the repository on its own.
pub fn maintained_golden_dir() -> Option<PathBuf> {
    let dir = PathBuf::from(std::env::var_os("IMPACTMC_SHARED")?).join("golden");
    dir.is_dir().then_some(dir)
}

/// A JSON file of a run folder, parsed.
pub fn json_file(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// `|a − b| ≤ tol`, with a message naming what was compared.
#[macro_export]
macro_rules! assert_close {
    ($a:expr, $b:expr, $tol:expr, $($what:tt)+) => {{
        let (a, b, tol): (f64, f64, f64) = ($a, $b, $tol);
        assert!(
            (a - b).abs() <= tol && a.is_finite() == b.is_finite(),
            "{}: {a} vs {b} (|Δ| = {:e} > {tol:e})",
            format!($($what)+),
            (a - b).abs()
        );
    }};
}

/// A Parquet file read with the arrow-rs reader, as record batches (the
/// Python readers are tested in tests/readers.rs).
pub fn read_parquet(path: &Path) -> Vec<arrow_array::RecordBatch> {
    let f = std::fs::File::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(f)
        .unwrap()
        .build()
        .unwrap()
        .map(|b| b.unwrap())
        .collect()
}

/// A primitive column of [`read_parquet`]'s batches, e.g.
/// `column::<UInt16Type>(&b, "bounce")`.
pub fn column<T: arrow_array::ArrowPrimitiveType>(
    batches: &[arrow_array::RecordBatch],
    name: &str,
) -> Vec<T::Native> {
    use arrow_array::cast::AsArray;
    batches
        .iter()
        .flat_map(|b| {
            let c = b
                .column_by_name(name)
                .unwrap_or_else(|| panic!("no column {name}"));
            c.as_primitive::<T>().values().to_vec()
        })
        .collect()
}

/// A string column of [`read_parquet`]'s batches.
pub fn strings(batches: &[arrow_array::RecordBatch], name: &str) -> Vec<String> {
    use arrow_array::cast::AsArray;
    batches
        .iter()
        .flat_map(|b| {
            let c = b
                .column_by_name(name)
                .unwrap_or_else(|| panic!("no column {name}"));
            c.as_string::<i32>()
                .iter()
                .map(|s| s.unwrap().to_string())
                .collect::<Vec<_>>()
        })
        .collect()
}

/// A small xorshift generator for property tests that need many draws
/// cheaply: uniforms in [0, 1), standard normals, unit vectors.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }

    pub fn normal(&mut self) -> f64 {
        let (u, v) = (self.next().max(1e-300), self.next());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }

    pub fn unit(&mut self) -> glam::DVec3 {
        glam::DVec3::new(self.normal(), self.normal(), self.normal()).normalize()
    }
}

/// A summary's JSON without what legitimately differs between runs of the
/// same scene (`throughput`, `threads`), at any depth.
pub fn without_timing(mut v: serde_json::Value) -> serde_json::Value {
    fn strip(v: &mut serde_json::Value) {
        if let Some(o) = v.as_object_mut() {
            o.remove("throughput");
            o.remove("threads");
            o.values_mut().for_each(strip);
        } else if let Some(a) = v.as_array_mut() {
            a.iter_mut().for_each(strip);
        }
    }
    strip(&mut v);
    v
}
