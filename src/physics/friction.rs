//! Impacts with Coulomb friction (`shared/friction.md`), f64 reference:
//! the Delassus blocks, the single-contact solve (take-off, stick, slide),
//! the laws `newton` (nonlinear Gauss–Seidel to its limit), `pgsN`,
//! `paper`, and `stronge` (energetic restitution by Darboux–Keller
//! integration in the normal impulse).
//!
//! Impulses here are world vectors `P_i = λ_i n_i + f_i`. The contact-point
//! velocity is `c_i = v + A(ω × x_i)`, and `c⁺_i = c⁻_i + Σ_j W_ij P_j`.

use glam::{DMat3, DVec3};

use super::{Ellipsoid, State};

/// friction.md's sticking threshold: a contact with an impulse ends
/// sticking when `|c⁺_t| ≤` this, 1e-9 of the larger velocity scale
/// `|v| + L|ω|` of before and after.
pub fn sticking_threshold(body: &Ellipsoid, before: &State, after: &State) -> f64 {
    let l = body.length_scale();
    1e-9 * (before.velocity.length() + l * before.omega.length())
        .max(after.velocity.length() + l * after.omega.length())
}

/// `[x]×`, the cross-product matrix: `[x]× y = x × y`.
pub(crate) fn skew(x: DVec3) -> DMat3 {
    DMat3::from_cols(
        DVec3::new(0.0, x.z, -x.y),
        DVec3::new(-x.z, 0.0, x.x),
        DVec3::new(x.y, -x.x, 0.0),
    )
}

/// The Delassus block `W_ij = I/m − A [x_i]× J⁻¹ [x_j]× Aᵀ` (world frame,
/// 1/kg) for body-frame contact points `x_i`, `x_j`.
pub fn delassus(body: &Ellipsoid, rotation: DMat3, xi: DVec3, xj: DVec3) -> DMat3 {
    let inv_j = DMat3::from_diagonal(body.inertia().recip());
    DMat3::from_diagonal(DVec3::splat(1.0 / body.mass()))
        - rotation * skew(xi) * inv_j * skew(xj) * rotation.transpose()
}

/// An orthonormal tangent basis of the plane with unit normal `n`.
fn tangent_basis(n: DVec3) -> (DVec3, DVec3) {
    let t1 = n.any_orthonormal_vector();
    (t1, n.cross(t1))
}

/// What one single-contact solve found.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Single {
    /// The impulse `P = λn + f` (world, N·s).
    pub impulse: DVec3,
    /// Several valid solutions (stick and a slide root, or two slide
    /// roots).
    pub ambiguous: bool,
    /// No valid case: the frictionless fallback `max(−c_n, 0)/W_nn · n`.
    pub unsolved: bool,
}

/// A minimal complex number, for the slide angle's quartic.
#[derive(Debug, Clone, Copy, PartialEq)]
struct C(f64, f64);

