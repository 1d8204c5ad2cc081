//! Elliptic functions and integrals of the torque-free motion: Carlson's
//! symmetric forms R_F, R_C and R_J by duplication, Jacobi's sn, cn and dn
//! by the descending Landen sequence, and the incomplete integral of the
//! third kind in Jacobi's theta form ([`ThetaPhase`]).

/// Carlson's R_F(x, y, z) (x, y, z ≥ 0, at most one zero), by duplication to
/// a relative error below 1e-16.
pub fn carlson_rf(x: f64, y: f64, z: f64) -> f64 {
    const ERRTOL: f64 = 0.0025;
    let (mut x, mut y, mut z) = (x, y, z);
    loop {
        let (sx, sy, sz) = (x.sqrt(), y.sqrt(), z.sqrt());
        let lambda = sx * (sy + sz) + sy * sz;
        x = 0.25 * (x + lambda);
        y = 0.25 * (y + lambda);
        z = 0.25 * (z + lambda);
        let ave = (x + y + z) / 3.0;
        let (dx, dy, dz) = ((ave - x) / ave, (ave - y) / ave, (ave - z) / ave);
        if dx.abs().max(dy.abs()).max(dz.abs()) <= ERRTOL {
            return carlson_rf_series(x, y, z);
        }
    }
}

/// The last step of R_F's duplication: its fifth-order series about the
/// mean of x, y and z, once they agree to the duplication's tolerance
/// (Carlson 1995, eq. 2.2). Every R_F of the crate ends here, the lane
/// set-up of flights included (hence inlined).
#[inline(always)]
pub fn carlson_rf_series(x: f64, y: f64, z: f64) -> f64 {
    let ave = (x + y + z) / 3.0;
    let (dx, dy, dz) = ((ave - x) / ave, (ave - y) / ave, (ave - z) / ave);
    let e2 = dx * dy - dz * dz;
    let e3 = dx * dy * dz;
    (1.0 + (e2 / 24.0 - 0.1 - 3.0 / 44.0 * e3) * e2 + e3 / 14.0) / ave.sqrt()
}

/// Carlson's R_C(x, y) for x ≥ 0, y > 0, in closed form (the arctangent
/// forms, accurate also for x close to y).
pub fn carlson_rc(x: f64, y: f64) -> f64 {
    if x < y {
        let d = y - x;
        (d / x).sqrt().atan() / d.sqrt()
    } else if x > y {
        let d = x - y;
        (d / x).sqrt().atanh() / d.sqrt()
    } else {
        1.0 / y.sqrt()
    }
}

/// Carlson's R_J(x, y, z, p) for x, y, z ≥ 0 (at most one zero) and p > 0,
/// by duplication to a relative error of about 1e-16 (`carlson_rf_rj`).
pub fn carlson_rj(x: f64, y: f64, z: f64, p: f64) -> f64 {
    carlson_rf_rj(x, y, z, p).1
}

