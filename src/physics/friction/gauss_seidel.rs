//! The touching contacts of one impact and the Gauss–Seidel laws over them
//! (friction.md §5): `newton` to its limit, `pgsN`, and `paper`.

use glam::{DMat3, DVec3};

use super::single::{single_contact, Case, Single};
use super::{delassus, tangent_basis};
use crate::physics::Ellipsoid;

/// The touching contacts of one impact, as the frictional laws see them:
/// the first [`Contacts::len`] entries of each array, on the stack (up to
/// [`MAX_DROP_PLANES`](crate::physics::MAX_DROP_PLANES) contacts, no allocation).
#[derive(Debug, Clone)]
pub struct Contacts {
    n: usize,
    /// Unit normals, Coulomb coefficients, restitutions.
    pub normals: [DVec3; MAX],
    pub mu: [f64; MAX],
    pub k: [f64; MAX],
    /// Pre-impact contact-point velocities `c⁻_i`.
    pub before: [DVec3; MAX],
    /// Delassus blocks, `w[i][j] = W_ij`.
    pub w: [[DMat3; MAX]; MAX],
    /// `|v| + L|ω|` before the impact (m/s), and `m` times it (N·s).
    pub vscale: f64,
    pub pscale: f64,
}

impl Contacts {
    /// Contacts at body-frame points `points` with the given planes' data
    /// (one entry per point each).
    ///
    /// # Panics
    /// With more than [`MAX_DROP_PLANES`](crate::physics::MAX_DROP_PLANES) points, or slices of other lengths.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        body: &Ellipsoid,
        rotation: DMat3,
        velocity: DVec3,
        omega: DVec3,
        points: &[DVec3],
        normals: &[DVec3],
        mu: &[f64],
        k: &[f64],
    ) -> Self {
        let n = points.len();
        let mut ct = Self::empty(n);
        ct.normals[..n].copy_from_slice(normals);
        ct.mu[..n].copy_from_slice(mu);
        ct.k[..n].copy_from_slice(k);
        for (i, &xi) in points.iter().enumerate() {
            ct.before[i] = velocity + rotation * omega.cross(xi);
            for (j, &xj) in points.iter().enumerate() {
                ct.w[i][j] = delassus(body, rotation, xi, xj);
            }
        }
        ct.vscale = velocity.length() + body.length_scale() * omega.length();
        ct.pscale = body.mass() * ct.vscale;
        ct
    }

    /// `n` contacts, every entry zero, for the caller to fill.
    ///
    /// # Panics
    /// With more than [`MAX_DROP_PLANES`](crate::physics::MAX_DROP_PLANES) contacts.
    pub fn empty(n: usize) -> Self {
        assert!(n <= MAX, "{n} contacts, at most {MAX}");
        Self {
            n,
            normals: [DVec3::ZERO; MAX],
            mu: [0.0; MAX],
            k: [0.0; MAX],
            before: [DVec3::ZERO; MAX],
            w: [[DMat3::ZERO; MAX]; MAX],
            vscale: 0.0,
            pscale: 0.0,
        }
    }

    /// The number of contacts.
    pub fn len(&self) -> usize {
        self.n
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.n == 0
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
    /// Gauss–Seidel sweeps taken (a confirming sweep after an accelerated
    /// step included; both solves of a `jammed` impact).
    pub sweeps: u32,
}

