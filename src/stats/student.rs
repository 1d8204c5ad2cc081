//! Intervals from replicate estimates: Student's t with R − 1 degrees of
//! freedom over R independent replicates, and the variance gain over
//! independent sampling.

/// `t_{0.975, ν}` for ν = 1 … 30 (computed with scipy's `stats.t.ppf`).
const T975: [f64; 30] = [
    12.706204736174694,
    4.302652729749462,
    3.182446305283708,
    2.7764451051977934,
    2.5705818356363146,
    2.4469118511449786,
    2.364624251592784,
    2.306004135204166,
    2.262157162798205,
    2.228138851986274,
    2.200985160091639,
    2.1788128296672284,
    2.1603686564627913,
    2.144786687917804,
    2.131449545559776,
    2.1199052992212546,
    2.1098155778333156,
    2.1009220402410382,
    2.0930240544083087,
    2.085963447265864,
    2.0796138447276795,
    2.0738730679040254,
    2.0686576104190486,
    2.0638985616280245,
    2.0595385527532972,
    2.0555294386428735,
    2.0518305164802846,
    2.0484071417952454,
    2.045229642132703,
    2.0422724563012378,
];

/// The 97.5 % quantile of Student's t with `dof` ≥ 1 degrees of freedom:
/// tabulated to 30, then the Cornish–Fisher expansion in 1/ν about the
/// normal quantile (Abramowitz & Stegun 26.7.5), within 1e-7 there.
pub fn t975(dof: u64) -> f64 {
    assert!(dof >= 1, "Student t needs a degree of freedom");
    if dof <= 30 {
        return T975[dof as usize - 1];
    }
    let z: f64 = 1.959_963_984_540_054;
    let n = dof as f64;
    let (z2, z3) = (z * z, z * z * z);
    let (z5, z7, z9) = (z3 * z2, z3 * z2 * z2, z3 * z3 * z3);
    z + (z3 + z) / (4.0 * n)
        + (5.0 * z5 + 16.0 * z3 + 3.0 * z) / (96.0 * n * n)
        + (3.0 * z7 + 19.0 * z5 + 17.0 * z3 - 15.0 * z) / (384.0 * n * n * n)
        + (79.0 * z9 + 776.0 * z7 + 1482.0 * z5 - 1920.0 * z3 - 945.0 * z)
            / (92160.0 * n * n * n * n)
}

/// What R replicate estimates say about their mean: the 95 % half-width
/// `t_{0.975, R−1}·s/√R` (s the sample sd of the estimates), and the gain
/// `(mc_ci95 / 1.96)² / (s²/R)`: the variance of the same estimate from
/// independent samples (`mc_ci95`, its normal half-width) over the
/// replicates' variance of the mean. NaN where an estimate is undefined.
pub fn replicate_interval(estimates: &[f64], mc_ci95: f64) -> (f64, f64) {
    let r = estimates.len();
    if r < 2 || estimates.iter().any(|x| !x.is_finite()) {
        return (f64::NAN, f64::NAN);
    }
    let mean = estimates.iter().sum::<f64>() / r as f64;
    let var = estimates.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (r - 1) as f64;
    let var_of_mean = var / r as f64;
    let ci95 = t975(r as u64 - 1) * var_of_mean.sqrt();
    let mc_var = (mc_ci95 / 1.959_963_984_540_054).powi(2);
    let gain = if var_of_mean > 0.0 {
        mc_var / var_of_mean
    } else if mc_var > 0.0 {
        f64::INFINITY
    } else {
        f64::NAN
    };
    (ci95, gain)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Past the table, against scipy's `stats.t.ppf(0.975, ν)`.
    #[test]
    fn t_quantiles_past_the_table() {
        for (dof, want) in [
            (31, 2.039513446396408),
            (40, 2.021075390306273),
            (63, 1.998340542520741),
            (100, 1.9839715185235518),
            (255, 1.9693105698498752),
            (1000, 1.9623390808264083),
        ] {
            assert!((t975(dof) - want).abs() < 1e-7, "{dof}: {}", t975(dof));
        }
    }

    /// Four estimates 1, 2, 3, 4: s² = 5/3, so the half-width is
    /// t_{0.975,3}·√(5/12), and an MC half-width of 1.96 (variance 1) gains
    /// 12/5.
    #[test]
    fn an_interval_by_hand() {
        let (ci, gain) = replicate_interval(&[1.0, 2.0, 3.0, 4.0], 1.959_963_984_540_054);
        assert!((ci - 3.182446305283708 * (5.0f64 / 12.0).sqrt()).abs() < 1e-12);
        assert!((gain - 2.4).abs() < 1e-12);
        assert!(replicate_interval(&[1.0, f64::NAN], 1.0).0.is_nan());
    }
}
