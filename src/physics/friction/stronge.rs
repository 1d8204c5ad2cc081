//! `stronge`: energetic restitution by Darboux–Keller integration in the
//! normal impulse, for one rough contact (friction.md §5, law 4).

use glam::DVec3;

use super::gauss_seidel::{Contacts, Solved};
use super::tangent_basis;

/// How the tangential impulse grows with the normal impulse p.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Mode {
    /// `dF/dp = −μ c_t/|c_t|`.
    Slide,
    /// Slip along a fixed unit direction (resumed from rest): `−μ ŝ`.
    Ray([f64; 2]),
    /// `c_t` stays zero: `dF/dp = −W_tt⁻¹ w_t`.
    Stick([f64; 2]),
}

/// One contact in tangent coordinates: `c_n(p, F) = c_n⁻ + p W_nn + w_t·F`
/// and `c_t(p, F) = c_t⁻ + p w_t + W_tt F` for a tangential impulse F.
struct Path {
    cn0: f64,
    ct0: [f64; 2],
    w_nn: f64,
    wt: [f64; 2],
    wtt: [[f64; 2]; 2],
    mu: f64,
}

impl Path {
    fn cn(&self, p: f64, f: [f64; 2]) -> f64 {
        self.cn0 + p * self.w_nn + self.wt[0] * f[0] + self.wt[1] * f[1]
    }
    fn ct(&self, p: f64, f: [f64; 2]) -> [f64; 2] {
        [
            self.ct0[0] + p * self.wt[0] + self.wtt[0][0] * f[0] + self.wtt[0][1] * f[1],
            self.ct0[1] + p * self.wt[1] + self.wtt[1][0] * f[0] + self.wtt[1][1] * f[1],
        ]
    }
    /// d(F, work)/dp, with work = ∫ c_n dp.
    fn rhs(&self, mode: Mode, p: f64, y: [f64; 3]) -> [f64; 3] {
        let f = [y[0], y[1]];
        let df = match mode {
            Mode::Slide => {
                let ct = self.ct(p, f);
                let m = (ct[0] * ct[0] + ct[1] * ct[1]).sqrt();
                if m > 0.0 {
                    [-self.mu * ct[0] / m, -self.mu * ct[1] / m]
                } else {
                    [0.0, 0.0]
                }
            }
            Mode::Ray(s) => [-self.mu * s[0], -self.mu * s[1]],
            Mode::Stick(g) => g,
        };
        [df[0], df[1], self.cn(p, f)]
    }

    /// Where slip goes once `c_t` is zero: stick if `|W_tt⁻¹ w_t| ≤ μ`,
    /// else the unique ray `ŝ = (μ W_tt + σ I)⁻¹ w_t`, `|ŝ| = 1`, σ > 0.
    fn at_rest(&self) -> Mode {
        let [[a, b], [c, d]] = self.wtt;
        let det = a * d - b * c;
        let g = [
            -(d * self.wt[0] - b * self.wt[1]) / det,
            -(-c * self.wt[0] + a * self.wt[1]) / det,
        ];
        if g[0].hypot(g[1]) <= self.mu {
            return Mode::Stick(g);
        }
        let dir = |sigma: f64| {
            let (a, b, c, d) = (
                self.mu * a + sigma,
                self.mu * b,
                self.mu * c,
                self.mu * d + sigma,
            );
            let det = a * d - b * c;
            [
                (d * self.wt[0] - b * self.wt[1]) / det,
                (-c * self.wt[0] + a * self.wt[1]) / det,
            ]
        };
        // |ŝ(σ)| falls strictly from above 1 at σ = 0 to at most 1 at
        // σ = |w_t|: bisection to the last bit.
        let (mut lo, mut hi) = (0.0, self.wt[0].hypot(self.wt[1]));
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if mid <= lo || mid >= hi {
                break;
            }
            let s = dir(mid);
            if s[0].hypot(s[1]) > 1.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let s = dir(hi);
        let m = s[0].hypot(s[1]);
        Mode::Ray([s[0] / m, s[1] / m])
    }

