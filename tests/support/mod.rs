//! Helpers shared by the integration tests.
#![allow(dead_code)]

pub mod scenes;

use std::path::PathBuf;

/// A shipped scene (`configs/NAME.toml`) in the given precision.
pub fn shipped_scene(name: &str, precision: &str) -> impactmc::scene::Scene {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("configs/{name}.toml"));
    impactmc::scene::load_scene(
        &path,
        &impactmc::scene::Overrides {
            precision: Some(precision.into()),
            ..Default::default()
        },
    )
    .expect("shipped scene")
}

/// `shared/` beside the repository (CI clones the repo next to it).
/// `IMPACTMC_SHARED` overrides the location.
pub fn shared_dir() -> PathBuf {
    if let Ok(p) = std::env::var("IMPACTMC_SHARED") {
        return PathBuf::from(p);
    }
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared")
}

pub fn shared_file(rel: &str) -> String {
    let path = shared_dir().join(rel);
    std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (the golden data lives in shared/ beside the repository; set IMPACTMC_SHARED to point elsewhere)",
            path.display()
        )
    })
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
