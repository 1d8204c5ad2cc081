//! The LCP over the touching planes in lanes: exact enumeration of the
//! supports for N ≤ 3, with a certificate for the full or empty support
//! (physics.md §4).

// Lane code indexes SoA arrays by lane and contact on purpose: the index
// form is what the loop vectoriser sees through.
#![allow(clippy::needless_range_loop, clippy::manual_memcpy)]

use crate::kernel::geometry::{conditioned_with, g_at, well_conditioned};
use crate::kernel::{Consts, Geometry};
use crate::lanes::dispatch::BLOCK;
use crate::lanes::{select, Real};

/// Solves `G_SS λ_S = −q_S` for the subset MASK in closed form.
#[inline(always)]
pub(crate) fn solve_subset<T: Real, const N: usize, const MASK: usize>(
    g: &[[T; N]; N],
    q: &[T; N],
) -> [T; N] {
    let mut idx = [0usize; 3];
    let mut m = 0;
    for i in 0..N {
        if MASK & (1 << i) != 0 {
            idx[m] = i;
            m += 1;
        }
    }
    let mut lam = [T::ZERO; N];
    match m {
        1 => {
            let i = idx[0];
            lam[i] = -q[i] / g[i][i];
        }
        2 => {
            let (i, j) = (idx[0], idx[1]);
            let det = g[i][i] * g[j][j] - g[i][j] * g[i][j];
            // One division per pair (divisions are the slow lane op).
            let inv = T::ONE / det;
            lam[i] = (-q[i] * g[j][j] + q[j] * g[i][j]) * inv;
            lam[j] = (-q[j] * g[i][i] + q[i] * g[i][j]) * inv;
        }
        _ => {
            let (r, _) = cramer3(g, q);
            for i in 0..N {
                lam[i] = r[i];
            }
        }
    }
    lam
}

/// `G λ = −q` for the full 3×3 by Cramer's rule with the symmetric
/// cofactors, and det G (the cofactor expansion along the first row).
#[inline(always)]
pub(crate) fn cramer3<T: Real, const N: usize>(g: &[[T; N]; N], q: &[T; N]) -> ([T; 3], T) {
    let c00 = g[1][1] * g[2][2] - g[1][2] * g[1][2];
    let c01 = g[0][2] * g[1][2] - g[0][1] * g[2][2];
    let c02 = g[0][1] * g[1][2] - g[0][2] * g[1][1];
    let c11 = g[0][0] * g[2][2] - g[0][2] * g[0][2];
    let c12 = g[0][1] * g[0][2] - g[0][0] * g[1][2];
    let c22 = g[0][0] * g[1][1] - g[0][1] * g[0][1];
    let det = g[0][0] * c00 + g[0][1] * c01 + g[0][2] * c02;
    let inv = -T::ONE / det;
    let r = [
        (c00 * q[0] + c01 * q[1] + c02 * q[2]) * inv,
        (c01 * q[0] + c11 * q[1] + c12 * q[2]) * inv,
        (c02 * q[0] + c12 * q[1] + c22 * q[2]) * inv,
    ];
    (r, det)
}

/// Largest violation of `λ ≥ 0` (as `−λ_i G_ii`) on the support and of
/// `w = q + Gλ ≥ 0` off it.
#[inline(always)]
pub(crate) fn violation<T: Real, const N: usize, const MASK: usize>(
    g: &[[T; N]; N],
    q: &[T; N],
    lam: &[T; N],
) -> T {
    let mut v = T::ZERO;
    for i in 0..N {
        let term = if MASK & (1 << i) != 0 {
            -lam[i] * g[i][i]
        } else {
            let mut w = q[i];
            for j in 0..N {
                w += g[i][j] * lam[j];
            }
            -w
        };
        v = v.max(term);
    }
    v
}

/// Running choice among LCP candidates: the first whose violation is at
/// rounding level, else the least violating (the rule of `physics::lcp`).
pub(crate) struct Choice<T, const N: usize> {
    lam: [T; N],
    viol: T,
    found: bool,
}

impl<T: Real, const N: usize> Choice<T, N> {
    #[inline(always)]
    fn offer<const MASK: usize>(&mut self, g: &[[T; N]; N], q: &[T; N], accept: T) {
        let lam = solve_subset::<T, N, MASK>(g, q);
        let viol = violation::<T, N, MASK>(g, q, &lam);
        let take = !self.found && (viol <= accept || viol < self.viol);
        for i in 0..N {
            self.lam[i] = select(take, lam[i], self.lam[i]);
        }
        self.viol = select(take, viol, self.viol);
        self.found |= viol <= accept;
    }
}

