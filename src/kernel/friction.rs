//! Coulomb friction in lanes (friction.md): each touching plane's contact
//! frame, the single-contact solve (take-off, stick, slide) with a
//! certificate, and the laws `newton` (Gauss–Seidel to its limit), `pgsN`
//! and `paper` as visits of it.
//!
//! Contact i has three directions d ∈ {n, t₁, t₂} (its normal and a tangent
//! basis fixed per plane, in the world frame) and for each the body-frame
//! lever `r = x_i × Aᵀd`. The contact-point velocity along d is
//! `c_d = d·v + r·ω`; impulse components `P_d` change v by `Σ P_d d / m`
//! and ω by `J⁻¹ Σ P_d r`. The Delassus block in these coordinates is
//! `W_de = δ_de/m + Σ_k r_d,k r_e,k / J_k` (friction.md, "Kinematics").
//!
//! The slide angle θ of `ŝ = cos θ t₁ + sin θ t₂` solves
//! `F(θ) = ŝ⊥·[D(θ) c_t − a (w_t − μ W_tt ŝ)] = 0` (friction.md, case 3), a
//! trigonometric polynomial of degree 2 with closed-form coefficients
//! ([`Slide`]), so it has at most four roots. They are located on a fixed
//! grid of 32 intervals: each interval must be certified root-free, or to
//! hold exactly one root (F monotone there, or convex or concave with a
//! sign change), from F and its derivatives at the interval's ends and a
//! bound on the next derivative ([`positive_on`]). Each root is refined by
//! a fixed count of safeguarded Newton steps in its interval and judged
//! where it is: valid when D > 0 and its sliding speed N/D exceeds the stick
//! threshold, both clear of the margins. A lane is solved here only when
//! exactly one valid case remains (stick, or one slide root) and every
//! decision on the way is clear of its boundary by a margin above the lane
//! type's rounding; otherwise (several valid cases: `ambiguous`; none:
//! `unsolved`; a decision within its margin; Gauss–Seidel not converged)
//! it is flagged [`RECOMPUTE`] and solved by the f64 reference.
//!
//! Each step is a pass over the lanes of a block with its state in
//! [`Solve`], so that every loop vectorises; the passes run inside the
//! multiversioned entry points of `engine/batch.rs`, whose reference
//! arguments tell the compiler the arrays do not overlap.

// Lane code indexes SoA arrays by lane and contact on purpose: the index
// form is what the loop vectoriser sees through.
#![allow(clippy::needless_range_loop, clippy::manual_memcpy)]

use super::geometry::dot3;
use crate::kernel::*;
use crate::lanes::dispatch::BLOCK;
use crate::lanes::{select, Real};

/// Intervals of the slide angle's grid over [0, 2π).
const GRID: usize = 32;

/// Contact i's last visit took the stick case (bit `STICK_SHIFT + i` of
/// the sweep bits).
const STICK_SHIFT: u32 = 0;
/// Some visit of the lane could not be certified.
const UNSURE: u32 = 1 << 8;
/// Contact i's velocity changed after its last visit (bit
/// `MOVED_SHIFT + i`): another contact's impulse moved since.
const MOVED_SHIFT: u32 = 12;

/// The friction constants of a scene for the lane kernel.
#[derive(Debug, Clone)]
pub struct FrictionConsts<T, const N: usize> {
    /// A touching plane has μ > 0: the scene runs this kernel.
    pub on: bool,
    mu: [T; N],
    /// t₁, t₂ of each touching plane (world): the tangent basis the
    /// reference uses, though no result depends on it.
    tangent: [[[T; 3]; 2]; N],
    /// cos θ_j, sin θ_j, cos 2θ_j, sin 2θ_j at θ_j = 2πj/GRID, j ≤ GRID.
    grid: [[T; 4]; GRID + 1],
    /// The grid step 2π/GRID and half of it.
    h: T,
    half_h: T,
    /// Decisions closer than these to their boundary are not taken here:
    /// `take_off_band`, |a| against 0 and a contact's final sliding speed
    /// against friction.md's stick threshold, relative to the velocity
    /// scale; `stick_band`, |f| against μλ in the stick test, relative;
    /// `slide_hi` and `slide_lo`, a slide root's speed above and below the
    /// threshold, relative to the velocity scale; `round`, the
    /// certificate's values, relative to their terms' magnitude.
    take_off_band: T,
    stick_band: T,
    slide_hi: T,
    slide_lo: T,
    round: T,
    /// The refined angle's last Newton step must be below this (rad).
    angle_tol: T,
    /// Gauss–Seidel's stopping rule: no impulse moved by more than this
    /// times `m (|v| + L|ω|)` in a sweep (friction.md: 1e-13 in f64).
    gs_tol: T,
    /// Sweeps after which a block's unconverged lanes go to the reference.
    gs_max: u32,
}

impl<T: Real, const N: usize> FrictionConsts<T, N> {
    pub fn new(scene: &Scene) -> Self {
        let f32_lanes = T::EPSILON.to_f64() > 1e-10;
        let planes = scene.touching_planes();
        let tau = std::f64::consts::TAU;
        let h = tau / GRID as f64;
        // friction.md's stick threshold for a slide root's speed.
        let stick_speed = 1e-9;
        let band = if f32_lanes { 1e-4 } else { 1e-12 };
        Self {
            on: planes.iter().any(|p| p.friction() > 0.0),
            mu: std::array::from_fn(|i| T::from_f64(planes[i].friction())),
            tangent: std::array::from_fn(|i| {
                let n = planes[i].normal();
                let t1 = n.any_orthonormal_vector();
                [t1, n.cross(t1)].map(|t| t.to_array().map(T::from_f64))
            }),
            grid: std::array::from_fn(|j| {
                let t = tau * (j % GRID) as f64 / GRID as f64;
                [t.cos(), t.sin(), (2.0 * t).cos(), (2.0 * t).sin()].map(T::from_f64)
            }),
            h: T::from_f64(h),
            half_h: T::from_f64(0.5 * h),
            take_off_band: T::from_f64(if f32_lanes { 1e-5 } else { 1e-12 }),
            stick_band: T::from_f64(band),
            slide_hi: T::from_f64(stick_speed + band),
            slide_lo: T::from_f64(stick_speed - band),
            round: T::from_f64(if f32_lanes { 1e-5 } else { 1e-12 }),
            angle_tol: T::from_f64(if f32_lanes { 1e-5 } else { 1e-12 }),
            gs_tol: T::from_f64(if f32_lanes { 2e-6 } else { 1e-13 }),
            gs_max: if f32_lanes { 64 } else { 200 },
        }
    }
}