/// R_F(x, y, z) and R_J(x, y, z, p) together: the two duplications share
/// x, y and z, so one loop serves both (iterated until both series
/// converge).
pub fn carlson_rf_rj(x: f64, y: f64, z: f64, p: f64) -> (f64, f64) {
    const C1: f64 = 3.0 / 14.0;
    const C2: f64 = 1.0 / 3.0;
    const C3: f64 = 3.0 / 22.0;
    const C4: f64 = 3.0 / 26.0;
    const C5: f64 = 0.75 * C3;
    const C6: f64 = 1.5 * C4;
    const C7: f64 = 0.5 * C2;
    const C8: f64 = C3 + C3;
    let (mut x, mut y, mut z, mut p) = (x, y, z, p);
    let (mut sum, mut fac) = (0.0, 1.0);
    loop {
        let (sx, sy, sz) = (x.sqrt(), y.sqrt(), z.sqrt());
        let lambda = sx * (sy + sz) + sy * sz;
        let alpha = (p * (sx + sy + sz) + sx * sy * sz).powi(2);
        let beta = p * (p + lambda).powi(2);
        sum += fac * carlson_rc(alpha, beta);
        fac *= 0.25;
        x = 0.25 * (x + lambda);
        y = 0.25 * (y + lambda);
        z = 0.25 * (z + lambda);
        p = 0.25 * (p + lambda);
        let ave = 0.2 * (x + y + z + p + p);
        let (dx, dy, dz, dp) = (
            (ave - x) / ave,
            (ave - y) / ave,
            (ave - z) / ave,
            (ave - p) / ave,
        );
        let ave3 = (x + y + z) / 3.0;
        let (ex, ey, ez) = ((ave3 - x) / ave3, (ave3 - y) / ave3, (ave3 - z) / ave3);
        if dx.abs().max(dy.abs()).max(dz.abs()).max(dp.abs()) <= 0.0015
            && ex.abs().max(ey.abs()).max(ez.abs()) <= 0.0025
        {
            let rf = carlson_rf_series(x, y, z);
            let ea = dx * (dy + dz) + dy * dz;
            let eb = dx * dy * dz;
            let ec = dp * dp;
            let ed = ea - 3.0 * ec;
            let ee = eb + 2.0 * dp * (ea - ec);
            let rj = 3.0 * sum
                + fac
                    * (1.0
                        + ed * (-C1 + C5 * ed - C6 * ee)
                        + eb * (C7 + dp * (-C8 + dp * C4))
                        + dp * ea * (C2 - dp * C3)
                        - C2 * dp * ec)
                    / (ave * ave.sqrt());
            return (rf, rj);
        }
    }
}

/// Jacobi's sn, cn, dn of one parameter m = k² ∈ [0, 1], by the descending
/// Landen (AGM) sequence, which depends on m only and is kept.
#[derive(Debug, Clone, Copy)]
pub struct Jacobi {
    /// 1 − m.
    pub(crate) mc: f64,
    pub(crate) levels: usize,
    pub(crate) a: [f64; 16],
    pub(crate) b: [f64; 16],
    /// The AGM limit.
    pub(crate) agm: f64,
}

impl Jacobi {
    pub fn new(m: f64) -> Self {
        let mc = (1.0 - m).max(0.0);
        let mut s = Self {
            mc,
            levels: 0,
            a: [0.0; 16],
            b: [0.0; 16],
            agm: 1.0,
        };
        if mc == 0.0 {
            return s;
        }
        let (mut a, mut emc) = (1.0f64, mc);
        let mut c = 1.0;
        for i in 0..16 {
            s.levels = i + 1;
            s.a[i] = a;
            emc = emc.sqrt();
            s.b[i] = emc;
            c = 0.5 * (a + emc);
            if (a - emc).abs() <= 1e-8 * a {
                break;
            }
            emc *= a;
            a = c;
        }
        s.agm = c;
        s
    }

    /// (sn u, cn u, dn u).
    pub fn sncndn(&self, u: f64) -> (f64, f64, f64) {
        if self.mc == 0.0 {
            let cn = 1.0 / u.cosh();
            return (u.tanh(), cn, cn);
        }
        let v = u * self.agm;
        let (mut sn, cn0) = v.sin_cos();
        let mut cn = cn0;
        let mut dn = 1.0;
        if sn != 0.0 {
            let mut a = cn / sn;
            let mut c = self.agm * a;
            for i in (0..self.levels).rev() {
                let b = self.a[i];
                a *= c;
                c *= dn;
                dn = (self.b[i] + a) / (b + a);
                a = c / b;
            }
            let r = 1.0 / (c * c + 1.0).sqrt();
            sn = if sn >= 0.0 { r } else { -r };
            cn = c * sn;
        }
        (sn, cn, dn)
    }
}

/// Most terms of a [`ThetaPhase`] series: enough for q ≤ 0.55, that is for
/// every orbit the closed form is used on (1 − k² ≥ [`SEPARATRIX`]).
pub(crate) const THETA_TERMS: usize = 12;