/// Exact LCP(q, G) for N ≤ 3 by enumeration in (size, mask) order. Returns
/// λ (clamped ≥ 0) and whether a candidate met the feasibility tolerance.
#[inline(always)]
pub(crate) fn lcp_lane<T: Real, const N: usize>(
    c: &Consts<T, N>,
    g: &[[T; N]; N],
    q: &[T; N],
) -> ([T; N], bool) {
    let mut scale = T::ZERO;
    let mut viol0 = T::ZERO;
    for i in 0..N {
        scale = scale.max(q[i].abs());
        viol0 = viol0.max(-q[i]);
    }
    let accept = c.accept * scale;
    let mut ch = Choice {
        lam: [T::ZERO; N],
        viol: viol0,
        found: viol0 <= accept,
    };
    match N {
        1 => ch.offer::<1>(g, q, accept),
        2 => {
            ch.offer::<1>(g, q, accept);
            ch.offer::<2>(g, q, accept);
            ch.offer::<3>(g, q, accept);
        }
        _ => {
            ch.offer::<1>(g, q, accept);
            ch.offer::<2>(g, q, accept);
            ch.offer::<4>(g, q, accept);
            ch.offer::<3>(g, q, accept);
            ch.offer::<5>(g, q, accept);
            ch.offer::<6>(g, q, accept);
            ch.offer::<7>(g, q, accept);
        }
    }
    let ok = ch.viol <= c.feasible * scale;
    (ch.lam.map(|l| l.max(T::ZERO)), ok)
}

/// The empty or the full support's candidate, and whether it is certainly
/// what [`lcp_lane`] returns: λ = 0 when the empty support is acceptable
/// (it is tried first); else `λ = −G⁻¹q` when every λᵢ > 0 and
/// `min λᵢ · det G > 8 · accept · (tr G)^(N−1)`.
///
/// Why that suffices: with f(λ) = ½λᵀGλ + qᵀλ, the full candidate λ* is
/// f's unconstrained minimum and a smaller support S's candidate λˢ is its
/// minimum on the face λᵢ = 0 (i ∉ S). With d = λ* − λˢ, ∇f(λˢ) = −Gd is
/// zero on S, so `Σ_{i∉S} wᵢ λ*ᵢ = −dᵀGd ≤ −σ_min Σ_{i∉S} λ*ᵢ²`, and some
/// i ∉ S has `−wᵢ ≥ σ_min · min λ*`. Since `σ_min ≥ det G / (tr G)^(N−1)`
/// (the other eigenvalues are at most the trace), every smaller support
/// violates `w ≥ 0` by more than 8× the acceptance tolerance (so by more
/// than rounding too), none is accepted before the full one, and the
/// enumeration would return λ* itself (already positive, so unclamped),
/// computed by the same `solve_subset`, with a negative violation (ok).
#[inline(always)]
pub(crate) fn full_support<T: Real, const N: usize>(
    c: &Consts<T, N>,
    g: &[[T; N]; N],
    q: &[T; N],
) -> ([T; N], bool, bool) {
    // The full support's candidate, as `solve_subset` computes it, and
    // with three contacts the determinant Cramer's rule already took.
    let (lam, det3) = match N {
        1 => (solve_subset::<T, N, 1>(g, q), T::ZERO),
        2 => (solve_subset::<T, N, 3>(g, q), T::ZERO),
        _ => {
            let (r, det) = cramer3(g, q);
            (std::array::from_fn(|i| r[i]), det)
        }
    };
    let mut scale = T::ZERO;
    let mut viol0 = T::ZERO;
    let mut least = T::INFINITY;
    let mut trace = T::ZERO;
    for i in 0..N {
        scale = scale.max(q[i].abs());
        viol0 = viol0.max(-q[i]);
        least = least.min(lam[i]);
        trace += g[i][i];
    }
    let (det, bound) = match N {
        1 => (g[0][0], T::ONE),
        2 => (g[0][0] * g[1][1] - g[0][1] * g[0][1], trace),
        _ => (det3, trace * trace),
    };
    let margin = T::from_f64(8.0) * c.accept * scale * bound;
    // The empty support comes first in the enumeration and wins whenever
    // its violation is acceptable (no contact approaching): λ = 0.
    let empty = viol0 <= c.accept * scale;
    let lam = lam.map(|l| select(empty, T::ZERO, l));
    // `well_conditioned(g)` from the same determinant: its expansion is
    // Cramer's term for term (g symmetric), so the same bit.
    (
        lam,
        empty | ((least > T::ZERO) & (least * det > margin)),
        conditioned_with(g, det, c.det_min),
    )
}