/// The contact frames of a block: levers, pre-impact contact-point
/// velocities and Delassus blocks per touching plane. Cache-line aligned.
#[repr(C, align(64))]
pub struct Frame<T, const N: usize> {
    /// `lever[i][d][k]`: component k of `x_i × Aᵀd`, d = n, t₁, t₂.
    lever: [[[[T; BLOCK]; 3]; 3]; N],
    /// `c0[i][d]`: `c⁻_i · d`.
    c0: [[[T; BLOCK]; 3]; N],
    /// W_ii in the frame: nn, nt₁, nt₂, t₁t₁, t₁t₂, t₂t₂.
    w: [[[T; BLOCK]; 6]; N],
    /// `|v| + L|ω|` before the impact.
    vscale: [T; BLOCK],
}

/// Gauss–Seidel state of one law on a block.
#[repr(C, align(64))]
pub struct Sweep<T, const N: usize> {
    /// `p[i][d]`: contact i's impulse along d (N·s).
    p: [[[T; BLOCK]; 3]; N],
    /// What the impulses have changed so far: v (world) and ω (body).
    dv: [[T; BLOCK]; 3],
    dw: [[T; BLOCK]; 3],
    /// The largest |ΔP_i| of the current sweep.
    moved: [T; BLOCK],
    /// Stick bits per contact and [`UNSURE`].
    bits: [u32; BLOCK],
    /// The current visit's single-contact solve.
    solve: Solve<T>,
}

impl<T: Real, const N: usize> Frame<T, N> {
    pub fn new() -> Box<Self> {
        Box::new(Self {
            lever: [[[[T::ZERO; BLOCK]; 3]; 3]; N],
            c0: [[[T::ZERO; BLOCK]; 3]; N],
            w: [[[T::ZERO; BLOCK]; 6]; N],
            vscale: [T::ZERO; BLOCK],
        })
    }
}

impl<T: Real, const N: usize> Sweep<T, N> {
    pub fn new() -> Box<Self> {
        Box::new(Self {
            p: [[[T::ZERO; BLOCK]; 3]; N],
            dv: [[T::ZERO; BLOCK]; 3],
            dw: [[T::ZERO; BLOCK]; 3],
            moved: [T::ZERO; BLOCK],
            bits: [0; BLOCK],
            solve: Solve::empty(),
        })
    }
}

/// The contact frames of a block, and the geometry the statistics read
/// (normal velocities, T⁻, approach bits; in f32 grazing lanes flagged as
/// in [`geometry`]).
#[inline(always)]
pub fn frame<T: Real, const N: usize>(
    c: &Consts<T, N>,
    x: &Inputs<T>,
    fr: &mut Frame<T, N>,
    geo: &mut Geometry<T, N>,
) {
    let f32_lanes = T::EPSILON.to_f64() > 1e-10;
    for s in 0..BLOCK {
        let a: [T; 9] = std::array::from_fn(|k| x.a[k][s]);
        let v = [x.v[0][s], x.v[1][s], x.v[2][s]];
        let w = [x.w[0][s], x.w[1][s], x.w[2][s]];
        let vscale = c.length.mul_add(dot3(w, w).sqrt(), dot3(v, v).sqrt());
        let mut status = 0u32;
        for i in 0..N {
            let dirs = [c.normal[i], c.fr.tangent[i][0], c.fr.tangent[i][1]];
            // Aᵀd for each direction: the body-frame directions.
            let body: [[T; 3]; 3] = std::array::from_fn(|d| {
                std::array::from_fn(|col| dot3([a[col], a[3 + col], a[6 + col]], dirs[d]))
            });
            let u = body[0];
            let h = dot3([c.semi2[0] * u[0], c.semi2[1] * u[1], c.semi2[2] * u[2]], u).sqrt();
            let minus_inv_h = -T::ONE / h;
            // The support point x = −diag(a², b², c²) u / h (physics.md §2).
            let p: [T; 3] = std::array::from_fn(|k| c.semi2[k] * u[k] * minus_inv_h);
            let lever: [[T; 3]; 3] = std::array::from_fn(|d| {
                let e = body[d];
                [
                    p[1] * e[2] - p[2] * e[1],
                    p[2] * e[0] - p[0] * e[2],
                    p[0] * e[1] - p[1] * e[0],
                ]
            });
            for d in 0..3 {
                for k in 0..3 {
                    fr.lever[i][d][k][s] = lever[d][k];
                }
                fr.c0[i][d][s] = dot3(lever[d], w) + dot3(dirs[d], v);
            }
            let wde = |d: usize, e: usize| {
                let mut x = if d == e { c.inv_mass } else { T::ZERO };
                for k in 0..3 {
                    x = (lever[d][k] * lever[e][k]).mul_add(c.inv_inertia[k], x);
                }
                x
            };
            let blocks = [
                wde(0, 0),
                wde(0, 1),
                wde(0, 2),
                wde(1, 1),
                wde(1, 2),
                wde(2, 2),
            ];
            for m in 0..6 {
                fr.w[i][m][s] = blocks[m];
            }
            let vn = fr.c0[i][0][s];
            geo.vn[i][s] = vn;
            status |= ((vn < T::ZERO) as u32) << (APPROACHING_SHIFT + i as u32);
            status |= bit(f32_lanes && vn.abs() < c.graze * vscale, RECOMPUTE);
        }
        fr.vscale[s] = vscale;
        geo.t_before[s] = T::HALF
            * c.mass.mul_add(
                dot3(v, v),
                dot3(
                    [
                        c.inertia[0] * w[0],
                        c.inertia[1] * w[1],
                        c.inertia[2] * w[2],
                    ],
                    w,
                ),
            );
        geo.status[s] = status;
    }
}