    /// One Dormand–Prince 5(4) step in p.
    fn step(&self, mode: Mode, p: f64, y: [f64; 3], h: f64) -> ([f64; 3], [f64; 3]) {
        dopri5(&|q, z| self.rhs(mode, q, z), p, y, h)
    }

    /// The approach to zero slip, integrated in `τ = ln(m₀/|c_t|)` from a
    /// sliding state `(p, y)` whose slip `|c_t| = m₀` falls: with `c_t = m s`
    /// and `v(s) = w_t − μ W_tt s` (dc_t/dp while sliding, a function of the
    /// direction alone) and `a = −s·v > 0`,
    /// `dp/dτ = m/a`, `ds/dτ = (v + a s)/a`, `dF/dτ = −μ s m/a` and
    /// `d(work)/dτ = c_n m/a`, `m = m₀ e^{−τ}`. The direction's equation does
    /// not involve m, so the path reaches `c_t = 0` at a finite p that the
    /// integrals reach to rounding after [`APPROACH_FOLDS`] e-foldings:
    /// nothing is stopped early. `None` if the slip stops falling on the
    /// way (`a` no longer positive) or the steps fail.
    fn approach(
        &self,
        p: f64,
        y: [f64; 3],
        c: [f64; 2],
        p_scale: f64,
        vs: f64,
    ) -> Option<(f64, [f64; 3])> {
        let m0 = c[0].hypot(c[1]);
        let rate = |s: [f64; 2]| {
            let v = [
                self.wt[0] - self.mu * (self.wtt[0][0] * s[0] + self.wtt[0][1] * s[1]),
                self.wt[1] - self.mu * (self.wtt[1][0] * s[0] + self.wtt[1][1] * s[1]),
            ];
            (v, -(s[0] * v[0] + s[1] * v[1]))
        };
        let floor = 1e-9 * self.wt[0].hypot(self.wt[1]).max(self.mu * vs / p_scale);
        let rhs = |tau: f64, z: [f64; 6]| -> [f64; 6] {
            let n = z[0].hypot(z[1]);
            let s = [z[0] / n, z[1] / n];
            let (v, a) = rate(s);
            let a = a.max(floor);
            let dp = m0 * (-tau).exp() / a;
            [
                (v[0] + a * s[0]) / a,
                (v[1] + a * s[1]) / a,
                dp,
                -self.mu * s[0] * dp,
                -self.mu * s[1] * dp,
                self.cn(z[2], [z[3], z[4]]) * dp,
            ]
        };
        let mut z = [c[0] / m0, c[1] / m0, p, y[0], y[1], y[2]];
        let a0 = rate([z[0], z[1]]).1;
        if !(a0 > 0.0) {
            return None;
        }
        // The impulse the approach takes at its first rate, if larger than
        // the impact's: the errors are relative to it.
        let p_scale = p_scale.max(m0 / a0);
        let (mut tau, mut h) = (0.0f64, 0.25f64);
        let tol = 1e-14;
        for _ in 0..2_000 {
            if tau >= APPROACH_FOLDS {
                return Some((z[2], [z[3], z[4], z[5]]));
            }
            h = h.min(APPROACH_FOLDS - tau);
            let (z1, err) = dopri5(&rhs, tau, z, h);
            // Mixed absolute and relative errors: the direction's in
            // slip speed, p's and F's against the impulse scale, the
            // work's against its own.
            let e = (err[0].hypot(err[1]) * m0 * (-tau).exp() / vs)
                .max(err[2].abs() / (p_scale + z[2].abs()))
                .max(err[3].hypot(err[4]) / (p_scale + z[3].hypot(z[4])))
                .max(err[5].abs() / (p_scale * vs + z[5].abs()));
            if e > tol {
                h *= (0.9 * (tol / e).powf(0.2)).max(0.2);
                // Steps that vanish: the slip turns to where it no longer
                // falls (a minimum of |c_t| above zero).
                if h < 1e-9 {
                    return None;
                }
                continue;
            }
            let n = z1[0].hypot(z1[1]);
            if !(rate([z1[0] / n, z1[1] / n]).1 > floor) {
                return None;
            }
            tau += h;
            z = z1;
            h *= if e > 0.0 {
                (0.9 * (tol / e).powf(0.2)).min(5.0)
            } else {
                5.0
            };
        }
        None
    }
}

