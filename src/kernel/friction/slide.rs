//! The single-contact solve in lanes (friction.md §3): take-off and stick
//! tests, the slide angle's roots on a certified 32-interval grid, their
//! refinement and judgement, and the lane's decision.

// Lane code indexes SoA arrays by lane and contact on purpose: the index
// form is what the loop vectoriser sees through.
#![allow(clippy::needless_range_loop, clippy::manual_memcpy)]

use crate::kernel::friction::state::{
    bit, Frame, FrictionConsts, Solve, Sweep, GRID, MOVED_SHIFT, STICK_SHIFT, UNSURE,
};
use crate::kernel::geometry::dot3;
use crate::kernel::Consts;
use crate::lanes::dispatch::BLOCK;
use crate::lanes::{select, Real};

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
pub(super) struct Slide<T> {
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
        let Self { a1, b1, a2, b2, .. } = *self;
        let [cs, sn, c2t, s2t] = g;
        let [f, fp] = self.f_fp(g);
        let two = T::ONE + T::ONE;
        let four = two + two;
        let eight = four + four;
        [
            f,
            fp,
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

    /// F and F′ alone (the first two of [`Slide::at`], computed alike).
    #[inline(always)]
    fn f_fp(&self, g: [T; 4]) -> [T; 2] {
        let Self {
            a0, a1, b1, a2, b2, ..
        } = *self;
        let [cs, sn, c2t, s2t] = g;
        let two = T::ONE + T::ONE;
        [
            b2.mul_add(s2t, a2.mul_add(c2t, b1.mul_add(sn, a1.mul_add(cs, a0)))),
            (two * b2).mul_add(c2t, (-two * a2).mul_add(s2t, b1.mul_add(cs, -(a1 * sn)))),
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
pub(super) fn positive_on<T: Real, const N: usize>(
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

/// The Delassus block of contact i in lane s.
#[inline(always)]
pub(super) fn w_of<T: Real, const N: usize>(fr: &Frame<T, N>, i: usize, s: usize) -> [T; 6] {
    std::array::from_fn(|m| fr.w[i][m][s])
}

/// Set-up of a visit of contact i, in passes over the lanes: the free
/// velocity (with the other contacts' impulses when `COUPLED`) and `a`
/// with Newton's bias `b = k min(c⁻_n, 0)`; the stick case (`W P = (−a,
/// −c_t)` by the symmetric cofactors); the slide polynomials with their
/// margins and the certified search's start; no roots yet.
///
/// Each pass takes the arrays it reads and writes as separate references:
/// inlined, they tell the loop vectoriser that no two overlap, so that it
/// needs no run-time checks (one pass over all of them needed more than it
/// allows, and stayed scalar).
#[inline(always)]
pub(super) fn setup<T: Real, const N: usize, const COUPLED: bool>(
    c: &Consts<T, N>,
    i: usize,
    fr: &Frame<T, N>,
    sw: &mut Sweep<T, N>,
    lanes: usize,
) {
    let fc = &c.fr;
    let dirs = [c.normal[i], fc.tangent[i][0], fc.tangent[i][1]];
    let mu = fc.mu[i];
    let Sweep {
        p, dv, dw, solve, ..
    } = sw;
    let Solve {
        a,
        ct,
        stick,
        stick_ok,
        stick_no,
        coef,
        m_f,
        m_d,
        start,
        ..
    } = solve;
    let w = &fr.w[i];
    free_velocity::<T, COUPLED>(
        dirs,
        c.k[i],
        w,
        &fr.c0[i],
        &fr.lever[i],
        &p[i],
        dv,
        dw,
        a,
        ct,
        lanes,
    );
    let free = Free { fc, mu, w, a, ct };
    stick_case(&free, stick, stick_ok, stick_no, lanes);
    slide_case(&free, coef, m_f, m_d, start, lanes);
    restart(solve, lanes);
}

/// `a` and the free tangential velocity `ct` of contact i with directions
/// `dirs` and bias coefficient `k`: its pre-impact velocity `c0`, and when
/// `COUPLED` the other contacts' impulses (every impulse's change of v
/// and ω so far, less this contact's own, `W_ii P_i`).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn free_velocity<T: Real, const COUPLED: bool>(
    dirs: [[T; 3]; 3],
    k: T,
    w: &[[T; BLOCK]; 6],
    c0: &[[T; BLOCK]; 3],
    lever: &[[[T; BLOCK]; 3]; 3],
    p: &[[T; BLOCK]; 3],
    dv: &[[T; BLOCK]; 3],
    dw: &[[T; BLOCK]; 3],
    a: &mut [T; BLOCK],
    ct: &mut [[T; BLOCK]; 2],
    lanes: usize,
) {
    for s in 0..lanes.min(BLOCK) {
        let mut cf = [c0[0][s], c0[1][s], c0[2][s]];
        if COUPLED {
            let w: [T; 6] = std::array::from_fn(|m| w[m][s]);
            let old = [p[0][s], p[1][s], p[2][s]];
            let dv = [dv[0][s], dv[1][s], dv[2][s]];
            let dw = [dw[0][s], dw[1][s], dw[2][s]];
            // W_ii P_i, to take this contact's own impulse out.
            let own = [
                dot3([w[0], w[1], w[2]], old),
                dot3([w[1], w[3], w[4]], old),
                dot3([w[2], w[4], w[5]], old),
            ];
            for d in 0..3 {
                let lever = [lever[d][0][s], lever[d][1][s], lever[d][2][s]];
                cf[d] = cf[d] + dot3(dirs[d], dv) + dot3(lever, dw) - own[d];
            }
        }
        a[s] = k.mul_add(c0[0][s].min(T::ZERO), cf[0]);
        ct[0][s] = cf[1];
        ct[1][s] = cf[2];
    }
}

/// What the stick and slide cases of a visit read: the friction
/// constants, the contact's μ and Delassus block, and the free velocity's
/// `a` and `c_t` (only written arrays need be separate arguments).
struct Free<'a, T, const N: usize> {
    fc: &'a FrictionConsts<T, N>,
    mu: T,
    w: &'a [[T; BLOCK]; 6],
    a: &'a [T; BLOCK],
    ct: &'a [[T; BLOCK]; 2],
}

impl<T: Real, const N: usize> Free<'_, T, N> {
    /// Lane s's Delassus block, `a` and `c_t`.
    #[inline(always)]
    fn lane(&self, s: usize) -> ([T; 6], T, [T; 2]) {
        (
            std::array::from_fn(|m| self.w[m][s]),
            self.a[s],
            [self.ct[0][s], self.ct[1][s]],
        )
    }
}

/// The stick case of every lane: `W P = (−a, −c_t)` by the symmetric
/// cofactors, valid when P_n > 0 and |P_t| ≤ μ P_n, each clear of the
/// band, or clearly not.
#[inline(always)]
fn stick_case<T: Real, const N: usize>(
    free: &Free<'_, T, N>,
    stick: &mut [[T; BLOCK]; 3],
    stick_ok: &mut [bool; BLOCK],
    stick_no: &mut [bool; BLOCK],
    lanes: usize,
) {
    let (fc, mu) = (free.fc, free.mu);
    for s in 0..lanes.min(BLOCK) {
        let ([wnn, w1, w2, pp, q, r], a, [c1, c2]) = free.lane(s);
        let k00 = pp.mul_add(r, -(q * q));
        let k01 = w2.mul_add(q, -(w1 * r));
        let k02 = w1.mul_add(q, -(pp * w2));
        let k11 = wnn.mul_add(r, -(w2 * w2));
        let k12 = w1.mul_add(w2, -(wnn * q));
        let k22 = wnn.mul_add(pp, -(w1 * w1));
        let inv = T::ONE / w2.mul_add(k02, w1.mul_add(k01, wnn * k00));
        let rhs = [-a, -c1, -c2];
        let p = [
            dot3([k00, k01, k02], rhs) * inv,
            dot3([k01, k11, k12], rhs) * inv,
            dot3([k02, k12, k22], rhs) * inv,
        ];
        let f_stick = p[1].mul_add(p[1], p[2] * p[2]).sqrt();
        let limit = mu * p[0];
        stick_ok[s] = (p[0] > T::ZERO) & (f_stick <= limit * (T::ONE - fc.stick_band));
        stick_no[s] = f_stick >= limit * (T::ONE + fc.stick_band);
        for m in 0..3 {
            stick[m][s] = p[m];
        }
    }
}

/// The slide polynomials of every lane, the margins within which their
/// values decide nothing, and the certified search's start direction.
#[inline(always)]
fn slide_case<T: Real, const N: usize>(
    free: &Free<'_, T, N>,
    coef: &mut [[T; BLOCK]; 6],
    m_f: &mut [T; BLOCK],
    m_d: &mut [T; BLOCK],
    start: &mut [[T; BLOCK]; 2],
    lanes: usize,
) {
    let (fc, mu) = (free.fc, free.mu);
    for s in 0..lanes.min(BLOCK) {
        let (w6, a, [c1, c2]) = free.lane(s);
        let [wnn, w1, w2, pp, q, r] = w6;
        let sl = Slide::new(mu, [c1, c2], a, w6);
        let cf = [sl.a0, sl.a1, sl.b1, sl.a2, sl.b2, sl.n0];
        // Margins: values within rounding (and, in f32, within the inputs'
        // own rounding) of zero decide nothing.
        let (mw1, mw2) = (mu * w1, mu * w2);
        let ld = mw1.mul_add(mw1, mw2 * mw2).sqrt();
        let mag = (wnn + ld) * (c1.abs() + c2.abs())
            + a.abs() * ((w1.abs() + w2.abs()) + mu * (pp.abs() + q.abs() + r.abs()));
        m_f[s] = fc.round * mag;
        m_d[s] = fc.round * (wnn + ld);
        for m in 0..6 {
            coef[m][s] = cf[m];
        }
        let ratio = -a / wnn;
        let g = [ratio.mul_add(w1, c1), ratio.mul_add(w2, c2)];
        let len = g[0].mul_add(g[0], g[1] * g[1]).sqrt();
        let some = len > T::ZERO;
        start[0][s] = select(some, g[0] / len, T::ONE);
        start[1][s] = select(some, g[1] / len, T::ZERO);
    }
}

/// Starts the certified search's root in slot 0: Newton's method on F from
/// the start direction, unbracketed (B3 leaves one valid root to find; a
/// lane that lands elsewhere, or has not converged, is caught by the
/// judgement).
#[inline(always)]
pub(super) fn certified_start<T: Real>(k: &mut Solve<T>, lanes: usize) {
    for s in 0..lanes {
        let now = [
            k.start[0][s],
            k.start[1][s],
            T::ZERO,
            T::ZERO,
            T::ZERO,
            T::INFINITY,
        ];
        for m in 0..6 {
            k.newton[m][s] = now[m];
        }
        k.changes[s] = T::ONE;
    }
}

/// One step of the certified search, capped at half a radian.
#[inline(always)]
pub(super) fn certified_step<T: Real>(k: &mut Solve<T>, lanes: usize) {
    for s in 0..lanes {
        let sl = slide_of(k, s);
        let [cj, sj, t] = [k.newton[0][s], k.newton[1][s], k.newton[2][s]];
        let (cs, sn) = rotate(cj, sj, t);
        let [f, fp] = sl.f_fp(angles(cs, sn));
        let dt = (f / fp).max(-T::HALF).min(T::HALF);
        k.newton[2][s] = t - dt;
        k.newton[5][s] = dt.abs();
    }
}

/// After the certified search: a lane whose stick is valid has no valid
/// slide root (B3), so its slide search is settled (no root, judged
/// clear). True if every lane is decided: none approaches, clearly not
/// sticking, without exactly one valid root judged clear. (A lane within
/// the stick test's band is left unsure by [`finish`] whatever a search
/// finds.)
#[inline(always)]
pub(super) fn certified_settle<T: Real>(k: &mut Solve<T>, lanes: usize) -> bool {
    let mut open = false;
    for s in 0..lanes {
        let stuck = k.stick_ok[s];
        k.count[s] = select(stuck, T::ZERO, k.count[s]);
        k.roots_ok[s] |= stuck;
        let one = (k.count[s] == T::ONE) & k.roots_ok[s];
        open |= (k.a[s] < T::ZERO) & k.stick_no[s] & !one;
    }
    !open
}

/// Lane s before a search: no sign changes, no roots, nothing uncertain.
#[inline(always)]
fn no_roots_yet<T: Real>(k: &mut Solve<T>, s: usize) {
    k.changes[s] = T::ZERO;
    k.grid_ok[s] = true;
    k.count[s] = T::ZERO;
    k.roots_ok[s] = true;
    k.dir[0][s] = T::ONE;
    k.dir[1][s] = T::ZERO;
}

/// The full search after an undecided certified one: no roots yet.
#[inline(always)]
pub(super) fn restart<T: Real>(k: &mut Solve<T>, lanes: usize) {
    for s in 0..lanes {
        no_roots_yet(k, s);
    }
}

/// Before the grid search of every lane: the bounds on F's higher
/// derivatives and F at the grid's start (the certified search needs
/// neither).
#[inline(always)]
pub(super) fn grid_setup<T: Real, const N: usize>(
    fc: &FrictionConsts<T, N>,
    k: &mut Solve<T>,
    lanes: usize,
) {
    for s in 0..lanes {
        let sl = slide_of(k, s);
        let f1 = sl.a1.mul_add(sl.a1, sl.b1 * sl.b1).sqrt();
        let f2 = sl.a2.mul_add(sl.a2, sl.b2 * sl.b2).sqrt();
        // |F⁽ᵏ⁾| ≤ |c₁| + 2ᵏ|c₂| for a degree-2 polynomial's amplitudes.
        k.l3[s] = T::from_f64(8.0).mul_add(f2, f1);
        k.l4[s] = T::from_f64(16.0).mul_add(f2, f1);
        k.l5[s] = T::from_f64(32.0).mul_add(f2, f1);
        let left = sl.at(fc.grid[0]);
        for m in 0..5 {
            k.left[m][s] = left[m];
        }
    }
}

/// The slide polynomials of lane s.
#[inline(always)]
pub(super) fn slide_of<T: Real>(k: &Solve<T>, s: usize) -> Slide<T> {
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
pub(super) fn interval<T: Real, const N: usize>(
    fc: &FrictionConsts<T, N>,
    j: usize,
    k: &mut Solve<T>,
    lanes: usize,
) {
    let index = T::from_f64(j as f64);
    let g = fc.grid[j + 1];
    for s in 0..lanes {
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
pub(super) fn root_start<T: Real, const N: usize>(
    fc: &FrictionConsts<T, N>,
    n: usize,
    k: &mut Solve<T>,
    lanes: usize,
) {
    let per_turn = T::from_f64(1.0 / GRID as f64);
    for s in 0..lanes {
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
pub(super) fn rotate<T: Real>(cj: T, sj: T, t: T) -> (T, T) {
    let (st, ct) = T::sin_cos_quarter(t * T::from_f64(std::f64::consts::FRAC_2_PI));
    (cj.mul_add(ct, -(sj * st)), sj.mul_add(ct, cj * st))
}

/// (cos θ, sin θ, cos 2θ, sin 2θ) from cos θ and sin θ.
#[inline(always)]
pub(super) fn angles<T: Real>(cs: T, sn: T) -> [T; 4] {
    [cs, sn, cs.mul_add(cs, -(sn * sn)), (cs + cs) * sn]
}

/// One safeguarded Newton step on root n: the bracket keeps the root, and a
/// step that leaves it is replaced by bisection.
#[inline(always)]
pub(super) fn root_step<T: Real>(n: usize, k: &mut Solve<T>, lanes: usize) {
    for s in 0..lanes {
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
pub(super) fn root_judge<T: Real, const N: usize>(
    fc: &FrictionConsts<T, N>,
    mu: T,
    i: usize,
    n: usize,
    fr: &Frame<T, N>,
    k: &mut Solve<T>,
    lanes: usize,
) {
    for s in 0..lanes {
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

/// The end of a visit of contact i, in two passes over the lanes: the
/// impulse (take-off, stick, or the one valid slide root; with μ = 0,
/// `max(−a, 0)/W_nn · n`) with its stick and certainty, then its effect on
/// v and ω, the largest move, and the sweep's bits.
#[inline(always)]
pub(super) fn finish<T: Real, const N: usize, const COUPLED: bool, const ROUGH: bool>(
    c: &Consts<T, N>,
    i: usize,
    fr: &Frame<T, N>,
    sw: &mut Sweep<T, N>,
    lanes: usize,
) {
    let fc = &c.fr;
    let Sweep {
        p,
        dv,
        dw,
        moved,
        bits,
        solve,
        ..
    } = sw;
    let Solve {
        a,
        stick,
        stick_ok,
        stick_no,
        count,
        dir,
        grid_ok,
        roots_ok,
        new,
        stuck,
        sure,
        ..
    } = solve;
    let w = &fr.w[i];
    if ROUGH {
        let chosen = Chosen {
            stick,
            stick_ok,
            stick_no,
            count,
            dir,
            grid_ok,
            roots_ok,
        };
        choose(
            fc, fc.mu[i], w, &fr.vscale, a, chosen, new, stuck, sure, lanes,
        );
    } else {
        frictionless(w, a, new, stuck, sure, lanes);
    }
    let moves = Moves {
        dirs: [c.normal[i], fc.tangent[i][0], fc.tangent[i][1]],
        inv_mass: c.inv_mass,
        inv_inertia: c.inv_inertia,
        stick_bit: 1u32 << (STICK_SHIFT + i as u32),
        own_moved: 1u32 << (MOVED_SHIFT + i as u32),
        all_moved: ((1u32 << N) - 1) << MOVED_SHIFT,
        coupled: COUPLED,
    };
    apply(
        &moves,
        &fr.lever[i],
        new,
        stuck,
        sure,
        &mut p[i],
        dv,
        dw,
        moved,
        bits,
        lanes,
    );
}

/// What the rough choice reads of the single-contact solve.
struct Chosen<'a, T> {
    stick: &'a [[T; BLOCK]; 3],
    stick_ok: &'a [bool; BLOCK],
    stick_no: &'a [bool; BLOCK],
    count: &'a [T; BLOCK],
    dir: &'a [[T; BLOCK]; 2],
    grid_ok: &'a [bool; BLOCK],
    roots_ok: &'a [bool; BLOCK],
}

/// The rough impulse of every lane: none when leaving, else the stick
/// impulse when it is valid, or the slide root's; sure when `a` is clear
/// of zero and, approaching, the search was certified with exactly one
/// valid case.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn choose<T: Real, const N: usize>(
    fc: &FrictionConsts<T, N>,
    mu: T,
    w: &[[T; BLOCK]; 6],
    vscale: &[T; BLOCK],
    a: &[T; BLOCK],
    chosen: Chosen<'_, T>,
    new: &mut [[T; BLOCK]; 3],
    stuck: &mut [bool; BLOCK],
    sure: &mut [bool; BLOCK],
    lanes: usize,
) {
    let Chosen {
        stick,
        stick_ok,
        stick_no,
        count,
        dir,
        grid_ok,
        roots_ok,
    } = chosen;
    for s in 0..lanes.min(BLOCK) {
        let a = a[s];
        let approaching = a < T::ZERO;
        let [cs, sn] = [dir[0][s], dir[1][s]];
        let d = (-mu * w[2][s]).mul_add(sn, (-mu * w[1][s]).mul_add(cs, w[0][s]));
        let lambda = -a / d;
        let slide = [lambda, -mu * lambda * cs, -mu * lambda * sn];
        let (ok, no) = (stick_ok[s], stick_no[s]);
        let one_case = (ok & (count[s] == T::ZERO)) | (no & (count[s] == T::ONE));
        let sure_a = a.abs() > fc.take_off_band * vscale[s];
        // Take-off decides nothing within rounding of a = 0 on either
        // side: just below it, a stick impulse need not be small
        // (Painlevé's impact without collision).
        sure[s] = sure_a & (!approaching | (grid_ok[s] & roots_ok[s] & one_case));
        stuck[s] = approaching & ok;
        for m in 0..3 {
            new[m][s] = select(approaching, select(ok, stick[m][s], slide[m]), T::ZERO);
        }
    }
}

/// The frictionless impulse of every lane, `max(−a, 0)/W_nn` along the
/// normal, which is always sure and never sticks.
#[inline(always)]
fn frictionless<T: Real>(
    w: &[[T; BLOCK]; 6],
    a: &[T; BLOCK],
    new: &mut [[T; BLOCK]; 3],
    stuck: &mut [bool; BLOCK],
    sure: &mut [bool; BLOCK],
    lanes: usize,
) {
    for s in 0..lanes.min(BLOCK) {
        new[0][s] = select(a[s] < T::ZERO, -a[s] / w[0][s], T::ZERO);
        new[1][s] = T::ZERO;
        new[2][s] = T::ZERO;
        stuck[s] = false;
        sure[s] = true;
    }
}

/// The constants of [`apply`]: contact i's directions, the body's inverse
/// mass and inertia, and contact i's bits in the sweep's bits.
struct Moves<T> {
    dirs: [[T; 3]; 3],
    inv_mass: T,
    inv_inertia: [T; 3],
    stick_bit: u32,
    own_moved: u32,
    all_moved: u32,
    coupled: bool,
}

/// Contact i's new impulse in every lane: its change moves v and ω, the
/// sweep's largest move and the bits (stick, unsure, and the other
/// contacts' moved bits; a visit that saw the others' impulses, `coupled`,
/// starts its own afresh).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn apply<T: Real>(
    k: &Moves<T>,
    lever: &[[[T; BLOCK]; 3]; 3],
    new: &[[T; BLOCK]; 3],
    stuck: &[bool; BLOCK],
    sure: &[bool; BLOCK],
    p: &mut [[T; BLOCK]; 3],
    dv: &mut [[T; BLOCK]; 3],
    dw: &mut [[T; BLOCK]; 3],
    moved: &mut [T; BLOCK],
    bits: &mut [u32; BLOCK],
    lanes: usize,
) {
    let dirs = k.dirs;
    let others_moved = k.all_moved & !k.own_moved;
    let fresh = if k.coupled { k.own_moved } else { 0 };
    for s in 0..lanes.min(BLOCK) {
        let new = [new[0][s], new[1][s], new[2][s]];
        let dp = [new[0] - p[0][s], new[1] - p[1][s], new[2] - p[2][s]];
        for m in 0..3 {
            let lever = [lever[0][m][s], lever[1][m][s], lever[2][m][s]];
            let lin = dp[2].mul_add(dirs[2][m], dp[1].mul_add(dirs[1][m], dp[0] * dirs[0][m]));
            dv[m][s] = lin.mul_add(k.inv_mass, dv[m][s]);
            let ang = dp[2].mul_add(lever[2], dp[1].mul_add(lever[1], dp[0] * lever[0]));
            dw[m][s] = ang.mul_add(k.inv_inertia[m], dw[m][s]);
            p[m][s] = new[m];
        }
        moved[s] = moved[s].max(dot3(dp, dp).sqrt());
        // An active contact's visit moves the others (in exact arithmetic
        // its increment is zero only at the limit), as does any change.
        let nonzero =
            (dp[0] != T::ZERO) | (dp[1] != T::ZERO) | (dp[2] != T::ZERO) | (new[0] != T::ZERO);
        bits[s] = (bits[s] & !(k.stick_bit | fresh))
            | bit(stuck[s], k.stick_bit)
            | bit(!sure[s], UNSURE)
            | bit(nonzero, others_moved);
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