/// The slide case's trigonometric polynomials (friction.md, case 3), with
/// `ŝ = (cos θ, sin θ)` in the tangent basis and `v(θ) = D(θ) c_t −
/// a (w_t − μ W_tt ŝ)`, `D(θ) = W_nn − μ w_t·ŝ`:
/// - `F(θ) = ŝ⊥·v = A0 + A1 cos θ + B1 sin θ + A2 cos 2θ + B2 sin 2θ`, whose
///   roots are the slide directions;
/// - `N(θ) = ŝ·v = N0 − B1 cos θ + A1 sin θ − B2 cos 2θ + A2 sin 2θ`, the
///   sliding speed times D at a root.
///
/// (Expand the products with cos²θ = (1 + cos 2θ)/2, sin θ cos θ =
/// sin 2θ / 2 and sin²θ = (1 − cos 2θ)/2.)
#[derive(Debug, Clone, Copy)]
struct Slide<T> {
    a0: T,
    a1: T,
    b1: T,
    a2: T,
    b2: T,
    n0: T,
}

impl<T: Real> Slide<T> {
    /// From μ, the free tangential velocity `ct`, `a = c_n + b` and the
    /// Delassus block (nn, nt₁, nt₂, t₁t₁, t₁t₂, t₂t₂).
    #[inline(always)]
    fn new(mu: T, ct: [T; 2], a: T, w: [T; 6]) -> Self {
        let [wnn, w1, w2, p, q, r] = w;
        let [c1, c2] = ct;
        let hm = T::HALF * mu;
        let am = a * mu;
        Self {
            a0: hm * w2.mul_add(c1, -(w1 * c2)),
            a1: wnn.mul_add(c2, -(a * w2)),
            b1: a.mul_add(w1, -(wnn * c1)),
            a2: am.mul_add(q, -(hm * w1.mul_add(c2, w2 * c1))),
            b2: (T::HALF * am).mul_add(r - p, -(hm * w2.mul_add(c2, -(w1 * c1)))),
            n0: (T::HALF * am).mul_add(p + r, -(hm * w1.mul_add(c1, w2 * c2))),
        }
    }

    /// F, F′, F″, F‴, F⁗ at the angle with (cos θ, sin θ, cos 2θ, sin 2θ)
    /// = `g`.
    #[inline(always)]
    fn at(&self, g: [T; 4]) -> [T; 5] {
        let Self {
            a0, a1, b1, a2, b2, ..
        } = *self;
        let [cs, sn, c2t, s2t] = g;
        let two = T::ONE + T::ONE;
        let four = two + two;
        let eight = four + four;
        [
            b2.mul_add(s2t, a2.mul_add(c2t, b1.mul_add(sn, a1.mul_add(cs, a0)))),
            (two * b2).mul_add(c2t, (-two * a2).mul_add(s2t, b1.mul_add(cs, -(a1 * sn)))),
            (-four * b2).mul_add(
                s2t,
                (-four * a2).mul_add(c2t, (-b1).mul_add(sn, -(a1 * cs))),
            ),
            (-eight * b2).mul_add(c2t, (eight * a2).mul_add(s2t, (-b1).mul_add(cs, a1 * sn))),
            (eight * two * b2).mul_add(
                s2t,
                (eight * two * a2).mul_add(c2t, b1.mul_add(sn, a1 * cs)),
            ),
        ]
    }

    /// N at the angle with (cos θ, sin θ, cos 2θ, sin 2θ) = `g`.
    #[inline(always)]
    fn numerator(&self, g: [T; 4]) -> T {
        let Self {
            a1, b1, a2, b2, n0, ..
        } = *self;
        let [cs, sn, c2t, s2t] = g;
        a2.mul_add(
            s2t,
            (-b2).mul_add(c2t, a1.mul_add(sn, (-b1).mul_add(cs, n0))),
        )
    }
}

/// Whether `g > m` on a whole grid interval, from g, g′ and g″ at both
/// ends and `l3 ≥ |g‴|`. On the half next to an end, g″ ≥ κ = g″(end) −
/// l3·h/2, so g lies above the quadratic with that value, slope and
/// curvature κ; the quadratic's least value on the half is at one of its
/// ends or at its vertex (clamped into the half).
#[inline(always)]
fn positive_on<T: Real, const N: usize>(
    fc: &FrictionConsts<T, N>,
    g: [T; 2],
    slope: [T; 2],
    curve: [T; 2],
    l3: T,
    m: T,
) -> bool {
    let half = fc.half_h;
    // From the left end in t ≥ 0, from the right end in t = θ_j+1 − θ ≥ 0.
    let side = |g0: T, s0: T, c0: T| {
        let kappa = l3.mul_add(-half, c0);
        let vertex = (-s0 / kappa).max(T::ZERO).min(half);
        let q = |t: T| (T::HALF * kappa).mul_add(t * t, s0.mul_add(t, g0));
        (q(half) > m) & (q(vertex) > m)
    };
    (g[0] > m) & (g[1] > m) & side(g[0], slope[0], curve[0]) & side(g[1], -slope[1], curve[1])
}

