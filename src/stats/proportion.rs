//! Intervals on proportions: Wilson's score interval, which, unlike the
//! normal (Wald) interval, stays inside [0, 1] and gives a zero count a
//! positive upper bound (z²/(n + z²), about 3.8/n).

/// The standard normal's 97.5 % quantile.
pub const Z975: f64 = 1.959_963_984_540_054;

/// Wilson's 95 % score interval `[low, high]` for `k` successes in `n`
/// trials (Wilson 1927; Agresti & Coull 1998): the proportions p with
/// (k/n − p)² ≤ z² p(1 − p)/n. NaN for `n = 0`.
pub fn wilson(k: u64, n: u64) -> [f64; 2] {
    if n == 0 {
        return [f64::NAN, f64::NAN];
    }
    let (nf, z2) = (n as f64, Z975 * Z975);
    let p = k as f64 / nf;
    let denom = 1.0 + z2 / nf;
    let centre = (p + z2 / (2.0 * nf)) / denom;
    let half = Z975 / denom * (p * (1.0 - p) / nf + z2 / (4.0 * nf * nf)).sqrt();
    let low = if k == 0 {
        0.0
    } else {
        (centre - half).max(0.0)
    };
    let high = if k >= n {
        1.0
    } else {
        (centre + half).min(1.0)
    };
    [low, high]
}

/// The normal (Wald) 95 % half-width of a proportion `p` of `n` trials:
/// what independent sampling's variance is, for an RQMC gain.
pub fn wald_ci95(p: f64, n: u64) -> f64 {
    Z975 * (p * (1.0 - p) / n as f64).sqrt()
}

/// An interval from replicates for a proportion `p` whose pooled count
/// gives `pooled` (its Wilson interval): `p ± half` inside [0, 1]; a count
/// of none (or of all) keeps the pooled bound, which the replicates, all
/// alike, cannot narrow.
pub fn replicated(p: f64, half: f64, pooled: [f64; 2]) -> [f64; 2] {
    if !(p.is_finite() && half.is_finite()) {
        return [f64::NAN, f64::NAN];
    }
    if pooled[0] == 0.0 || pooled[1] == 1.0 {
        return pooled;
    }
    [(p - half).max(0.0), (p + half).min(1.0)]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against statsmodels 0.15's `proportion_confint(k, n, alpha=0.05,
    /// method="wilson")` (which gives 4.2e-22, not 0, as the low end of
    /// 0 of 10⁶).
    #[test]
    fn wilson_against_statsmodels() {
        for (k, n, lo, hi) in [
            (0, 10, 0.0, 0.27753279986288926),
            (3, 10, 0.10779126740630104, 0.6032218525388546),
            (10, 10, 0.7224672001371106, 1.0),
            (0, 1_000_000, 0.0, 3.841444063944944e-06),
            (500, 1000, 0.4690696003681042, 0.5309303996318958),
        ] {
            let [l, h] = wilson(k, n);
            assert!(
                (l - lo).abs() < 1e-15 && (h - hi).abs() < 1e-15,
                "{k}/{n}: {l} {h}"
            );
        }
        assert!(wilson(0, 0)[0].is_nan());
    }
}