/// E-foldings of the slip the approach integrates: `e^{−40} ≈ 4·10⁻¹⁸` of
/// where it starts, itself at most [`APPROACH_FROM`] of the velocity scale.
const APPROACH_FOLDS: f64 = 40.0;

/// The slip, as a fraction of the velocity scale, below which a falling
/// slip is followed to zero by [`Path::approach`].
const APPROACH_FROM: f64 = 1e-3;

/// One Dormand–Prince 5(4) step of `dy/dt = f(t, y)`: the fifth-order
/// result and the difference to the embedded fourth-order one.
fn dopri5<const N: usize>(
    f: &dyn Fn(f64, [f64; N]) -> [f64; N],
    t: f64,
    y: [f64; N],
    h: f64,
) -> ([f64; N], [f64; N]) {
    const A: [[f64; 6]; 6] = [
        [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
        [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
        [
            19372.0 / 6561.0,
            -25360.0 / 2187.0,
            64448.0 / 6561.0,
            -212.0 / 729.0,
            0.0,
            0.0,
        ],
        [
            9017.0 / 3168.0,
            -355.0 / 33.0,
            46732.0 / 5247.0,
            49.0 / 176.0,
            -5103.0 / 18656.0,
            0.0,
        ],
        [
            35.0 / 384.0,
            0.0,
            500.0 / 1113.0,
            125.0 / 192.0,
            -2187.0 / 6784.0,
            11.0 / 84.0,
        ],
    ];
    const CN: [f64; 6] = [1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0];
    const B4: [f64; 7] = [
        5179.0 / 57600.0,
        0.0,
        7571.0 / 16695.0,
        393.0 / 640.0,
        -92097.0 / 339200.0,
        187.0 / 2100.0,
        1.0 / 40.0,
    ];
    let mut k = [[0.0; N]; 7];
    k[0] = f(t, y);
    for s in 0..6 {
        let mut ys = y;
        for (i, yi) in ys.iter_mut().enumerate() {
            for (j, kj) in k.iter().enumerate().take(s + 1) {
                *yi += h * A[s][j] * kj[i];
            }
        }
        k[s + 1] = f(t + CN[s] * h, ys);
    }
    // The seventh stage is at the fifth-order result (FSAL).
    let mut y5 = y;
    for (i, yi) in y5.iter_mut().enumerate() {
        for j in 0..6 {
            *yi += h * A[5][j] * k[j][i];
        }
    }
    let mut err = [0.0; N];
    for (i, e) in err.iter_mut().enumerate() {
        let mut y4 = y[i];
        for (j, kj) in k.iter().enumerate() {
            y4 += h * B4[j] * kj[i];
        }
        *e = y5[i] - y4;
    }
    (y5, err)
}

/// The rest of a Darboux–Keller path from `(p, y)` with `dF/dp = g` fixed:
/// `c_n(p + q) = c_n + α q` and `work(p + q) = work + c_n q + ½ α q²`,
/// `α = W_nn + w_t·g`. Compression ends at `c_n = 0`; restitution where the
/// work reaches its target (`E_c` absorbed, `e² E_c` returned), or where
/// `c_n` falls to zero again. `None` if compression never ends (α ≤ 0).
fn linear_end(
    path: &Path,
    p: f64,
    y: [f64; 3],
    g: [f64; 2],
    end_work: Option<f64>,
    e2: f64,
) -> Option<(f64, [f64; 3])> {
    let alpha = path.w_nn + path.wt[0] * g[0] + path.wt[1] * g[1];
    let at = |q: f64, y: [f64; 3], cn: f64| {
        [
            y[0] + g[0] * q,
            y[1] + g[1] * q,
            y[2] + cn * q + 0.5 * alpha * q * q,
        ]
    };
    let (mut p, mut y) = (p, y);
    let mut cn = path.cn(p, [y[0], y[1]]);
    let target = match end_work {
        Some(t) => t,
        None => {
            if cn < 0.0 {
                if !(alpha > 0.0) {
                    return None;
                }
                let q = -cn / alpha;
                y = at(q, y, cn);
                p += q;
                cn = 0.0;
            }
            if e2 == 0.0 {
                return Some((p, y));
            }
            // E_c = −work at the end of compression.
            y[2] - e2 * y[2]
        }
    };
    // Restitution: cn q + ½ α q² = target − work, q ≥ 0, without
    // cancellation; c_n may reach zero first when α < 0.
    let need = (target - y[2]).max(0.0);
    let q_work = if alpha == 0.0 {
        if cn > 0.0 {
            need / cn
        } else {
            f64::INFINITY
        }
    } else {
        let disc = cn * cn + 2.0 * alpha * need;
        if disc < 0.0 {
            f64::INFINITY
        } else {
            2.0 * need / (cn + disc.sqrt())
        }
    };
    let q_zero = if alpha < 0.0 {
        -cn / alpha
    } else {
        f64::INFINITY
    };
    let q = q_work.min(q_zero);
    if !q.is_finite() {
        return None;
    }
    Some((p + q, at(q, y, cn)))
}

/// `stronge` for one touching contact: Darboux–Keller integration in the
/// normal impulse p through slide, stick and resumed slip, compression
/// (`c_n` reaches 0 at `p_c`, absorbing `E_c`) and restitution (until
/// `∫_{p_c} c_n dp = k² E_c`). Slip is integrated by Dormand–Prince 5(4)
/// at a local error of 1e-13 of the impulse scale per step, each step
/// aimed at where the slip would stop and never carried through it, the
/// events of the step located by regula falsi. A falling slip below
/// [`APPROACH_FROM`] of the velocity scale is followed to zero in
/// `ln|c_t|` ([`Path::approach`]), unless the phase ends first; once the slip has stopped
/// (sticking, or resumed along its one ray) the rest of the path is linear
/// in p and finished in closed form.
pub fn stronge(ct: &Contacts) -> Solved {
    assert_eq!(ct.len(), 1, "stronge takes one contact");
    let n = ct.normals[0];
    let c0 = ct.before[0];
    let w = ct.w[0][0];
    let (t1, t2) = tangent_basis(n);
    let wn = w * n;
    let path = Path {
        cn0: n.dot(c0),
        ct0: [t1.dot(c0), t2.dot(c0)],
        w_nn: n.dot(wn),
        wt: [t1.dot(wn), t2.dot(wn)],
        wtt: [
            [t1.dot(w * t1), t1.dot(w * t2)],
            [t2.dot(w * t1), t2.dot(w * t2)],
        ],
        mu: ct.mu[0],
    };
    let e2 = ct.k[0] * ct.k[0];
    let mut out = Solved {
        impulses: vec![DVec3::ZERO],
        ..Solved::default()
    };
    if !(path.cn0 < 0.0) {
        return out;
    }
    let vs = ct.vscale.max(path.cn0.abs());
    // The frictionless compression impulse sets the scale of p.
    let p_scale = -path.cn0 / path.w_nn;
    let tol = 1e-13;
    let mut mode = if path.ct(0.0, [0.0; 2]).iter().all(|x| x.abs() <= 1e-13 * vs) {
        path.at_rest()
    } else {
        Mode::Slide
    };
    let (mut p, mut y) = (0.0f64, [0.0f64; 3]);
    let mut h = p_scale / 64.0;
    // None while compressing; then the work at which restitution ends.
    let mut end_work: Option<f64> = None;
    let mut ended = false;
    let (mut smallest, mut stalled) = (f64::INFINITY, 0);
    // The phase (compression or restitution) of the last approach tried.
    let mut approached: Option<bool> = None;
    for _ in 0..2_000_000 {
        let dir = match mode {
            Mode::Slide => None,
            Mode::Ray(s) => Some([-path.mu * s[0], -path.mu * s[1]]),
            Mode::Stick(g) => Some(g),
        };
        if let Some(g) = dir {
            // Stick and resumed slip keep dF/dp fixed for the rest of the
            // impact: c_n and the work are linear and quadratic in p, and
            // the events are roots in closed form.
            match linear_end(&path, p, y, g, end_work, e2) {
                Some((q, yq)) => {
                    p = q;
                    y = yq;
                    ended = true;
                }
                None => ended = false,
            }
            break;
        }
        // The event of this phase, as a function that turns ≥ 0.
        let event = |q: f64, yq: [f64; 3]| -> f64 {
            let cn = path.cn(q, [yq[0], yq[1]]);
            match end_work {
                None => cn / vs,
                // c_n turning negative again also ends the impact.
                Some(target) => ((yq[2] - target) / (p_scale * vs)).max(-cn / vs),
            }
        };
        let c = path.ct(p, [y[0], y[1]]);
        let m = (c[0] * c[0] + c[1] * c[1]).sqrt();
        // Slip has stopped. Aimed steps land on zero to rounding when the
        // slip keeps its direction; a turning slip approaches it in ever
        // shorter aimed steps, stopped at 1e-12 of the velocity scale (an
        // error of that order in the result).
        // A turning slip can also spiral into zero, each aimed step
        // covering a few per cent of the way, down to where the
        // integration's own error makes it chatter: stopped when eight
        // accepted steps in a row no longer shrink it.
        if m < 0.999 * smallest {
            smallest = m;
            stalled = 0;
        }
        // A small falling slip is followed to zero in ln|c_t| (once per
        // phase: again only after compression ends), unless the phase's
        // event comes first.
        let phase = end_work.is_some();
        if m <= APPROACH_FROM * vs && approached != Some(phase) {
            approached = Some(phase);
            if let Some((q, yq)) = path.approach(p, y, c, p_scale, vs) {
                if event(q, yq) < 0.0 {
                    (p, y) = (q, yq);
                    mode = path.at_rest();
                    continue;
                }
            }
        }
        if m <= 1e-12 * vs || (stalled >= 8 && m <= 1e-6 * vs) {
            mode = path.at_rest();
            continue;
        }
        // Aim at where |c_t| would reach zero at its present rate of fall:
        // exact when the slip keeps its direction (planar motion, spheres),
        // and repeated as the direction turns.
        let s = [c[0] / m, c[1] / m];
        let m_s = [
            path.wtt[0][0] * s[0] + path.wtt[0][1] * s[1],
            path.wtt[1][0] * s[0] + path.wtt[1][1] * s[1],
        ];
        let fall =
            -(s[0] * (path.wt[0] - path.mu * m_s[0]) + s[1] * (path.wt[1] - path.mu * m_s[1]));
        if fall > 0.0 {
            h = h.min(m / fall);
        }
        let (y1, err) = path.step(mode, p, y, h);
        let e = ((err[0] * err[0] + err[1] * err[1]).sqrt() / p_scale)
            .max(err[2].abs() / (p_scale * vs));
        if e > tol {
            h *= (0.9 * (tol / e).powf(0.2)).max(0.2);
            continue;
        }
        // A step must not carry the slip through zero (where its direction
        // jumps and the error estimate is blind): shorter, until it ends
        // short of zero and the next aimed step lands on it.
        let c1 = path.ct(p + h, [y1[0], y1[1]]);
        if c[0] * c1[0] + c[1] * c1[1] < 0.0 {
            h *= 0.5;
            continue;
        }
        let e1 = event(p + h, y1);
        if e1 >= 0.0 {
            // The step length to the event by regula falsi (Illinois).
            let (mut lo, mut hi) = (0.0, h);
            let (mut f_lo, mut f_hi) = (event(p, y), e1);
            let mut side = 0;
            for _ in 0..100 {
                if hi - lo <= 1e-15 * hi {
                    break;
                }
                let mut mid = hi - f_hi * (hi - lo) / (f_hi - f_lo);
                if !(mid > lo && mid < hi) {
                    mid = 0.5 * (lo + hi);
                }
                let f_mid = event(p + mid, path.step(mode, p, y, mid).0);
                if f_mid >= 0.0 {
                    hi = mid;
                    f_hi = f_mid;
                    if side == 1 {
                        f_lo *= 0.5;
                    }
                    side = 1;
                } else {
                    lo = mid;
                    f_lo = f_mid;
                    if side == -1 {
                        f_hi *= 0.5;
                    }
                    side = -1;
                }
            }
            y = path.step(mode, p, y, hi).0;
            p += hi;
            if end_work.is_none() && path.cn(p, [y[0], y[1]]) >= 0.0 {
                // End of compression: E_c = −∫₀^{p_c} c_n dp; restitution
                // returns e² of it.
                if e2 == 0.0 {
                    ended = true;
                    break;
                }
                end_work = Some(y[2] - e2 * y[2]);
                h = p_scale / 64.0;
                continue;
            }
            ended = true;
            break;
        }
        p += h;
        y = y1;
        stalled += 1;
        let grow = if e > 0.0 {
            (0.9 * (tol / e).powf(0.2)).min(5.0)
        } else {
            5.0
        };
        h *= grow;
        if p > 1e6 * p_scale {
            break;
        }
    }
    // A compression that never ends (or a path that never finishes).
    out.unsolved = !ended;
    out.impulses[0] = n * p + t1 * y[0] + t2 * y[1];
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn path(wt: [f64; 2], wtt: [[f64; 2]; 2], mu: f64) -> Path {
        Path {
            cn0: -1.0,
            ct0: [0.0, 0.0],
            w_nn: 2.0,
            wt,
            wtt,
            mu,
        }
    }

    /// Planar slip keeps its direction, so `c_t` is linear in p and
    /// reaches zero at `p + m/a` in closed form, `a` its rate of fall;
    /// next to the stick threshold `a` is small.
    #[test]
    fn a_planar_approach_lands_where_the_line_does() {
        // |W_tt⁻¹ w_t| = 0.6/0.8 = 0.75. Slip along −t1 falls at
        // a = 0.8 μ − 0.6, slowly just above the threshold; along +t1 at
        // 0.6 + 0.8 μ.
        for (mu, sign) in [
            (0.75 * (1.0 + 1e-6), -1.0),
            (0.75 * (1.0 + 1e-3), -1.0),
            (0.3, 1.0),
            (0.75 * (1.0 - 1e-6), 1.0),
        ] {
            let pa = path([-0.6, 0.0], [[0.8, 0.0], [0.0, 1.1]], mu);
            let (p, y) = (0.2, [0.05, 0.0, -0.1]);
            let m = 1e-4;
            let f = [y[0], y[1]];
            let c0 = pa.ct(p, f);
            let shift = [sign * m - c0[0], 0.0];
            let pa = Path {
                ct0: [pa.ct0[0] + shift[0], pa.ct0[1] + shift[1]],
                ..pa
            };
            let c = pa.ct(p, f);
            let s = [sign, 0.0];
            let a = -(s[0] * (pa.wt[0] - mu * pa.wtt[0][0] * s[0]));
            assert!(a > 0.0, "{mu} {sign}");
            let (q, yq) = pa
                .approach(p, y, c, 1.0, 1.0)
                .unwrap_or_else(|| panic!("{mu} {sign}: refused"));
            let want = p + m / a;
            // To 1e-13 of the impulse scale (1) or of the value.
            assert!(
                (q - want).abs() <= 1e-13 * want.max(1.0),
                "{mu}: {q} vs {want}"
            );
            let f_want = y[0] - sign * mu * m / a;
            assert!(
                (yq[0] - f_want).abs() <= 1e-13 * f_want.abs().max(1.0),
                "{mu}: {} vs {f_want}",
                yq[0]
            );
            // c_t at the end: within 1e-13 of the velocity scale (1), or
            // the rounding of its terms' cancellation.
            let ct = pa.ct(q, [yq[0], yq[1]]);
            let terms = pa.wt[0].abs() * q + pa.wtt[0][0] * yq[0].abs() + pa.ct0[0].abs();
            assert!(ct[0].hypot(ct[1]) <= 1e-13 * terms.max(1.0), "{mu}: {ct:?}");
        }
    }

    /// The slip of a sliding path integrated in p by fixed RK4 steps
    /// (independent of the approach): its smallest |c_t| over `span` and
    /// the p where it is.
    fn smallest_slip(pa: &Path, p: f64, f: [f64; 2], span: f64) -> (f64, f64) {
        let n = 200_000;
        let h = span / n as f64;
        let df = |q: f64, f: [f64; 2]| {
            let c = pa.ct(q, f);
            let m = c[0].hypot(c[1]);
            [-pa.mu * c[0] / m, -pa.mu * c[1] / m]
        };
        let (mut q, mut f) = (p, f);
        let mut best = (pa.ct(q, f)[0].hypot(pa.ct(q, f)[1]), q);
        for _ in 0..n {
            let k1 = df(q, f);
            let k2 = df(
                q + h / 2.0,
                [f[0] + h / 2.0 * k1[0], f[1] + h / 2.0 * k1[1]],
            );
            let k3 = df(
                q + h / 2.0,
                [f[0] + h / 2.0 * k2[0], f[1] + h / 2.0 * k2[1]],
            );
            let k4 = df(q + h, [f[0] + h * k3[0], f[1] + h * k3[1]]);
            for i in 0..2 {
                f[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
            q += h;
            let c = pa.ct(q, f);
            let m = c[0].hypot(c[1]);
            if m < best.0 {
                best = (m, q);
            }
        }
        best
    }

    /// Where the direction turns (W_tt not a multiple of the identity, w_t
    /// off its axes), the approach ends where a path integrated in p
    /// reaches zero slip, with `c_t` within 1e-13 of the velocity scale there; it refuses a slip
    /// that turns and stops falling short of zero, as that path shows.
    #[test]
    fn a_turning_approach_ends_at_zero_slip() {
        let wtt = [[0.9, 0.3], [0.3, 0.5]];
        let (p, y) = (0.1, [0.0, 0.0, -0.05]);
        let (mut landed, mut refused) = (0, 0);
        // A w_t small against μ W_tt (the slip falls in every direction)
        // and one that is not.
        for (wt, c) in [
            ([-0.05, 0.02], [-3e-4, 1e-4]),
            ([-0.05, 0.02], [1e-5, -2e-4]),
            ([-0.05, 0.02], [-1e-6, -1e-6]),
            ([-0.5, 0.2], [1e-5, -2e-4]),
            ([-0.5, 0.2], [-3e-4, 1e-4]),
        ] {
            let pa = Path {
                ct0: [c[0] - 0.1 * wt[0], c[1] - 0.1 * wt[1]],
                ..path(wt, wtt, 0.7)
            };
            let c = pa.ct(p, [y[0], y[1]]);
            let m = c[0].hypot(c[1]);
            // Beyond where the slip would stop at its first rate.
            let (least, at) = smallest_slip(&pa, p, [y[0], y[1]], 20.0 * m);
            let Some((q, yq)) = pa.approach(p, y, c, 1.0, 1.0) else {
                // Refused: the slip turns and stops falling short of zero.
                assert!(least > 1e-2 * m, "{c:?} refused, but it reaches {least:e}");
                refused += 1;
                continue;
            };
            assert!(least < 1e-3 * m, "{c:?}: the path in p keeps {least:e}");
            assert!(
                (q - at).abs() < 1e-3 * (at - p),
                "{c:?}: zero at {q}, not {at}"
            );
            let ct = pa.ct(q, [yq[0], yq[1]]);
            assert!(ct[0].hypot(ct[1]) <= 1e-13, "{c:?}: slip {ct:?} left");
            landed += 1;
        }
        assert!(
            landed >= 2 && refused >= 1,
            "{landed} landed, {refused} refused"
        );
    }
}