/// One contact's single-contact solve across a block, pass by pass (each
/// pass a loop over the lanes, so that it vectorises): the set-up with the
/// stick case, the grid intervals, the refinement of each root, the
/// choice. Cache-line aligned; one per worker.
#[repr(C, align(64))]
struct Solve<T> {
    /// `a = c_n + b` of the free contact-point velocity.
    a: [T; BLOCK],
    /// The stick case's impulse, and whether it is valid, or clearly not.
    stick: [[T; BLOCK]; 3],
    stick_ok: [bool; BLOCK],
    stick_no: [bool; BLOCK],
    /// [`Slide`]'s coefficients: A0, A1, B1, A2, B2, N0.
    coef: [[T; BLOCK]; 6],
    /// Bounds on |F‴|, |F⁗| and |F⁽⁵⁾|, and the margins of F (and N) and
    /// of D.
    l3: [T; BLOCK],
    l4: [T; BLOCK],
    l5: [T; BLOCK],
    m_f: [T; BLOCK],
    m_d: [T; BLOCK],
    /// F, F′, F″, F‴, F⁗ at the current interval's left end.
    left: [[T; BLOCK]; 5],
    /// Sign changes of F so far, and whether every interval was certified.
    changes: [T; BLOCK],
    grid_ok: [bool; BLOCK],
    /// Per sign change (at most four): the interval index j, F(θ_j),
    /// F(θ_j+1).
    slot: [[[T; BLOCK]; 3]; 4],
    /// The refinement of the current root: cos θ_j, sin θ_j, t, lo, hi and
    /// the last step.
    newton: [[T; BLOCK]; 6],
    /// Valid slide roots, the last one's direction, and whether every root
    /// was judged clear of the margins.
    count: [T; BLOCK],
    dir: [[T; BLOCK]; 2],
    roots_ok: [bool; BLOCK],
}

impl<T: Real> Solve<T> {
    fn empty() -> Self {
        let z = [T::ZERO; BLOCK];
        Self {
            a: z,
            stick: [z; 3],
            stick_ok: [false; BLOCK],
            stick_no: [false; BLOCK],
            coef: [z; 6],
            l3: z,
            l4: z,
            l5: z,
            m_f: z,
            m_d: z,
            left: [z; 5],
            changes: z,
            grid_ok: [false; BLOCK],
            slot: [[z; 3]; 4],
            newton: [z; 6],
            count: z,
            dir: [z; 2],
            roots_ok: [false; BLOCK],
        }
    }
}

/// The Delassus block of contact i in lane s.
#[inline(always)]
fn w_of<T: Real, const N: usize>(fr: &Frame<T, N>, i: usize, s: usize) -> [T; 6] {
    std::array::from_fn(|m| fr.w[i][m][s])
}

/// Set-up of a visit of contact i: the free velocity (with the other
/// contacts' impulses when `COUPLED`), `a` with Newton's bias
/// `b = k min(c⁻_n, 0)`, the stick case (`W P = (−a, −c_t)` by the
/// symmetric cofactors), and the slide polynomials with their bounds and
/// margins.
#[inline(always)]
fn setup<T: Real, const N: usize, const COUPLED: bool>(
    c: &Consts<T, N>,
    i: usize,
    fr: &Frame<T, N>,
    sw: &mut Sweep<T, N>,
) {
    let fc = &c.fr;
    let dirs = [c.normal[i], fc.tangent[i][0], fc.tangent[i][1]];
    let mu = fc.mu[i];
    let Sweep {
        p, dv, dw, solve, ..
    } = sw;
    let k = &mut *solve;
    for s in 0..BLOCK {
        let w = w_of(fr, i, s);
        let mut cf = [fr.c0[i][0][s], fr.c0[i][1][s], fr.c0[i][2][s]];
        if COUPLED {
            let old = [p[i][0][s], p[i][1][s], p[i][2][s]];
            let dv = [dv[0][s], dv[1][s], dv[2][s]];
            let dw = [dw[0][s], dw[1][s], dw[2][s]];
            // W_ii P_i, to take this contact's own impulse out.
            let own = [
                dot3([w[0], w[1], w[2]], old),
                dot3([w[1], w[3], w[4]], old),
                dot3([w[2], w[4], w[5]], old),
            ];
            for d in 0..3 {
                let lever = [
                    fr.lever[i][d][0][s],
                    fr.lever[i][d][1][s],
                    fr.lever[i][d][2][s],
                ];
                cf[d] = cf[d] + dot3(dirs[d], dv) + dot3(lever, dw) - own[d];
            }
        }
        let a = c.k[i].mul_add(fr.c0[i][0][s].min(T::ZERO), cf[0]);
        let [wnn, w1, w2, pp, q, r] = w;
        let [_, c1, c2] = cf;
        let k00 = pp.mul_add(r, -(q * q));
        let k01 = w2.mul_add(q, -(w1 * r));
        let k02 = w1.mul_add(q, -(pp * w2));
        let k11 = wnn.mul_add(r, -(w2 * w2));
        let k12 = w1.mul_add(w2, -(wnn * q));
        let k22 = wnn.mul_add(pp, -(w1 * w1));
        let inv = T::ONE / w2.mul_add(k02, w1.mul_add(k01, wnn * k00));
        let rhs = [-a, -c1, -c2];
        let stick = [
            dot3([k00, k01, k02], rhs) * inv,
            dot3([k01, k11, k12], rhs) * inv,
            dot3([k02, k12, k22], rhs) * inv,
        ];
        let f_stick = stick[1].mul_add(stick[1], stick[2] * stick[2]).sqrt();
        let limit = mu * stick[0];
        k.stick_ok[s] = (stick[0] > T::ZERO) & (f_stick <= limit * (T::ONE - fc.stick_band));
        k.stick_no[s] = f_stick >= limit * (T::ONE + fc.stick_band);
        let sl = Slide::new(mu, [c1, c2], a, w);
        let coef = [sl.a0, sl.a1, sl.b1, sl.a2, sl.b2, sl.n0];
        let f1 = sl.a1.mul_add(sl.a1, sl.b1 * sl.b1).sqrt();
        let f2 = sl.a2.mul_add(sl.a2, sl.b2 * sl.b2).sqrt();
        // |F⁽ᵏ⁾| ≤ |c₁| + 2ᵏ|c₂| for a degree-2 polynomial's amplitudes.
        k.l3[s] = T::from_f64(8.0).mul_add(f2, f1);
        k.l4[s] = T::from_f64(16.0).mul_add(f2, f1);
        k.l5[s] = T::from_f64(32.0).mul_add(f2, f1);
        // Margins: values within rounding (and, in f32, within the inputs'
        // own rounding) of zero decide nothing.
        let (mw1, mw2) = (mu * w1, mu * w2);
        let ld = mw1.mul_add(mw1, mw2 * mw2).sqrt();
        let mag = (wnn + ld) * (c1.abs() + c2.abs())
            + a.abs() * ((w1.abs() + w2.abs()) + mu * (pp.abs() + q.abs() + r.abs()));
        k.m_f[s] = fc.round * mag;
        k.m_d[s] = fc.round * (wnn + ld);
        let left = sl.at(fc.grid[0]);
        for m in 0..3 {
            k.stick[m][s] = stick[m];
        }
        for m in 0..5 {
            k.left[m][s] = left[m];
        }
        for m in 0..6 {
            k.coef[m][s] = coef[m];
        }
        k.a[s] = a;
        k.changes[s] = T::ZERO;
        k.grid_ok[s] = true;
        k.count[s] = T::ZERO;
        k.roots_ok[s] = true;
        k.dir[0][s] = T::ONE;
        k.dir[1][s] = T::ZERO;
    }
}

