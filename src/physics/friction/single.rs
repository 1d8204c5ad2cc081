//! The single-contact solve (friction.md §3): take-off, stick, and the
//! slide roots of a degree-2 trigonometric polynomial in the slip angle.

use glam::{DMat3, DVec3};

use super::roots::{poly_roots, C, MAX_DEGREE};
use super::tangent_basis;

/// Which case of the single-contact solve an impulse is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Case {
    /// `c_n + b ≥ 0`: no impulse.
    #[default]
    TakeOff,
    /// μ = 0 and approaching: a normal impulse.
    Normal,
    /// `c⁺ = −b n` inside the cone.
    Stick,
    /// `P = λ(n − μ ŝ)` with `c⁺_t = s ŝ`, `s > 0`.
    Slide,
    /// No valid case: the frictionless fallback.
    Unsolved,
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
    /// The case the impulse is.
    pub case: Case,
}

/// friction.md's certificate B3, which depends on W and μ only: with
/// `S = W_tt − w_t w_tᵀ/W_nn`,
/// `(μ/W_nn)(|w_t| + sqrt(λ_max(S) · w_tᵀ S⁻¹ w_t)) < 2` (here with a
/// relative margin of 1e-9). Where it holds, a valid stick excludes every
/// valid slide root, and without a valid stick exactly one slide root is
/// valid.
pub fn certified(w: &DMat3, n: DVec3, mu: f64) -> bool {
    let (t1, t2) = tangent_basis(n);
    let wn = *w * n;
    let wtt = [
        [t1.dot(*w * t1), t1.dot(*w * t2)],
        [t2.dot(*w * t1), t2.dot(*w * t2)],
    ];
    b3(n.dot(wn), [t1.dot(wn), t2.dot(wn)], wtt, mu)
}

/// B3 in a tangent basis: `W_nn`, `w_t` and `W_tt`.
fn b3(w_nn: f64, wt: [f64; 2], wtt: [[f64; 2]; 2], mu: f64) -> bool {
    let s00 = wtt[0][0] - wt[0] * wt[0] / w_nn;
    let s11 = wtt[1][1] - wt[1] * wt[1] / w_nn;
    let s01 = 0.5 * (wtt[0][1] + wtt[1][0]) - wt[0] * wt[1] / w_nn;
    let det = s00 * s11 - s01 * s01;
    if !(det > 0.0 && s00 > 0.0) {
        return false;
    }
    let half_tr = 0.5 * (s00 + s11);
    let lambda_max = half_tr + (0.25 * (s00 - s11) * (s00 - s11) + s01 * s01).sqrt();
    // w_tᵀ S⁻¹ w_t with S⁻¹ = adj(S)/det.
    let q = (s11 * wt[0] * wt[0] - 2.0 * s01 * wt[0] * wt[1] + s00 * wt[1] * wt[1]) / det;
    let wt_len = (wt[0] * wt[0] + wt[1] * wt[1]).sqrt();
    mu / w_nn * (wt_len + (lambda_max * q.max(0.0)).sqrt()) < 2.0 * (1.0 - 1e-9)
}

/// The single-contact solve of friction.md: free contact-point velocity
/// `c`, normal bias `b ≤ 0`, Delassus block `w`, unit normal `n`, Coulomb
/// coefficient `mu` and the velocity scale `vscale` (for the slide root
/// that is the stick solution itself).
pub fn single_contact(c: DVec3, b: f64, w: &DMat3, n: DVec3, mu: f64, vscale: f64) -> Single {
    solve(c, b, w, n, mu, vscale, true)
}

/// [`single_contact`] without B3's shortcuts: every case tried, every
/// slide root searched (what the certificate is tested against).
pub fn single_contact_full(c: DVec3, b: f64, w: &DMat3, n: DVec3, mu: f64, vscale: f64) -> Single {
    solve(c, b, w, n, mu, vscale, false)
}

