//! The single-contact solve (friction.md §3): take-off, stick, and the
//! slide roots of a degree-2 trigonometric polynomial in the slip angle.

use glam::{DMat3, DVec3};

use super::roots::{poly_roots, C};
use super::tangent_basis;

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