/// The slide polynomials of lane s.
#[inline(always)]
fn slide_of<T: Real>(k: &Solve<T>, s: usize) -> Slide<T> {
    Slide {
        a0: k.coef[0][s],
        a1: k.coef[1][s],
        b1: k.coef[2][s],
        a2: k.coef[3][s],
        b2: k.coef[4][s],
        n0: k.coef[5][s],
    }
}

/// Grid interval j of every lane: certified root-free, or holding exactly
/// one root (F′ keeps the sign of the change), which takes the next slot.
#[inline(always)]
fn interval<T: Real, const N: usize>(fc: &FrictionConsts<T, N>, j: usize, k: &mut Solve<T>) {
    let index = T::from_f64(j as f64);
    let g = fc.grid[j + 1];
    for s in 0..BLOCK {
        let sl = slide_of(k, s);
        let right = sl.at(g);
        let [f0, fp0, fpp0, fppp0, f40] = std::array::from_fn(|m| k.left[m][s]);
        let [f1, fp1, fpp1, fppp1, f41] = right;
        let (l3, m_f) = (k.l3[s], k.m_f[s]);
        let rise = (f0 <= T::ZERO) & (f1 > T::ZERO);
        let fall = (f0 > T::ZERO) & (f1 <= T::ZERO);
        let (l4, l5) = (k.l4[s], k.l5[s]);
        let root_free = positive_on(fc, [f0, f1], [fp0, fp1], [fpp0, fpp1], l3, m_f)
            | positive_on(fc, [-f0, -f1], [-fp0, -fp1], [-fpp0, -fpp1], l3, m_f);
        // One root where F changes sign: F′ keeps the sign of the change
        // (F monotone), or F″ keeps a sign (F convex or concave: at most
        // two roots, and an odd count).
        let monotone = (rise & positive_on(fc, [fp0, fp1], [fpp0, fpp1], [fppp0, fppp1], l4, m_f))
            | (fall & positive_on(fc, [-fp0, -fp1], [-fpp0, -fpp1], [-fppp0, -fppp1], l4, m_f));
        let convex = positive_on(fc, [fpp0, fpp1], [fppp0, fppp1], [f40, f41], l5, m_f)
            | positive_on(fc, [-fpp0, -fpp1], [-fppp0, -fppp1], [-f40, -f41], l5, m_f);
        let one_root = monotone | convex;
        let change = rise | fall;
        k.grid_ok[s] &= (change & one_root) | (!change & root_free);
        let changes = k.changes[s];
        let new = [index, f0, f1];
        for n in 0..4 {
            let take = change & (changes == T::from_f64(n as f64));
            for m in 0..3 {
                k.slot[n][m][s] = select(take, new[m], k.slot[n][m][s]);
            }
        }
        k.changes[s] = changes + select(change, T::ONE, T::ZERO);
        for m in 0..5 {
            k.left[m][s] = right[m];
        }
    }
}

/// Starts the refinement of root n: cos θ_j, sin θ_j of its interval and
/// the secant through the interval's ends, in t = θ − θ_j ∈ [0, h].
#[inline(always)]
fn root_start<T: Real, const N: usize>(fc: &FrictionConsts<T, N>, n: usize, k: &mut Solve<T>) {
    let per_turn = T::from_f64(1.0 / GRID as f64);
    for s in 0..BLOCK {
        let used = k.changes[s] > T::from_f64(n as f64);
        let j = select(used, k.slot[n][0][s], T::ZERO);
        let (sn, cs) = (j * per_turn).sin_cos_2pi();
        let (fl, fr) = (k.slot[n][1][s], k.slot[n][2][s]);
        let t = select(used, fl / (fl - fr), T::HALF) * fc.h;
        let start = [cs, sn, t, T::ZERO, fc.h, fc.h];
        for m in 0..6 {
            k.newton[m][s] = start[m];
        }
    }
}

/// cos and sin of θ_j + t.
#[inline(always)]
fn rotate<T: Real>(cj: T, sj: T, t: T) -> (T, T) {
    let (st, ct) = T::sin_cos_quarter(t * T::from_f64(std::f64::consts::FRAC_2_PI));
    (cj.mul_add(ct, -(sj * st)), sj.mul_add(ct, cj * st))
}

/// (cos θ, sin θ, cos 2θ, sin 2θ) from cos θ and sin θ.
#[inline(always)]
fn angles<T: Real>(cs: T, sn: T) -> [T; 4] {
    [cs, sn, cs.mul_add(cs, -(sn * sn)), (cs + cs) * sn]
}