/// `Π(−ν; am u)` for any real `u` in Jacobi's theta form (Whittaker &
/// Watson §22.74, with the imaginary parameter of a negative
/// characteristic):
///
/// `Π(−ν; am u) = (Π(−ν)/K) u + S · arg Θ(u + iβ)`,
///
/// where `Θ(u) = θ₄(πu/2K, q)`, `q = exp(−πK′/K)`, `sc(β, k′) = √ν/k` and
/// `S = sn β cn β / dn β = √ν / √((k² + ν)(1 + ν))`. The argument is
/// periodic in u with period 2K and its series,
/// `Θ(u + iβ) = 1 + Σₙ 2(−1)ⁿ qⁿ² [cos 2nv cosh 2nw − i sin 2nv sinh 2nw]`
/// (`v = πu/2K`, `w = πβ/2K`), converges like `q^{n(n−1)}`: with
/// `γ = K′ − β = F(atan(1/√ν) | 1 − k²)` (so that no cancellation enters),
/// `qⁿ² e^{±2nw} = exp(−(π/K)(K′n² ∓ n(K′ − γ)))`. Each evaluation is one
/// `sin_cos`, a recurrence over a dozen terms and one `atan2`, with no
/// data-dependent loop: what Carlson's duplication needed for every pose.
#[derive(Debug, Clone, Copy, Default)]
pub struct ThetaPhase {
    /// π/(2K): u → v.
    pub(crate) scale: f64,
    /// Π(−ν)/K.
    pub(crate) slope: f64,
    pub(crate) s: f64,
    pub(crate) terms: usize,
    /// 2(−1)ⁿ qⁿ² cosh 2nw and 2(−1)ⁿ qⁿ² sinh 2nw, n = 1, 2, …
    pub(crate) re: [f64; THETA_TERMS],
    pub(crate) im: [f64; THETA_TERMS],
}

impl ThetaPhase {
    /// For parameter m = k² ∈ (0, 1) and ν > 0, given K(m) and Π(−ν | m).
    pub fn new(m: f64, nu: f64, k_complete: f64, pi_complete: f64) -> Self {
        let mc = 1.0 - m;
        // K′ = K(1 − m): infinite at m = 0 (equal moments I₁ = I₂, where
        // also ν = 0 and Π(0; am u) = u).
        let k_prime = if m > 0.0 {
            carlson_rf(0.0, m, 1.0)
        } else {
            f64::INFINITY
        };
        // γ = K′ − β = F(ψ | 1 − m) with tan ψ = 1/√ν (ψ = π/2 at ν = 0).
        let (sin_psi, cos2_psi) = (1.0 / (1.0 + nu).sqrt(), nu / (1.0 + nu));
        let gamma = if nu > 0.0 {
            sin_psi * carlson_rf(cos2_psi, 1.0 - mc * sin_psi * sin_psi, 1.0)
        } else {
            k_prime
        };
        let r = std::f64::consts::PI / k_complete;
        let mut s = Self {
            scale: 0.5 * r,
            slope: pi_complete / k_complete,
            // (No periodic part at ν = 0.)
            s: if nu > 0.0 {
                (nu / ((m + nu) * (1.0 + nu))).sqrt()
            } else {
                0.0
            },
            terms: 0,
            re: [0.0; THETA_TERMS],
            im: [0.0; THETA_TERMS],
        };
        for n in 1..=THETA_TERMS {
            let nf = n as f64;
            // qⁿ² e^{±2nw} = exp(−(π/K)(K′n(n ∓ 1) ± nγ)), written without
            // K′ − γ (and without ∞ · 0 when K′ is infinite).
            let below = if n == 1 {
                0.0
            } else {
                k_prime * nf * (nf - 1.0)
            };
            let up = (-r * (below + nf * gamma)).exp();
            let down = if k_prime.is_finite() {
                (-r * (k_prime * nf * (nf + 1.0) - nf * gamma)).exp()
            } else {
                0.0
            };
            let sign = if n % 2 == 0 { 1.0 } else { -1.0 };
            s.re[n - 1] = sign * (up + down);
            s.im[n - 1] = sign * (up - down);
            s.terms = n;
            if up < 1e-18 {
                break;
            }
        }
        s
    }