/// One Gauss–Seidel sweep over the contacts in scene order, in place: each
/// visit replaces `P_i` by the single-contact solve with
/// `c = c⁻_i + Σ_{j≠i} W_ij P_j`. Returns the largest move `|ΔP_i|`.
fn sweep(ct: &Contacts, p: &mut [DVec3], last: &mut [Single], plastic: bool) -> f64 {
    let mut moved = 0f64;
    for i in 0..p.len() {
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
    moved
}

/// Contacts a Gauss–Seidel solve keeps on the stack (every scene's; a
/// solved case with more planes uses the heap and is not accelerated).
pub(crate) const MAX: usize = crate::physics::MAX_DROP_PLANES;

/// Gauss–Seidel sweeps from P = 0. With `sweeps = None` it runs to the
/// limit (no impulse moved by more than 1e-13 of the impulse scale in a
/// sweep) or 10 000 sweeps; `converged` says which. With `accelerate`,
/// friction.md's acceleration to the same limit joins in (every touching
/// μ < 0.5; the caller checks). Flags come from each contact's last visit.
fn gauss_seidel(
    ct: &Contacts,
    sweeps: Option<u32>,
    plastic: bool,
    accelerate: bool,
) -> (Solved, bool) {
    const LIMIT: u32 = 10_000;
    let n = ct.len();
    // On the stack up to MAX contacts (every scene); a solved case may
    // have more planes.
    let (mut p_small, mut last_small) = ([DVec3::ZERO; MAX], [Single::default(); MAX]);
    let (mut p_big, mut last_big) = (Vec::new(), Vec::new());
    let (p, last): (&mut [DVec3], &mut [Single]) = if n <= MAX {
        (&mut p_small[..n], &mut last_small[..n])
    } else {
        p_big.resize(n, DVec3::ZERO);
        last_big.resize(n, Single::default());
        (&mut p_big, &mut last_big)
    };
    let max = sweeps.unwrap_or(LIMIT);
    let tol = 1e-13 * ct.pscale;
    let accelerate = accelerate && sweeps.is_none() && (2..=MAX).contains(&n);
    let mut previous = [DVec3::ZERO; MAX];
    // The cases and the largest move 4 sweeps ago, for the acceleration.
    let mut before: Option<([Case; MAX], f64)> = None;
    let mut converged = false;
    let mut t = 0;
    while t < max {
        if accelerate {
            previous[..n].copy_from_slice(p);
        }
        let moved = sweep(ct, p, last, plastic);
        t += 1;
        if sweeps.is_none() && moved <= tol {
            converged = true;
            break;
        }
        if !accelerate || t % 4 != 0 {
            continue;
        }
        let mut cases = [Case::TakeOff; MAX];
        for (c, s) in cases.iter_mut().zip(last.iter()) {
            *c = s.case;
        }
        let then = before.replace((cases, moved));
        let Some((old_cases, old_moved)) = then else {
            continue;
        };
        if t < 8 || cases[..n] != old_cases[..n] || !(moved < old_moved) {
            continue;
        }
        let r = (moved / old_moved).powf(0.25);
        let Some(x) = pattern_newton(ct, p, &cases[..n], plastic, JUMP_TOL) else {
            continue;
        };
        if !guard_passes(p, &previous[..n], &x[..n], r) {
            continue;
        }
        // One confirming sweep from the Newton point.
        let mut q = [DVec3::ZERO; MAX];
        let mut visits = [Single::default(); MAX];
        q[..n].copy_from_slice(&x[..n]);
        t += 1;
        if sweep(ct, &mut q[..n], &mut visits[..n], plastic) <= tol {
            p.copy_from_slice(&q[..n]);
            last.copy_from_slice(&visits[..n]);
            converged = true;
            break;
        }
    }
    let solved = Solved {
        impulses: p.to_vec(),
        ambiguous: last.iter().any(|s| s.ambiguous),
        unsolved: last.iter().any(|s| s.unsolved),
        sweeps: t,
        ..Solved::default()
    };
    (solved, converged || sweeps.is_some())
}

/// The reference's stop for [`pattern_newton`]: a step below f64 rounding
/// of the impulses.
pub(crate) const JUMP_TOL: f64 = 1e-14;

/// friction.md's Newton step on a pattern of cases: the impulses of every
/// contact at once that meet, per contact, take-off `P_i = 0`, stick
/// `c⁺_i = −b_i n_i`, a normal impulse (μ = 0) `c⁺_n,i = −b_i` with no
/// tangential part, or slide `c⁺_n,i = −b_i` and `f_i = −μ_i λ_i ŝ_i` with
/// `ŝ_i = c⁺_t,i/|c⁺_t,i|`; Newton's method from `p`, at most 12
/// iterations, until a step is at most `tol` of the impulse scale
/// ([`JUMP_TOL`] here; a lane type's rounding in the lanes, whose jump
/// lands in that type). `None` if a case is unsolved, a slide has no sliding
/// velocity, or the system is singular.
pub(crate) fn pattern_newton(
    ct: &Contacts,
    p: &[DVec3],
    cases: &[Case],
    plastic: bool,
    tol: f64,
) -> Option<[DVec3; MAX]> {
    let n = p.len();
    let m = 3 * n;
    let mut x = [DVec3::ZERO; MAX];
    x[..n].copy_from_slice(p);
    let mut basis = [(DVec3::ZERO, DVec3::ZERO); MAX];
    for (b, &nv) in basis.iter_mut().zip(&ct.normals[..n]) {
        *b = tangent_basis(nv);
    }
    let mut jac = [[0f64; 3 * MAX]; 3 * MAX];
    let mut res = [0f64; 3 * MAX];
    for _ in 0..12 {
        for row in &mut jac[..m] {
            row[..m].fill(0.0);
        }
        for i in 0..n {
            let nv = ct.normals[i];
            let (t1, t2) = basis[i];
            let cp = ct.before[i] + (0..n).fold(DVec3::ZERO, |acc, j| acc + ct.w[i][j] * x[j]);
            let b = ct.bias(i, plastic);
            // Row helpers: row r of contact i, against contact j's impulse.
            let mut set = |r: usize, j: usize, v: DVec3| {
                jac[3 * i + r][3 * j] = v.x;
                jac[3 * i + r][3 * j + 1] = v.y;
                jac[3 * i + r][3 * j + 2] = v.z;
            };
            match cases[i] {
                Case::Unsolved => return None,
                Case::TakeOff => {
                    for (r, e) in [DVec3::X, DVec3::Y, DVec3::Z].into_iter().enumerate() {
                        set(r, i, e);
                        res[3 * i + r] = x[i][r];
                    }
                }
                Case::Stick => {
                    let target = cp + b * nv;
                    for r in 0..3 {
                        for j in 0..n {
                            set(r, j, ct.w[i][j].row(r));
                        }
                        res[3 * i + r] = target[r];
                    }
                }
                Case::Normal | Case::Slide => {
                    for j in 0..n {
                        set(0, j, ct.w[i][j].transpose() * nv);
                    }
                    res[3 * i] = nv.dot(cp) + b;
                    let lambda = nv.dot(x[i]);
                    let f = x[i] - lambda * nv;
                    if cases[i] == Case::Normal {
                        set(1, i, t1);
                        set(2, i, t2);
                        res[3 * i + 1] = t1.dot(f);
                        res[3 * i + 2] = t2.dot(f);
                        continue;
                    }
                    let u = cp - nv * nv.dot(cp);
                    let len = u.length();
                    if !(len > 0.0) {
                        return None;
                    }
                    let uh = u / len;
                    let mu = ct.mu[i];
                    let g = f + mu * lambda * uh;
                    // dg/dP_j = δ_ij (I − n nᵀ + μ û nᵀ)
                    //         + μ λ (I − û ûᵀ)(I − n nᵀ) W_ij / |u|.
                    let proj = DMat3::IDENTITY - outer(nv, nv);
                    let bend = (DMat3::IDENTITY - outer(uh, uh)) * proj * (mu * lambda / len);
                    for j in 0..n {
                        let mut dg = bend * ct.w[i][j];
                        if j == i {
                            dg += proj + outer(uh, nv) * mu;
                        }
                        set(1, j, dg.transpose() * t1);
                        set(2, j, dg.transpose() * t2);
                    }
                    res[3 * i + 1] = t1.dot(g);
                    res[3 * i + 2] = t2.dot(g);
                }
            }
        }
        let dx = solve_dense(&mut jac, &mut res, m)?;
        let mut size = 0f64;
        for i in 0..n {
            let d = DVec3::new(dx[3 * i], dx[3 * i + 1], dx[3 * i + 2]);
            x[i] -= d;
            size = size.max(d.length());
        }
        if !x[..n].iter().all(|v| v.is_finite()) {
            return None;
        }
        // Below rounding of the impulses: Newton's next step would be
        // noise (the confirming sweep judges the point).
        if size <= tol * ct.pscale {
            break;
        }
    }
    Some(x)
}

/// friction.md's guard on an accelerated step: the Newton point `x` lies
/// within a quarter of the extrapolation's length `d = |ΔP| r/(1 − r)` of
/// the extrapolated point `P + ΔP r/(1 − r)`, where `ΔP = p − previous` is
/// the last sweep's step (over all contacts) and `r` its rate.
pub(crate) fn guard_passes(p: &[DVec3], previous: &[DVec3], x: &[DVec3], r: f64) -> bool {
    let g = r / (1.0 - r);
    let (mut step, mut off) = (0f64, 0f64);
    for ((pi, prev), xi) in p.iter().zip(previous).zip(x) {
        let dp = *pi - *prev;
        step += dp.length_squared();
        off += (*xi - (*pi + dp * g)).length_squared();
    }
    off.sqrt() <= 0.25 * step.sqrt() * g
}

/// `a bᵀ`.
pub(crate) fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// The solution of the `m`×`m` system `a x = b` by Gaussian elimination
/// with partial pivoting (`None` if singular), in `b`'s storage.
fn solve_dense(
    a: &mut [[f64; 3 * MAX]; 3 * MAX],
    b: &mut [f64; 3 * MAX],
    m: usize,
) -> Option<[f64; 3 * MAX]> {
    let scale = a[..m]
        .iter()
        .flat_map(|r| r[..m].iter())
        .fold(0f64, |s, v| s.max(v.abs()));
    if !(scale > 0.0) {
        return None;
    }
    for k in 0..m {
        let piv = (k..m).max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))?;
        if !(a[piv][k].abs() > 1e-14 * scale) {
            return None;
        }
        a.swap(k, piv);
        b.swap(k, piv);
        let pivot_row = a[k];
        for i in k + 1..m {
            let f = a[i][k] / pivot_row[k];
            if f != 0.0 {
                for (aij, akj) in a[i][k..m].iter_mut().zip(&pivot_row[k..m]) {
                    *aij -= f * akj;
                }
                b[i] -= f * b[k];
            }
        }
    }
    let mut x = [0f64; 3 * MAX];
    for k in (0..m).rev() {
        let mut s = b[k];
        for j in k + 1..m {
            s -= a[k][j] * x[j];
        }
        x[k] = s / a[k][k];
    }
    Some(x)
}

/// `newton` with friction: the Gauss–Seidel limit; if it does not
/// converge, the same with every k = 0 (`jammed`); if that does not
/// either, `unconverged` (the caller substitutes the frictionless result).
pub fn newton(ct: &Contacts) -> Solved {
    newton_with(ct, ct.mu[..ct.len()].iter().all(|&mu| mu < 0.5))
}

/// `newton` with friction.md's acceleration on or off (it must be off
/// unless every touching μ < 0.5).
pub fn newton_with(ct: &Contacts, accelerate: bool) -> Solved {
    let (s, ok) = gauss_seidel(ct, None, false, accelerate);
    if ok {
        return s;
    }
    let first = s.sweeps;
    let (mut s, ok) = gauss_seidel(ct, None, true, accelerate);
    s.sweeps += first;
    s.jammed = true;
    if !ok {
        s.unconverged = true;
    }
    s
}

/// `pgsN` with friction: `sweeps` sweeps of the same Gauss–Seidel.
pub fn pgs(ct: &Contacts, sweeps: u32) -> Solved {
    gauss_seidel(ct, Some(sweeps), false, false).0
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