/// One safeguarded Newton step on root n: the bracket keeps the root, and a
/// step that leaves it is replaced by bisection.
#[inline(always)]
fn root_step<T: Real>(n: usize, k: &mut Solve<T>) {
    for s in 0..BLOCK {
        let sl = slide_of(k, s);
        let [cj, sj, t, lo, hi, _] = std::array::from_fn(|m| k.newton[m][s]);
        let up = k.slot[n][2][s] > k.slot[n][1][s];
        let (cs, sn) = rotate(cj, sj, t);
        let [f, fp, ..] = sl.at(angles(cs, sn));
        let below = (f < T::ZERO) == up;
        let lo = select(below, t, lo);
        let hi = select(below, hi, t);
        let newton = t - f / fp;
        let next = select((newton >= lo) & (newton <= hi), newton, T::HALF * (lo + hi));
        let now = [cj, sj, next, lo, hi, (next - t).abs()];
        for m in 0..6 {
            k.newton[m][s] = now[m];
        }
    }
}

/// Judges root n where it is: valid when D > 0 and the sliding speed N/D
/// exceeds friction.md's stick threshold, clear of both by the margins.
#[inline(always)]
fn root_judge<T: Real, const N: usize>(
    fc: &FrictionConsts<T, N>,
    mu: T,
    i: usize,
    n: usize,
    fr: &Frame<T, N>,
    k: &mut Solve<T>,
) {
    for s in 0..BLOCK {
        let sl = slide_of(k, s);
        let used = k.changes[s] > T::from_f64(n as f64);
        let [cj, sj, t, _, _, step] = std::array::from_fn(|m| k.newton[m][s]);
        let (cs, sn) = rotate(cj, sj, t);
        let [wnn, w1, w2, ..] = w_of(fr, i, s);
        let d = (-mu * w2).mul_add(sn, (-mu * w1).mul_add(cs, wnn));
        let num = sl.numerator(angles(cs, sn));
        let vscale = fr.vscale[s];
        let (m_f, m_d) = (k.m_f[s], k.m_d[s]);
        let dpos = d > m_d;
        let valid = dpos & ((fc.slide_hi * vscale).mul_add(-d, num) > m_f);
        let invalid = (d < -m_d) | (dpos & ((fc.slide_lo * vscale).mul_add(-d, num) < -m_f));
        k.roots_ok[s] &= !used | ((valid | invalid) & (step <= fc.angle_tol));
        let take = used & valid;
        k.count[s] += select(take, T::ONE, T::ZERO);
        k.dir[0][s] = select(take, cs, k.dir[0][s]);
        k.dir[1][s] = select(take, sn, k.dir[1][s]);
    }
}

/// The end of a visit of contact i: the impulse (take-off, stick, or the
/// one valid slide root; with μ = 0, `max(−a, 0)/W_nn · n`), its effect on
/// v and ω, the largest move, and the stick and unsure bits.
#[inline(always)]
fn finish<T: Real, const N: usize, const COUPLED: bool, const ROUGH: bool>(
    c: &Consts<T, N>,
    i: usize,
    fr: &Frame<T, N>,
    sw: &mut Sweep<T, N>,
) {
    let fc = &c.fr;
    let dirs = [c.normal[i], fc.tangent[i][0], fc.tangent[i][1]];
    let mu = fc.mu[i];
    let stick_bit = 1u32 << (STICK_SHIFT + i as u32);
    let own_moved = 1u32 << (MOVED_SHIFT + i as u32);
    let others_moved = (((1u32 << N) - 1) << MOVED_SHIFT) & !own_moved;
    let Sweep {
        p,
        dv,
        dw,
        moved,
        bits,
        solve,
    } = sw;
    let k = &*solve;
    for s in 0..BLOCK {
        let a = k.a[s];
        let w = w_of(fr, i, s);
        let approaching = a < T::ZERO;
        let (new, stuck, sure) = if ROUGH {
            let [cs, sn] = [k.dir[0][s], k.dir[1][s]];
            let d = (-mu * w[2]).mul_add(sn, (-mu * w[1]).mul_add(cs, w[0]));
            let lambda = -a / d;
            let slide = [lambda, -mu * lambda * cs, -mu * lambda * sn];
            let (stick_ok, stick_no) = (k.stick_ok[s], k.stick_no[s]);
            let count = k.count[s];
            let one_case = (stick_ok & (count == T::ZERO)) | (stick_no & (count == T::ONE));
            let sure_a = a.abs() > fc.take_off_band * fr.vscale[s];
            // Take-off decides nothing within rounding of a = 0 on either
            // side: just below it, a stick impulse need not be small
            // (Painlevé's impact without collision).
            let sure = sure_a & (!approaching | (k.grid_ok[s] & k.roots_ok[s] & one_case));
            let new: [T; 3] = std::array::from_fn(|m| {
                select(
                    approaching,
                    select(stick_ok, k.stick[m][s], slide[m]),
                    T::ZERO,
                )
            });
            (new, approaching & stick_ok, sure)
        } else {
            (
                [select(approaching, -a / w[0], T::ZERO), T::ZERO, T::ZERO],
                false,
                true,
            )
        };
        let old = [p[i][0][s], p[i][1][s], p[i][2][s]];
        let dp = [new[0] - old[0], new[1] - old[1], new[2] - old[2]];
        for m in 0..3 {
            let lever = [
                fr.lever[i][0][m][s],
                fr.lever[i][1][m][s],
                fr.lever[i][2][m][s],
            ];
            let lin = dp[2].mul_add(dirs[2][m], dp[1].mul_add(dirs[1][m], dp[0] * dirs[0][m]));
            dv[m][s] = lin.mul_add(c.inv_mass, dv[m][s]);
            let ang = dp[2].mul_add(lever[2], dp[1].mul_add(lever[1], dp[0] * lever[0]));
            dw[m][s] = ang.mul_add(c.inv_inertia[m], dw[m][s]);
            p[i][m][s] = new[m];
        }
        moved[s] = moved[s].max(dot3(dp, dp).sqrt());
        // An active contact's visit moves the others (in exact arithmetic
        // its increment is zero only at the limit), as does any change.
        let nonzero =
            (dp[0] != T::ZERO) | (dp[1] != T::ZERO) | (dp[2] != T::ZERO) | (new[0] != T::ZERO);
        // A visit that saw the other contacts' impulses (COUPLED) starts
        // this contact afresh; paper's visits see none of them.
        let fresh = if COUPLED { own_moved } else { 0 };
        bits[s] = (bits[s] & !(stick_bit | fresh))
            | bit(stuck, stick_bit)
            | bit(!sure, UNSURE)
            | bit(nonzero, others_moved);
    }
}