impl C {
    fn add(self, o: C) -> C {
        C(self.0 + o.0, self.1 + o.1)
    }
    fn sub(self, o: C) -> C {
        C(self.0 - o.0, self.1 - o.1)
    }
    fn mul(self, o: C) -> C {
        C(self.0 * o.0 - self.1 * o.1, self.0 * o.1 + self.1 * o.0)
    }
    fn div(self, o: C) -> C {
        let d = o.0 * o.0 + o.1 * o.1;
        C(
            (self.0 * o.0 + self.1 * o.1) / d,
            (self.1 * o.0 - self.0 * o.1) / d,
        )
    }
    fn abs(self) -> f64 {
        self.0.hypot(self.1)
    }
    /// `|z|` without hypot's overflow care, for the iteration's moduli of
    /// O(1) numbers (monic coefficients, roots within Cauchy's bound).
    fn norm(self) -> f64 {
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
fn poly_roots(a: &[C]) -> Vec<C> {
    let deg = a.len() - 1;
    let lead = a[deg];
    let monic: Vec<C> = a.iter().map(|&x| x.div(lead)).collect();
    let eval = |z: C| {
        monic
            .iter()
            .rev()
            .fold(C(0.0, 0.0), |acc, &c| acc.mul(z).add(c))
    };
    // Start on a circle of the roots' size (Cauchy's bound), off the axes.
    let radius = 1.0 + monic[..deg].iter().map(|c| c.abs()).fold(0.0, f64::max);
    let mut z: Vec<C> = (0..deg)
        .map(|k| {
            let t = 0.4 + std::f64::consts::TAU * k as f64 / deg as f64;
            C(radius.min(2.0) * t.cos(), radius.min(2.0) * t.sin())
        })
        .collect();
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

/// The single-contact solve of friction.md: free contact-point velocity
/// `c`, normal bias `b ≤ 0`, Delassus block `w`, unit normal `n`, Coulomb
/// coefficient `mu` and the velocity scale `vscale` (for the slide root
/// that is the stick solution itself).
pub fn single_contact(c: DVec3, b: f64, w: &DMat3, n: DVec3, mu: f64, vscale: f64) -> Single {
    let cn = n.dot(c);
    let a = cn + b;
    // 1. Take-off.
    if a >= 0.0 {
        return Single::default();
    }
    let wn = *w * n;
    let w_nn = n.dot(wn);
    if mu == 0.0 {
        return Single {
            impulse: n * (-a / w_nn),
            ..Single::default()
        };
    }
    // 2. Stick: c⁺ = −b n.
    let stick = w.inverse() * (-b * n - c);
    let lambda_stick = n.dot(stick);
    let f_stick = stick - lambda_stick * n;
    let stick_ok = lambda_stick > 0.0 && f_stick.length() <= mu * lambda_stick;
    // 3. Slide: in a tangent basis, the angle θ of ŝ solves the degree-2
    // trigonometric polynomial F(θ) = ŝ⊥ · [D(θ) c_t − a (w_t − μ W_tt ŝ)].
    let (t1, t2) = tangent_basis(n);
    let ct = [t1.dot(c), t2.dot(c)];
    let wt = [t1.dot(wn), t2.dot(wn)];
    let wtt = [
        [t1.dot(*w * t1), t1.dot(*w * t2)],
        [t2.dot(*w * t1), t2.dot(*w * t2)],
    ];
    // Per angle: (D, the vector D c_t − a (w_t − μ W_tt ŝ)).
    let parts = |th: f64| -> (f64, [f64; 2]) {
        let (s, co) = th.sin_cos();
        let sh = [co, s];
        let d = w_nn - mu * (wt[0] * sh[0] + wt[1] * sh[1]);
        let m = [
            wtt[0][0] * sh[0] + wtt[0][1] * sh[1],
            wtt[1][0] * sh[0] + wtt[1][1] * sh[1],
        ];
        let v = [
            d * ct[0] - a * (wt[0] - mu * m[0]),
            d * ct[1] - a * (wt[1] - mu * m[1]),
        ];
        (d, v)
    };
    let f = |th: f64| -> f64 {
        let (s, co) = th.sin_cos();
        let (_, v) = parts(th);
        -s * v[0] + co * v[1]
    };
    let mut candidates = slide_angles(&f);
    candidates.sort_by(f64::total_cmp);
    let mut slides: Vec<(DVec3, f64)> = Vec::new();
    for th in candidates {
        let (d, v) = parts(th);
        if !(d > 0.0) {
            continue;
        }
        let (s, co) = th.sin_cos();
        // c⁺_t = s ŝ with s = ŝ·v / D.
        let speed = (co * v[0] + s * v[1]) / d;
        if !(speed > 1e-9 * vscale) {
            continue;
        }
        let dir = t1 * co + t2 * s;
        let lambda = -a / d;
        let p = lambda * (n - mu * dir);
        if slides
            .iter()
            .any(|(q, _)| (*q - p).length() <= 1e-9 * p.length())
        {
            continue;
        }
        let after = c + *w * p;
        slides.push((p, 0.5 * p.dot(c + after)));
    }
    let count = slides.len() + stick_ok as usize;
    if stick_ok {
        return Single {
            impulse: stick,
            ambiguous: count > 1,
            unsolved: false,
        };
    }
    if let Some(&(p, _)) = slides.iter().min_by(|x, y| x.1.total_cmp(&y.1)) {
        return Single {
            impulse: p,
            ambiguous: count > 1,
            unsolved: false,
        };
    }
    Single {
        impulse: n * ((-cn).max(0.0) / w_nn),
        ambiguous: false,
        unsolved: true,
    }
}

/// Every root in [−π, π) of a trigonometric polynomial of degree at most 2:
/// its Fourier coefficients from eight samples (exact for that degree), the
/// unit-circle roots of `z² F` as a polynomial in `z = e^{iθ}`, each
/// polished by Newton's method on F itself.
fn slide_angles(f: &dyn Fn(f64) -> f64) -> Vec<f64> {
    const N: usize = 8;
    let samples: Vec<f64> = (0..N)
        .map(|k| f(std::f64::consts::TAU * k as f64 / N as f64))
        .collect();
    // F(θ) = Σ_{k=−2}^{2} c_k e^{ikθ}, c_k = (1/N) Σ F_j e^{−ik θ_j}.
    let coef = |k: i32| -> C {
        let (mut re, mut im) = (0.0, 0.0);
        for (j, &x) in samples.iter().enumerate() {
            let t = -std::f64::consts::TAU * (k as f64) * j as f64 / N as f64;
            re += x * t.cos();
            im += x * t.sin();
        }
        C(re / N as f64, im / N as f64)
    };
    let c: Vec<C> = (-2..=2).map(coef).collect();
    let scale = c.iter().map(|x| x.abs()).fold(0.0, f64::max);
    if scale == 0.0 {
        return Vec::new();
    }
    // z² F = Σ c_{k} z^{k+2}; drop vanishing outer pairs (c_{−k} = conj c_k).
    let mut lo = 0;
    let mut hi = 4;
    while hi > lo && c[hi].abs() <= 1e-14 * scale {
        hi -= 1;
        lo += 1;
    }
    if hi == lo {
        return Vec::new();
    }
    let roots = poly_roots(&c[lo..=hi]);
    let df = |th: f64| {
        let h = 1e-6;
        (f(th + h) - f(th - h)) / (2.0 * h)
    };
    let mut out: Vec<f64> = Vec::new();
    for z in roots {
        let r = z.abs();
        if !(r.ln().abs() < 1e-5) {
            continue;
        }
        let mut th = z.1.atan2(z.0);
        // Newton on F, kept only while it improves.
        let mut best = (f(th).abs(), th);
        for _ in 0..8 {
            let d = df(th);
            if d == 0.0 {
                break;
            }
            let next = th - f(th) / d;
            let v = f(next).abs();
            if v < best.0 {
                best = (v, next);
                th = next;
            } else {
                break;
            }
        }
        let th = best.1;
        if out.iter().all(|&o| {
            (((o - th) + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI)
                .abs()
                > 1e-12
        }) {
            out.push(th);
        }
    }
    out
}

/// The touching contacts of one impact, as the frictional laws see them.
#[derive(Debug, Clone)]
pub struct Contacts {
    /// Unit normals, Coulomb coefficients, restitutions.
    pub normals: Vec<DVec3>,
    pub mu: Vec<f64>,
    pub k: Vec<f64>,
    /// Pre-impact contact-point velocities `c⁻_i`.
    pub before: Vec<DVec3>,
    /// Delassus blocks, `w[i][j] = W_ij`.
    pub w: Vec<Vec<DMat3>>,
    /// `|v| + L|ω|` before the impact (m/s), and `m` times it (N·s).
    pub vscale: f64,
    pub pscale: f64,
}

impl Contacts {
    /// Contacts at body-frame points `points` with the given planes' data.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        body: &Ellipsoid,
        rotation: DMat3,
        velocity: DVec3,
        omega: DVec3,
        points: &[DVec3],
        normals: Vec<DVec3>,
        mu: Vec<f64>,
        k: Vec<f64>,
    ) -> Self {
        let before = points
            .iter()
            .map(|&x| velocity + rotation * omega.cross(x))
            .collect();
        let w = points
            .iter()
            .map(|&xi| {
                points
                    .iter()
                    .map(|&xj| delassus(body, rotation, xi, xj))
                    .collect()
            })
            .collect();
        let vscale = velocity.length() + body.length_scale() * omega.length();
        Self {
            normals,
            mu,
            k,
            before,
            w,
            vscale,
            pscale: body.mass() * vscale,
        }
    }

    fn len(&self) -> usize {
        self.normals.len()
    }

    /// Newton's normal bias `b_i = k_i min(c⁻_n,i, 0)` (or zero: plastic).
    fn bias(&self, i: usize, plastic: bool) -> f64 {
        if plastic {
            0.0
        } else {
            self.k[i] * self.normals[i].dot(self.before[i]).min(0.0)
        }
    }
}

/// Impulses of a frictional solve and what it flagged.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Solved {
    pub impulses: Vec<DVec3>,
    pub ambiguous: bool,
    pub unsolved: bool,
    /// Newton's Gauss–Seidel did not converge; the plastic (k = 0) one did.
    pub jammed: bool,
    /// Neither converged: the caller uses the frictionless `newton` result.
    pub unconverged: bool,
}

/// Gauss–Seidel sweeps from P = 0: each visit replaces `P_i` by the
/// single-contact solve with `c = c⁻_i + Σ_{j≠i} W_ij P_j`. With
/// `sweeps = None` it runs to the limit (no impulse moved by more than
/// 1e-13 of the impulse scale in a sweep) or 10 000 sweeps; `converged`
/// says which. Flags come from each contact's last visit.
fn gauss_seidel(ct: &Contacts, sweeps: Option<u32>, plastic: bool) -> (Solved, bool) {
    const LIMIT: u32 = 10_000;
    let n = ct.len();
    let mut p = vec![DVec3::ZERO; n];
    let mut last = vec![Single::default(); n];
    let max = sweeps.unwrap_or(LIMIT);
    let mut converged = false;
    for _ in 0..max {
        let mut moved = 0f64;
        for i in 0..n {
            let mut c = ct.before[i];
            for (j, pj) in p.iter().enumerate() {
                if j != i {
                    c += ct.w[i][j] * *pj;
                }
            }
            let s = single_contact(
                c,
                ct.bias(i, plastic),
                &ct.w[i][i],
                ct.normals[i],
                ct.mu[i],
                ct.vscale,
            );
            moved = moved.max((s.impulse - p[i]).length());
            p[i] = s.impulse;
            last[i] = s;
        }
        if sweeps.is_none() && moved <= 1e-13 * ct.pscale {
            converged = true;
            break;
        }
    }
    let solved = Solved {
        impulses: p,
        ambiguous: last.iter().any(|s| s.ambiguous),
        unsolved: last.iter().any(|s| s.unsolved),
        ..Solved::default()
    };
    (solved, converged || sweeps.is_some())
}

/// `newton` with friction: the Gauss–Seidel limit; if it does not
/// converge, the same with every k = 0 (`jammed`); if that does not
/// either, `unconverged` (the caller substitutes the frictionless result).
pub fn newton(ct: &Contacts) -> Solved {
    let (s, ok) = gauss_seidel(ct, None, false);
    if ok {
        return s;
    }
    let (mut s, ok) = gauss_seidel(ct, None, true);
    s.jammed = true;
    if !ok {
        s.unconverged = true;
    }
    s
}

/// `pgsN` with friction: `sweeps` sweeps of the same Gauss–Seidel.
pub fn pgs(ct: &Contacts, sweeps: u32) -> Solved {
    gauss_seidel(ct, Some(sweeps), false).0
}

/// `paper` with friction: each approaching contact alone (its own `c⁻`,
/// `W_ii`), the impulses summed.
pub fn paper(ct: &Contacts) -> Solved {
    let mut out = Solved::default();
    for i in 0..ct.len() {
        let s = if ct.normals[i].dot(ct.before[i]) < 0.0 {
            single_contact(
                ct.before[i],
                ct.bias(i, false),
                &ct.w[i][i],
                ct.normals[i],
                ct.mu[i],
                ct.vscale,
            )
        } else {
            Single::default()
        };
        out.ambiguous |= s.ambiguous;
        out.unsolved |= s.unsolved;
        out.impulses.push(s.impulse);
    }
    out
}

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

    /// One Dormand–Prince 5(4) step: the fifth-order result and the
    /// difference to the embedded fourth-order one.
    fn step(&self, mode: Mode, p: f64, y: [f64; 3], h: f64) -> ([f64; 3], [f64; 3]) {
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
        let mut k = [[0.0; 3]; 7];
        k[0] = self.rhs(mode, p, y);
        for s in 0..6 {
            let mut ys = y;
            for (i, yi) in ys.iter_mut().enumerate() {
                for (j, kj) in k.iter().enumerate().take(s + 1) {
                    *yi += h * A[s][j] * kj[i];
                }
            }
            k[s + 1] = self.rhs(mode, p + CN[s] * h, ys);
        }
        // The seventh stage is at the fifth-order result (FSAL).
        let mut y5 = y;
        for (i, yi) in y5.iter_mut().enumerate() {
            for j in 0..6 {
                *yi += h * A[5][j] * k[j][i];
            }
        }
        let mut err = [0.0; 3];
        for (i, e) in err.iter_mut().enumerate() {
            let mut y4 = y[i];
            for (j, kj) in k.iter().enumerate() {
                y4 += h * B4[j] * kj[i];
            }
            *e = y5[i] - y4;
        }
        (y5, err)
    }
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
/// events of the step located by regula falsi; once the slip has stopped
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
        // The event of this phase, as a function that turns ≥ 0.
        let event = |q: f64, yq: [f64; 3]| -> f64 {
            let cn = path.cn(q, [yq[0], yq[1]]);
            match end_work {
                None => cn / vs,
                // c_n turning negative again also ends the impact.
                Some(target) => ((yq[2] - target) / (p_scale * vs)).max(-cn / vs),
            }
        };
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