    /// The periodic part, `arg Θ(u + iβ)` (period 2K in u).
    #[inline]
    pub fn periodic(&self, u: f64) -> f64 {
        let (s1, c1) = (2.0 * self.scale * u).sin_cos();
        let (mut re, mut im) = (1.0, 0.0);
        let (mut c_prev, mut s_prev) = (1.0, 0.0);
        let (mut c, mut s) = (c1, s1);
        for n in 0..self.terms {
            re += self.re[n] * c;
            im -= self.im[n] * s;
            let (cn, sn) = (2.0 * c1 * c - c_prev, 2.0 * c1 * s - s_prev);
            (c_prev, s_prev, c, s) = (c, s, cn, sn);
        }
        im.atan2(re)
    }

    /// `Π(−ν; am u)` (the motion uses its two parts apart).
    #[cfg(test)]
    pub fn value(&self, u: f64) -> f64 {
        self.slope * u + self.s * self.periodic(u)
    }
}

/// Π(−ν; φ) for |φ| ≤ π/2 given sin φ, cos φ and 1 − k² sin²φ (what the
/// theta form is tested against):
#[cfg(test)]
/// `s R_F(c², Δ², 1) − (ν/3) s³ R_J(c², Δ², 1, 1 + ν s²)`.
fn pi_partial(s: f64, c: f64, delta2: f64, nu: f64) -> f64 {
    if s == 0.0 {
        return 0.0;
    }
    let (rf, rj) = carlson_rf_rj(c * c, delta2, 1.0, 1.0 + nu * s * s);
    s * rf - nu / 3.0 * s * s * s * rj
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Carlson's own test values (Numer. Algorithms 10, 1995, Table 1–3).
    #[test]
    fn carlson_forms_match_published_values() {
        let rel = |a: f64, b: f64| ((a - b) / b).abs();
        assert!(rel(carlson_rf(1.0, 2.0, 0.0), 1.311_028_777_146_1) < 1e-13);
        assert!(rel(carlson_rf(2.0, 3.0, 4.0), 0.584_082_841_677_15) < 1e-13);
        assert!(rel(carlson_rc(0.0, 0.25), std::f64::consts::PI) < 1e-15);
        assert!(rel(carlson_rc(2.25, 2.0), std::f64::consts::LN_2) < 1e-14);
        assert!(rel(carlson_rj(0.0, 1.0, 2.0, 3.0), 0.776_886_237_785_82) < 1e-13);
        assert!(rel(carlson_rj(2.0, 3.0, 4.0, 5.0), 0.142_975_796_671_57) < 1e-13);
        // The joint loop gives both, to the same digits (mpmath values).
        for (x, y, z, p, rf, rj) in [
            (
                0.0,
                1.0,
                2.0,
                3.0,
                1.311_028_777_146_06,
                0.776_886_237_785_823,
            ),
            (
                2.0,
                3.0,
                4.0,
                5.0,
                0.584_082_841_677_152,
                0.142_975_796_671_568,
            ),
            (
                0.25,
                0.9,
                1.0,
                1.7,
                1.234_064_574_345_174,
                1.024_611_852_381_018,
            ),
        ] {
            let (a, b) = carlson_rf_rj(x, y, z, p);
            assert!(
                rel(a, rf) < 1e-14 && rel(b, rj) < 1e-14,
                "{x} {y} {z} {p}: {a} {b}"
            );
        }
    }

    /// Π(−ν | m) and K(m) for the tests, from Carlson's forms.
    fn complete(m: f64, nu: f64) -> (f64, f64) {
        let (k, rj) = carlson_rf_rj(0.0, 1.0 - m, 1.0, 1.0 + nu);
        (k, k - nu / 3.0 * rj)
    }

    /// The theta form of Π(−ν; am u) against `∫₀ᵘ dv / (1 + ν sn² v)` by
    /// mpmath's quadrature at 30 digits (`mp.quad` with `mp.ellipfun`,
    /// split at multiples of K, at the exact binary values of the f64
    /// inputs: near the separatrix Π moves by 10⁴ times a change of m), from
    /// m near 0 to the separatrix switch and ν from 10⁻³ to 10⁶.
    #[test]
    fn theta_phase_matches_quadrature() {
        for (m, nu, u, want) in [
            (1e-6, 0.2, 1.3, 1.2073581950497012),
            (0.3, 8.4, -2.1, -0.576_960_876_811_074_2),
            (0.5, 1e6, 0.77, 0.0015698890771730242),
            (0.7, 1e-3, 40.0, 39.97684025538245),
            (0.99, 300.0, -9.5, -0.292_543_836_618_876),
            (0.9999, 0.001, -5.9117, -5.906792649808501),
            (0.9999, 8.4, 12.25, 2.2663896348018595),
            (0.9999989, 0.001, -58.99, -58.938059583552172),
            (0.9999989, 8.4, 31.0, 4.4471479697732643),
            (0.9999989, 1e6, -3.0, -0.001572789783139142),
        ] {
            let (k, pc) = complete(m, nu);
            let got = ThetaPhase::new(m, nu, k, pc).value(u);
            assert!(
                (got - want).abs() <= 4e-15 * want.abs().max(1.0),
                "m {m} nu {nu} u {u}: {got} vs {want}"
            );
        }
    }

    /// The theta form against Carlson's (the reduced amplitude plus whole
    /// half-periods) over a grid, where Carlson's form is accurate
    /// (m ≤ 0.99: nearer the separatrix, sn at |u| ≈ K loses digits and the
    /// quadrature test above decides).
    #[test]
    fn theta_phase_matches_carlson() {
        for m in [1e-6, 0.01, 0.3, 0.7, 0.99] {
            let jac = Jacobi::new(m);
            for nu in [1e-3, 0.2, 1.0, 8.4, 300.0, 1e6] {
                let (k, pc) = complete(m, nu);
                let th = ThetaPhase::new(m, nu, k, pc);
                for i in -60..=60 {
                    let u = i as f64 * 0.37 * k / 3.0;
                    let turns = (u / (2.0 * k)).round();
                    let (s, c, _) = jac.sncndn(u - turns * 2.0 * k);
                    let want = 2.0 * turns * pc + pi_partial(s, c, (1.0 - m * s * s).max(0.0), nu);
                    let got = th.value(u);
                    let scale = pc.abs().max(1.0) * (1.0 + turns.abs());
                    assert!(
                        (got - want).abs() <= 1e-13 * scale,
                        "m {m} nu {nu} u {u}: {got} vs {want}"
                    );
                }
            }
        }
    }

    /// sn² + cn² = 1, dn² + m sn² = 1, and d sn/du = cn dn (by central
    /// differences), over a range of parameters.
    #[test]
    fn jacobi_identities() {
        for m in [0.0, 1e-6, 0.3, 0.9, 0.999_999, 1.0] {
            let j = Jacobi::new(m);
            for k in -40..40 {
                let u = k as f64 * 0.173;
                let (s, c, d) = j.sncndn(u);
                assert!((s * s + c * c - 1.0).abs() < 1e-14, "m {m} u {u}");
                assert!((d * d + m * s * s - 1.0).abs() < 1e-14, "m {m} u {u}");
                let h = 1e-5;
                let ds = (j.sncndn(u + h).0 - j.sncndn(u - h).0) / (2.0 * h);
                assert!((ds - c * d).abs() < 1e-8, "m {m} u {u}: {ds} vs {}", c * d);
            }
        }
        // m = 0: the circular functions.
        let _ = Jacobi::new(1.0).sncndn(0.3);
        let (s, c, d) = Jacobi::new(0.0).sncndn(0.7);
        assert!((s - 0.7f64.sin()).abs() < 1e-15 && (c - 0.7f64.cos()).abs() < 1e-15 && d == 1.0);
    }
}