/// One visit of contact i in every lane (friction.md's single-contact
/// solve, or with μ = 0 its closed form).
#[inline(always)]
fn visit<T: Real, const N: usize, const COUPLED: bool>(
    c: &Consts<T, N>,
    i: usize,
    fr: &Frame<T, N>,
    sw: &mut Sweep<T, N>,
) {
    let fc = &c.fr;
    setup::<T, N, COUPLED>(c, i, fr, sw);
    if fc.mu[i] == T::ZERO {
        finish::<T, N, COUPLED, false>(c, i, fr, sw);
        return;
    }
    let k = &mut sw.solve;
    for j in 0..GRID {
        interval(fc, j, k);
    }
    let iters = if T::EPSILON.to_f64() > 1e-10 { 5 } else { 8 };
    for n in 0..4 {
        // Blocks where no lane has this many roots skip it (no lane's
        // answer changes).
        let used = k.changes.iter().any(|&x| x > T::from_f64(n as f64));
        if !used {
            break;
        }
        root_start(fc, n, k);
        for _ in 0..iters {
            root_step(n, k);
        }
        root_judge(fc, fc.mu[i], i, n, fr, k);
    }
    finish::<T, N, COUPLED, true>(c, i, fr, sw);
}

/// Every contact visited once, in scene order.
#[inline(always)]
fn sweep<T: Real, const N: usize, const COUPLED: bool>(
    c: &Consts<T, N>,
    fr: &Frame<T, N>,
    sw: &mut Sweep<T, N>,
) {
    for i in 0..N {
        visit::<T, N, COUPLED>(c, i, fr, sw);
    }
}

/// The impulses of a frictional law on a block, then the post-impact
/// quantities into `out` (as [`post`] does without friction), with the
/// tangential impulse and sliding speed per contact.
#[inline(always)]
pub fn friction_impulses<T: Real, const N: usize>(
    c: &Consts<T, N>,
    law: Law,
    x: &Inputs<T>,
    geo: &Geometry<T, N>,
    fr: &Frame<T, N>,
    sw: &mut Sweep<T, N>,
    out: &mut LawOut<T, N>,
) {
    for i in 0..N {
        for d in 0..3 {
            sw.p[i][d] = [T::ZERO; BLOCK];
        }
    }
    for k in 0..3 {
        sw.dv[k] = [T::ZERO; BLOCK];
        sw.dw[k] = [T::ZERO; BLOCK];
    }
    sw.bits = [0; BLOCK];
    let mut unconverged = [false; BLOCK];
    match law {
        // Each approaching contact alone: its own c⁻ (paper with friction).
        Law::Paper => sweep::<T, N, false>(c, fr, sw),
        Law::Pgs { sweeps } => {
            for _ in 0..sweeps {
                sweep::<T, N, true>(c, fr, sw);
            }
        }
        // Stronge's Darboux–Keller integration runs per sample in the f64
        // reference.
        Law::Stronge => sw.bits = [UNSURE; BLOCK],
        // One contact: a single visit is the limit (a second moves nothing).
        Law::Newton if N == 1 => sweep::<T, N, true>(c, fr, sw),
        // Several contacts: sweeps until no impulse moves by more than the
        // tolerance (friction.md's stopping rule). The limit is what the
        // certificate must vouch for: a lane is kept when every visit of its
        // last sweep was certain and that sweep moved nothing, so that its
        // impulses satisfy every contact's law; earlier visits only lead
        // there.
        Law::Newton => {
            let mass = c.mass;
            for _ in 0..c.fr.gs_max {
                sw.moved = [T::ZERO; BLOCK];
                for b in sw.bits.iter_mut() {
                    *b &= !UNSURE;
                }
                sweep::<T, N, true>(c, fr, sw);
                let mut left = 0u32;
                for s in 0..BLOCK {
                    let still = sw.moved[s] > c.fr.gs_tol * mass * fr.vscale[s];
                    unconverged[s] = still;
                    left |= still as u32;
                }
                if left == 0 {
                    break;
                }
            }
        }
        Law::Poisson => unreachable!("poisson with friction is refused by the scene"),
    }
    let limit = matches!(law, Law::Newton);
    friction_post(c, x, geo, fr, sw, limit, &unconverged, out);
}