fn solve(c: DVec3, b: f64, w: &DMat3, n: DVec3, mu: f64, vscale: f64, shortcut: bool) -> Single {
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
            case: Case::Normal,
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
    // Where B3 certifies the solve, a valid stick is the only solution.
    let certain = shortcut && b3(w_nn, wt, wtt, mu);
    if certain && stick_ok {
        return Single {
            impulse: stick,
            case: Case::Stick,
            ..Single::default()
        };
    }
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
    // The slide impulse at angle `th`, if the root there is valid: D > 0
    // and a sliding speed s beyond the stick solution's own.
    let slide_at = |th: f64| -> Option<DVec3> {
        let (d, v) = parts(th);
        if !(d > 0.0) {
            return None;
        }
        let (s, co) = th.sin_cos();
        // c⁺_t = s ŝ with s = ŝ·v / D.
        let speed = (co * v[0] + s * v[1]) / d;
        if !(speed > 1e-9 * vscale) {
            return None;
        }
        let dir = t1 * co + t2 * s;
        Some(-a / d * (n - mu * dir))
    };
    if certain {
        // Exactly one valid slide root: Newton's method on F from the
        // direction of c_t + (−a/W_nn) w_t (the sliding direction under
        // the frictionless normal impulse), kept if it lands on a valid
        // root; else the full search below.
        let g = [ct[0] - a / w_nn * wt[0], ct[1] - a / w_nn * wt[1]];
        if g[0] != 0.0 || g[1] != 0.0 {
            let mut th = g[1].atan2(g[0]);
            let scale = (w_nn + mu * wt[0].hypot(wt[1])) * (ct[0].hypot(ct[1]) + a.abs());
            // F and dF/dθ: with ŝ = (cos θ, sin θ) and ŝ⊥ = (−sin θ, cos θ),
            // F = ŝ⊥·v and F' = −ŝ·v + ŝ⊥·(D' c_t + a μ W_tt ŝ⊥),
            // D' = −μ w_t·ŝ⊥.
            let f_df = |th: f64| -> (f64, f64) {
                let (sn, co) = th.sin_cos();
                let (_, v) = parts(th);
                let dd = -mu * (-wt[0] * sn + wt[1] * co);
                let mp = [
                    -wtt[0][0] * sn + wtt[0][1] * co,
                    -wtt[1][0] * sn + wtt[1][1] * co,
                ];
                let dv = [dd * ct[0] + a * mu * mp[0], dd * ct[1] + a * mu * mp[1]];
                (
                    -sn * v[0] + co * v[1],
                    -(co * v[0] + sn * v[1]) + (-sn * dv[0] + co * dv[1]),
                )
            };
            for _ in 0..16 {
                let (fx, df) = f_df(th);
                if df == 0.0 || !fx.is_finite() {
                    break;
                }
                let step = (fx / df).clamp(-0.5, 0.5);
                th -= step;
                if step.abs() <= 1e-14 {
                    break;
                }
            }
            if f(th).abs() <= 1e-12 * scale {
                if let Some(p) = slide_at(th) {
                    return Single {
                        impulse: p,
                        case: Case::Slide,
                        ..Single::default()
                    };
                }
            }
        }
    }
    let (mut candidates, found) = slide_angles(&f);
    let candidates = &mut candidates[..found];
    candidates.sort_by(f64::total_cmp);
    // At most one slide per root, on the stack.
    let mut all_slides = [(DVec3::ZERO, 0.0); MAX_DEGREE];
    let mut kept = 0;
    for &th in candidates.iter() {
        let Some(p) = slide_at(th) else {
            continue;
        };
        if all_slides[..kept]
            .iter()
            .any(|(q, _)| (*q - p).length() <= 1e-9 * p.length())
        {
            continue;
        }
        let after = c + *w * p;
        all_slides[kept] = (p, 0.5 * p.dot(c + after));
        kept += 1;
    }
    let slides = &all_slides[..kept];
    let count = slides.len() + stick_ok as usize;
    if stick_ok {
        return Single {
            impulse: stick,
            ambiguous: count > 1,
            unsolved: false,
            case: Case::Stick,
        };
    }
    if let Some(&(p, _)) = slides.iter().min_by(|x, y| x.1.total_cmp(&y.1)) {
        return Single {
            impulse: p,
            ambiguous: count > 1,
            unsolved: false,
            case: Case::Slide,
        };
    }
    Single {
        impulse: n * ((-cn).max(0.0) / w_nn),
        ambiguous: false,
        unsolved: true,
        case: Case::Unsolved,
    }
}

/// Every root in [−π, π) of a trigonometric polynomial of degree at most 2:
/// its Fourier coefficients from eight samples (exact for that degree), the
/// unit-circle roots of `z² F` as a polynomial in `z = e^{iθ}`, each
/// polished by Newton's method on F itself. On the stack: the first `n`
/// entries of the array are the roots.
fn slide_angles(f: &dyn Fn(f64) -> f64) -> ([f64; MAX_DEGREE], usize) {
    const N: usize = 8;
    let samples: [f64; N] = std::array::from_fn(|k| f(std::f64::consts::TAU * k as f64 / N as f64));
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
    let c: [C; 5] = std::array::from_fn(|i| coef(i as i32 - 2));
    let mut out = [0.0; MAX_DEGREE];
    let mut n = 0;
    let scale = c.iter().map(|x| x.abs()).fold(0.0, f64::max);
    if scale == 0.0 {
        return (out, n);
    }
    // z² F = Σ c_{k} z^{k+2}; drop vanishing outer pairs (c_{−k} = conj c_k).
    let mut lo = 0;
    let mut hi = 4;
    while hi > lo && c[hi].abs() <= 1e-14 * scale {
        hi -= 1;
        lo += 1;
    }
    if hi == lo {
        return (out, n);
    }
    let roots = poly_roots(&c[lo..=hi]);
    let roots = &roots[..hi - lo];
    let df = |th: f64| {
        let h = 1e-6;
        (f(th + h) - f(th - h)) / (2.0 * h)
    };
    for &z in roots {
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
        if out[..n].iter().all(|&o| {
            (((o - th) + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI)
                .abs()
                > 1e-12
        }) {
            out[n] = th;
            n += 1;
        }
    }
    (out, n)
}
