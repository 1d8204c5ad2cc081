//! The ratio statistics of a summary against a direct computation from the
//! same run's per-sample rows: `restitution_PLANE` is `Σ v_n⁺ / Σ |v_n⁻|`
//! over the samples where the plane approached, with the delta-method
//! ci95 of a ratio estimator, and `rebound_PLANE` is the per-contact ratio
//! over the same samples (docs/reference.md, "Statistics").

use crate::support;

use arrow_array::types::Float64Type;
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

#[test]
fn restitution_is_the_ratio_of_sums_over_approaching_contacts() {
    let dir = scratch("ratios");
    let out = bin()
        .args(["run", "--samples", "20000", "--precision", "f64"])
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
            let before = column::<Float64Type>(&rows, &format!("vn_before_{plane}"));
            let after = column::<Float64Type>(&rows, &format!("vn_after_{law}_{plane}"));
            let pairs: Vec<(f64, f64)> = before
                .iter()
                .zip(&after)
                .filter(|(b, _)| **b < 0.0)
                .map(|(b, a)| (*a, -b))
                .collect();
            let (n, r, ci, min, max) = direct(&pairs);
            let got = &stats[format!("restitution_{plane}")];
            let f = |k: &str| got[k].as_f64().unwrap();
            assert_eq!(got["n"].as_u64(), Some(n as u64), "{law} {plane}");
            assert_close!(f("mean"), r, 1e-12, "{law} {plane} ratio");
            // From three moments, the error's variance cancels to about
            // 1e-9 of the ratio where every contact rebounds alike.
            assert_close!(f("ci95"), ci, 1e-6 * ci + 1e-9 * r, "{law} {plane} ci95");
            assert_close!(f("min"), min, 1e-12, "{law} {plane} min");
            assert_close!(f("max"), max, 1e-12, "{law} {plane} max");
            let rebound = &stats[format!("rebound_{plane}")];
            assert_eq!(rebound["n"].as_u64(), Some(n as u64), "{law} {plane}");
            // The ratio is the per-contact ratios' mean weighted by |v_n⁻|.
            assert!(min <= r && r <= max, "{law} {plane}: {min} ≤ {r} ≤ {max}");
            if law == "newton" {
                // Complementarity, v_n⁺ + e·v_n⁻ ≥ 0: no contact rebounds
                // below its restitution, so neither does their ratio.
                assert!(min >= e - 1e-9, "{plane}: {min} < {e}");
            }
        }
    }
}