/// Post-impact velocities, normal velocities, energy, tangential impulses
/// and sliding speeds of a frictional block (`limit`: the impulses are
/// Newton's converged limit); lanes the solve could not vouch for are
/// flagged [`RECOMPUTE`].
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn friction_post<T: Real, const N: usize>(
    c: &Consts<T, N>,
    x: &Inputs<T>,
    geo: &Geometry<T, N>,
    fr: &Frame<T, N>,
    sw: &Sweep<T, N>,
    limit: bool,
    unconverged: &[bool; BLOCK],
    out: &mut LawOut<T, N>,
) {
    let stick_speed = T::from_f64(1e-9);
    for s in 0..BLOCK {
        let dv = [sw.dv[0][s], sw.dv[1][s], sw.dv[2][s]];
        let dw = [sw.dw[0][s], sw.dw[1][s], sw.dw[2][s]];
        let v: [T; 3] = std::array::from_fn(|k| x.v[k][s] + dv[k]);
        let w: [T; 3] = std::array::from_fn(|k| x.w[k][s] + dw[k]);
        let vscale_after = c.length.mul_add(dot3(w, w).sqrt(), dot3(v, v).sqrt());
        let stuck_at = stick_speed * fr.vscale[s].max(vscale_after);
        let mut status = geo.status[s];
        let mut work = T::ZERO;
        let mut work_abs = T::ZERO;
        let mut unsure_stick = false;
        for i in 0..N {
            let dirs = [c.normal[i], c.fr.tangent[i][0], c.fr.tangent[i][1]];
            let mut after = [T::ZERO; 3];
            for d in 0..3 {
                let lever = [
                    fr.lever[i][d][0][s],
                    fr.lever[i][d][1][s],
                    fr.lever[i][d][2][s],
                ];
                after[d] = fr.c0[i][d][s] + dot3(dirs[d], dv) + dot3(lever, dw);
                let p = sw.p[i][d][s];
                let before = fr.c0[i][d][s];
                work = p.mul_add(before + after[d], work);
                work_abs = p.abs().mul_add(before.abs() + after[d].abs(), work_abs);
            }
            let lambda = sw.p[i][0][s];
            // friction.md's sticking: |c⁺_t| ≤ 1e-9 × the velocity scale.
            // A contact whose last visit stuck has c⁺_t = 0 if nothing moved
            // since, or at Newton's limit (whose stopping rule leaves far
            // less than the threshold); otherwise the computed speed
            // decides, unless it is within rounding of the threshold.
            let stuck = sw.bits[s] & (1 << (STICK_SHIFT + i as u32)) != 0;
            let since = sw.bits[s] & (1 << (MOVED_SHIFT + i as u32)) != 0;
            let speed = after[1].mul_add(after[1], after[2] * after[2]).sqrt();
            let rounding = c.fr.take_off_band * fr.vscale[s];
            let at_rest = stuck & (limit | !since);
            let sliding = select(at_rest, T::ZERO, speed);
            let active = lambda > T::ZERO;
            unsure_stick |= active & !at_rest & ((speed - stuck_at).abs() <= rounding);
            out.lambda[i][s] = lambda;
            out.vn_after[i][s] = after[0];
            out.tangential[i][s] = sw.p[i][1][s]
                .mul_add(sw.p[i][1][s], sw.p[i][2][s] * sw.p[i][2][s])
                .sqrt();
            out.sliding[i][s] = sliding;
            status |= ((lambda > T::ZERO) as u32) << (ACTIVE_SHIFT + i as u32);
            status |= bit(
                active & (at_rest | (speed <= stuck_at)),
                1 << (STICKING_SHIFT + i as u32),
            );
        }
        // ΔT = ½ Σ P_i·(c⁻_i + c⁺_i), exact for any impulses (friction.md).
        let (t1, gained, unsure) =
            super::impulses::energy_after(c, geo.t_before[s], v, w, work, work_abs);
        for k in 0..3 {
            out.v_after[k][s] = v[k];
            out.w_after[k][s] = w[k];
        }
        out.t_after[s] = t1;
        status |= bit(gained, ENERGY_GAIN)
            | bit(
                unsure | unsure_stick | unconverged[s] | (sw.bits[s] & UNSURE != 0),
                RECOMPUTE,
            );
        out.status[s] = status;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed-form coefficients of F and N are friction.md's
    /// definitions, `ŝ⊥·v(θ)` and `ŝ·v(θ)` with
    /// `v = D(θ) c_t − a (w_t − μ W_tt ŝ)`, and F′ to F⁗ F's derivatives
    /// (central differences), at random angles and inputs.
    #[test]
    fn slide_polynomials_are_the_definition() {
        let mut state = 7u64;
        let mut next = || {
            state += 1;
            (crate::sampler::rng::mix64(state) >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for _ in 0..1000 {
            let (wnn, w1, w2) = (1.0 + next().abs(), next(), next());
            let (p, q, r) = (1.0 + next().abs(), 0.3 * next(), 1.0 + next().abs());
            let (c1, c2, a, mu) = (next(), next(), -next().abs(), 2.0 * next().abs());
            let k = Slide::new(mu, [c1, c2], a, [wnn, w1, w2, p, q, r]);
            let def = |th: f64| {
                let (sn, cs) = th.sin_cos();
                let d = wnn - mu * (w1 * cs + w2 * sn);
                let m = [p * cs + q * sn, q * cs + r * sn];
                let v = [d * c1 - a * (w1 - mu * m[0]), d * c2 - a * (w2 - mu * m[1])];
                (-sn * v[0] + cs * v[1], cs * v[0] + sn * v[1])
            };
            let th = 7.0 * next();
            let g = |th: f64| [th.cos(), th.sin(), (2.0 * th).cos(), (2.0 * th).sin()];
            let [f, fp, fpp, fppp, f4] = k.at(g(th));
            let [.., fpppa, _] = k.at(g(th + 1e-4));
            let [.., fpppb, _] = k.at(g(th - 1e-4));
            assert!((f4 - (fpppa - fpppb) / 2e-4).abs() < 1e-6, "F⁗ at {th}");
            let [_, fpa, ..] = k.at(g(th + 1e-4));
            let [_, fpb, ..] = k.at(g(th - 1e-4));
            assert!(
                (fppp - (fpa - 2.0 * fp + fpb) / 1e-8).abs() < 1e-5,
                "F‴ at {th}"
            );
            let n = k.numerator(g(th));
            let (f_def, n_def) = def(th);
            let e = 1e-4;
            let (fa, _) = def(th + e);
            let (fb, _) = def(th - e);
            assert!((f - f_def).abs() < 1e-12, "F {f} vs {f_def}");
            assert!((n - n_def).abs() < 1e-12, "N {n} vs {n_def}");
            assert!((fp - (fa - fb) / (2.0 * e)).abs() < 1e-6, "F′ at {th}");
            assert!(
                (fpp - (fa - 2.0 * f_def + fb) / (e * e)).abs() < 1e-5,
                "F″ at {th}"
            );
        }
    }
}