/// [`lcp_lane`] for every lane of a block, with `q` by lane: the empty or
/// the full support's candidate where [`full_support`] certifies it (on S3
/// about 96 % of lanes under Newton), and the enumeration, 16 lanes at a
/// time, for the lanes gathered from the rest (in place when they are more
/// than a quarter of the block). The same answers as `lcp_lane` in every
/// lane.
#[inline(always)]
pub(crate) fn lcp_block<T: Real, const N: usize, const ROT: bool>(
    c: &Consts<T, N>,
    geo: &Geometry<T, N>,
    q: &[[T; BLOCK]; N],
    lam: &mut [[T; BLOCK]; N],
    ok: &mut [bool; BLOCK],
    conditioned: &mut [bool; BLOCK],
) {
    let mut certain = [false; BLOCK];
    each_lane::<T, N, ROT, true>(c, geo, q, lam, &mut certain, conditioned);
    // A certified candidate meets the conditions.
    *ok = [true; BLOCK];
    // The other lanes, compacted (branch-free) and enumerated in chunks of
    // 16 (the last chunk padded with copies of its last lane).
    let mut idx = [0u16; BLOCK];
    let mut m = 0;
    for s in 0..BLOCK {
        idx[m] = s as u16;
        m += !certain[s] as usize;
    }
    if m > BLOCK / 4 {
        // Many uncertain lanes (a scene whose contacts seldom all engage):
        // gathering would cost more than enumerating every lane in place.
        lcp_lanes::<T, N, ROT>(c, geo, q, lam, ok, conditioned);
        return;
    }
    for start in (0..m).step_by(16) {
        let len = (m - start).min(16);
        let mut dg = [[[T::ZERO; 16]; N]; N];
        let mut dq = [[T::ZERO; 16]; N];
        for t in 0..16 {
            let s = idx[start + t.min(len - 1)] as usize;
            for i in 0..N {
                dq[i][t] = q[i][s];
                for j in i..N {
                    dg[i][j][t] = g_at::<T, N, ROT>(c, geo, i, j, s);
                }
            }
        }
        let mut dl = [[T::ZERO; 16]; N];
        let mut dok = [false; 16];
        for t in 0..16 {
            let g: [[T; N]; N] =
                std::array::from_fn(|i| std::array::from_fn(|j| dg[i.min(j)][i.max(j)][t]));
            let qs: [T; N] = std::array::from_fn(|i| dq[i][t]);
            let (l, o) = lcp_lane(c, &g, &qs);
            for i in 0..N {
                dl[i][t] = l[i];
            }
            dok[t] = o;
        }
        for t in 0..len {
            let s = idx[start + t] as usize;
            for i in 0..N {
                lam[i][s] = dl[i][t];
            }
            ok[s] = dok[t];
        }
    }
}

/// [`lcp_lane`] in every lane of a block, with `q` by lane.
#[inline(always)]
pub(crate) fn lcp_lanes<T: Real, const N: usize, const ROT: bool>(
    c: &Consts<T, N>,
    geo: &Geometry<T, N>,
    q: &[[T; BLOCK]; N],
    lam: &mut [[T; BLOCK]; N],
    ok: &mut [bool; BLOCK],
    conditioned: &mut [bool; BLOCK],
) {
    each_lane::<T, N, ROT, false>(c, geo, q, lam, ok, conditioned);
}

/// [`full_support`] (`CERTIFY`) or [`lcp_lane`] of every lane of a block
/// into `lam` and `flag`, and whether G is well conditioned. The solver is
/// chosen by a constant, not passed as a closure: LLVM left such a closure
/// out of line, compiled for baseline x86-64 whatever the caller's target,
/// and called it once per lane.
#[inline(always)]
pub(crate) fn each_lane<T: Real, const N: usize, const ROT: bool, const CERTIFY: bool>(
    c: &Consts<T, N>,
    geo: &Geometry<T, N>,
    q: &[[T; BLOCK]; N],
    lam: &mut [[T; BLOCK]; N],
    flag: &mut [bool; BLOCK],
    conditioned: &mut [bool; BLOCK],
) {
    for s in 0..BLOCK {
        let g = lane_g::<T, N, ROT>(c, geo, s);
        let qs: [T; N] = std::array::from_fn(|i| q[i][s]);
        let (l, f, w) = if CERTIFY {
            full_support(c, &g, &qs)
        } else {
            let (l, f) = lcp_lane(c, &g, &qs);
            (l, f, well_conditioned(&g, c.det_min))
        };
        for i in 0..N {
            lam[i][s] = l[i];
        }
        flag[s] = f;
        conditioned[s] = w;
    }
}

#[inline(always)]
pub(crate) fn lane_g<T: Real, const N: usize, const ROT: bool>(
    c: &Consts<T, N>,
    geo: &Geometry<T, N>,
    s: usize,
) -> [[T; N]; N] {
    std::array::from_fn(|i| std::array::from_fn(|j| g_at::<T, N, ROT>(c, geo, i, j, s)))
}
