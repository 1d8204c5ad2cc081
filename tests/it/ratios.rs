//! The ratio statistics of a summary against a direct computation from the
//! same run's per-sample rows: `restitution_PLANE` is `Σ v_n⁺ / Σ |v_n⁻|`
//! over the samples where the plane approached, with the delta-method
//! ci95 of a ratio estimator, and `rebound_PLANE` is the per-contact ratio
//! over the same samples (docs/reference.md, "Statistics").

use crate::support;

use arrow_array::types::{Float32Type, Float64Type};
use support::{assert_succeeded, bin, column, json_file, read_parquet, repo, scratch};

/// `(n, ratio, ci95, min, max)` of `Σx/Σy` over the pairs, two-pass.
fn direct(pairs: &[(f64, f64)]) -> (usize, f64, f64, f64, f64) {
    let n = pairs.len() as f64;
    let (sx, sy) = pairs
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x, b + y));
    let r = sx / sy;
    let ybar = sy / n;
    let z: Vec<f64> = pairs.iter().map(|(x, y)| (x - r * y) / ybar).collect();
    let zbar = z.iter().sum::<f64>() / n;
    let var = z.iter().map(|v| (v - zbar).powi(2)).sum::<f64>() / (n - 1.0);
    let ratios = pairs.iter().map(|(x, y)| x / y);
    let min = ratios.clone().fold(f64::INFINITY, f64::min);
    let max = ratios.fold(f64::NEG_INFINITY, f64::max);
    (pairs.len(), r, 1.96 * var.sqrt() / n.sqrt(), min, max)
}

/// In f64 and in f32, where Newton's law gives every contact its plane's
/// restitution up to f32 rounding (a ci95 of about 1e-9, which the summary
/// once gave as 0).
#[test]
fn restitution_is_the_ratio_of_sums_over_approaching_contacts() {
    for precision in ["f64", "f32"] {
        restitution_in(precision);
    }
}

fn restitution_in(precision: &str) {
    let dir = scratch(&format!("ratios-{precision}"));
    let out = bin()
        .args(["run", "--samples", "20000", "--precision", precision])
        .args([
            "--law",
            "paper",
            "--law",
            "newton",
            "--per-sample",
            "--force",
        ])
        .arg("--out")
        .arg(&dir)
        .arg(repo("configs/corner3.toml"))
        .output()
        .unwrap();
    assert_succeeded(&out);
    let summary = json_file(&dir.join("summary.json"));
    let rows = read_parquet(&dir.join("samples.parquet"));
    let restitution = [("wall_x", 0.5), ("wall_y", 0.7), ("floor", 0.9)];
    for law in ["paper", "newton"] {
        let stats = &summary["laws"][law]["groups"]["all"]["stats"];
        for (plane, e) in restitution {
            let floats = |name: &str| -> Vec<f64> {
                if precision == "f64" {
                    column::<Float64Type>(&rows, name)
                } else {
                    column::<Float32Type>(&rows, name)
                        .into_iter()
                        .map(f64::from)
                        .collect()
                }
            };
            let before = floats(&format!("vn_before_{plane}"));
            let after = floats(&format!("vn_after_{law}_{plane}"));
            let pairs: Vec<(f64, f64)> = before
                .iter()
                .zip(&after)
                .filter(|(b, _)| **b < 0.0)
                .map(|(b, a)| (*a, -b))
                .collect();
            let (n, r, ci, min, max) = direct(&pairs);
            let got = &stats[format!("restitution_{plane}")];
            let f = |k: &str| got[k].as_f64().unwrap();
            let at = format!("{precision} {law} {plane}");
            assert_eq!(got["n"].as_u64(), Some(n as u64), "{at}");
            // The f32 kernel's block sums are f32.
            let tol = if precision == "f64" { 1e-12 } else { 1e-6 };
            assert_close!(f("mean"), r, tol, "{at} ratio");
            eprintln!("{at}: ci95 {:e}, from the rows {ci:e}", f("ci95"));
            assert!(ci > 0.0, "{at}");
            // To 1 %, or both at f64 rounding (Newton's law in f64).
            assert_close!(f("ci95"), ci, 0.01 * ci + 1e-15 * r, "{at} ci95");
            assert_close!(f("min"), min, tol * min.abs().max(1.0), "{at} min");
            assert_close!(f("max"), max, tol * max.abs().max(1.0), "{at} max");
            let rebound = &stats[format!("rebound_{plane}")];
            assert_eq!(rebound["n"].as_u64(), Some(n as u64), "{law} {plane}");
            // The ratio is the per-contact ratios' mean weighted by |v_n⁻|.
            assert!(min <= r && r <= max, "{law} {plane}: {min} ≤ {r} ≤ {max}");
            if law == "newton" && precision == "f64" {
                // Complementarity, v_n⁺ + e·v_n⁻ ≥ 0: no contact rebounds
                // below its restitution, so neither does their ratio (in
                // f32 a grazing contact's ratio of two small numbers is
                // off by more than that).
                assert!(min >= e - 1e-9, "{at}: {min} < {e}");
            }
        }
    }
}
