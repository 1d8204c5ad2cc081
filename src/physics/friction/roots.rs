//! Roots of a complex polynomial (Durand–Kerner), for the slide angle's
//! quartic of the single-contact solve (friction.md §3).

/// The largest degree [`poly_roots`] takes (the slide angle's quartic).
pub(super) const MAX_DEGREE: usize = 4;

/// A minimal complex number, for the slide angle's quartic.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct C(pub(super) f64, pub(super) f64);

impl C {
    pub(super) fn add(self, o: C) -> C {
        C(self.0 + o.0, self.1 + o.1)
    }
    pub(super) fn sub(self, o: C) -> C {
        C(self.0 - o.0, self.1 - o.1)
    }
    pub(super) fn mul(self, o: C) -> C {
        C(self.0 * o.0 - self.1 * o.1, self.0 * o.1 + self.1 * o.0)
    }
    pub(super) fn div(self, o: C) -> C {
        let d = o.0 * o.0 + o.1 * o.1;
        C(
            (self.0 * o.0 + self.1 * o.1) / d,
            (self.1 * o.0 - self.0 * o.1) / d,
        )
    }
    pub(super) fn abs(self) -> f64 {
        self.0.hypot(self.1)
    }
    /// `|z|` without hypot's overflow care, for the iteration's moduli of
    /// O(1) numbers (monic coefficients, roots within Cauchy's bound).
    pub(super) fn norm(self) -> f64 {
        (self.0 * self.0 + self.1 * self.1).sqrt()
    }
}

/// The roots of `Σ_{k=0}^{deg} a_k z^k` (complex), by Durand–Kerner from
/// the usual spread of starting points. It stops when no root moves by
/// more than 1e-15 (relative), or, once the moves have been below 1e-6,
/// when the largest move has not fallen below 0.9 of its smallest value
/// for 16 iterations: near a double root the iteration converges linearly
/// and then wanders at the rounding floor (about the square root of the
/// precision), where more iterations change nothing that the polish on F
/// does not.
///
/// At most degree [`MAX_DEGREE`], on the stack: the first `deg` entries of
/// the array returned are the roots.
pub(super) fn poly_roots(a: &[C]) -> [C; MAX_DEGREE] {
    let deg = a.len() - 1;
    assert!(
        (1..=MAX_DEGREE).contains(&deg),
        "degree {deg} outside 1..={MAX_DEGREE}"
    );
    let lead = a[deg];
    let mut monic = [C(0.0, 0.0); MAX_DEGREE + 1];
    for (m, &x) in monic.iter_mut().zip(a) {
        *m = x.div(lead);
    }
    let monic = &monic[..=deg];
    let eval = |z: C| {
        monic
            .iter()
            .rev()
            .fold(C(0.0, 0.0), |acc, &c| acc.mul(z).add(c))
    };
    // Start on a circle of the roots' size (Cauchy's bound), off the axes.
    let radius = 1.0 + monic[..deg].iter().map(|c| c.abs()).fold(0.0, f64::max);
    let mut z = [C(0.0, 0.0); MAX_DEGREE];
    for (k, zk) in z.iter_mut().enumerate().take(deg) {
        let t = 0.4 + std::f64::consts::TAU * k as f64 / deg as f64;
        *zk = C(radius.min(2.0) * t.cos(), radius.min(2.0) * t.sin());
    }
    let (mut least, mut stalled) = (f64::INFINITY, 0);
    for _ in 0..500 {
        let mut moved = 0f64;
        for i in 0..deg {
            let mut den = C(1.0, 0.0);
            for j in 0..deg {
                if j != i {
                    den = den.mul(z[i].sub(z[j]));
                }
            }
            if den == C(0.0, 0.0) {
                continue;
            }
            let step = eval(z[i]).div(den);
            z[i] = z[i].sub(step);
            moved = moved.max(step.norm() / z[i].norm().max(1.0));
        }
        if moved < 1e-15 {
            break;
        }
        if moved < 0.9 * least {
            (least, stalled) = (moved, 0);
        } else if least < 1e-6 {
            // Converged to the rounding floor of a (near-)double root.
            stalled += 1;
            if stalled == 16 {
                break;
            }
        }
    }
    z
}
