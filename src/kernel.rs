//! The SoA impact kernel: closed-form contact geometry and impulses for a
//! block of samples against the N ≤ 3 planes the placement makes touch.
//!
//! Every pass is a branch-free loop over the lanes of a block, written once
//! for [`Real`] and const N, so the loop vectoriser can use full-width SIMD
//! (see `lanes.rs`). Laws are chosen per pass, never per sample. Lanes whose
//! answer the fast path cannot vouch for are flagged [`RECOMPUTE`] and solved
//! again by the f64 reference in `physics/`:
//! - G nearly singular: `det S < det_min` (S the unit-diagonal G; by
//!   Fischer's and Hadamard's inequalities every principal submatrix is then
//!   at least as well conditioned, so no subset solve can blow up);
//! - grazing contacts in f32 (`|v_n| < 1e-5 · (|v| + L|ω|)`), where the
//!   approaching test and the rebound ratio are not trustworthy (f32 rounds
//!   v_n to about 1e-7 of the scale, so above the margin the test cannot be
//!   misjudged; a misjudged lane would move v⁺ by only O(|v_n|) anyway,
//!   since every law is continuous in v_n);
//! - f32 energy changes within rounding of the `energy_gain` threshold;
//! - an LCP without an acceptable candidate (jammed, or rounding);
//! - a plane outside the placement that touches or is penetrated.

// Lane code indexes SoA arrays by lane and contact on purpose: the index
// form is what the loop vectoriser sees through.
#![allow(clippy::needless_range_loop, clippy::manual_memcpy)]

use glam::{DMat3, DVec3};

use crate::lanes::{select, Real};
use crate::physics::{solve_impact, Law, Pose, State};
use crate::sampler::{Inputs, BLOCK};
use crate::scene::Scene;

/// Lane status bits.
pub const APPROACHING_SHIFT: u32 = 0; // bits 0..N: contact i approaching
pub const ACTIVE_SHIFT: u32 = 4; // bits 4..4+N: λ_i > 0
pub const RECOMPUTE: u32 = 1 << 8;
pub const ENERGY_GAIN: u32 = 1 << 9;
pub const DEGENERATE: u32 = 1 << 10;
pub const JAMMED: u32 = 1 << 11;
pub const UNSOLVED: u32 = 1 << 12;
pub const PENETRATING: u32 = 1 << 13;
pub const RECOMPUTED: u32 = 1 << 14;

/// `flag` when `c` holds, else 0, without a branch.
#[inline(always)]
fn bit(c: bool, flag: u32) -> u32 {
    (c as u32) * flag
}

/// Constants of a scene for the kernel, in the lane type.
#[derive(Debug, Clone)]
pub struct Consts<T, const N: usize> {
    normal: [[T; 3]; N],
    k: [T; N],
    mass: T,
    inv_mass: T,
    inertia: [T; 3],
    inv_inertia: [T; 3],
    semi2: [T; 3],
    /// (b² − c², c² − a², a² − b²), for the lever arm in its sphere-exact form.
    dsq: [T; 3],
    nn: [[T; N]; N],
    /// G without rotational coupling (ρ = 0): `nn / m`, the same in every lane.
    g0: [[T; N]; N],
    length: T,
    det_min: T,
    graze: T,
    accept: T,
    feasible: T,
    /// When every touching plane's normal is ±e_k (exactly): k per plane.
    /// Then Aᵀn is ± row k of A and n·v is ±v_k, with no arithmetic.
    axes: Option<[usize; N]>,
}

impl<T: Real, const N: usize> Consts<T, N> {
    /// The rows of A the geometry passes read (bit r: row r): one per plane
    /// along an axis, else all.
    pub fn matrix_rows(&self) -> u8 {
        match self.axes {
            Some(rows) => rows.iter().fold(0, |m, &k| m | 1 << k),
            None => crate::sampler::ALL_ROWS,
        }
    }

    pub fn new(scene: &Scene) -> Self {
        assert_eq!(scene.touching().len(), N, "kernel width");
        let f32_lanes = T::EPSILON.to_f64() > 1e-10;
        let planes = scene.touching_planes();
        let body = scene.body();
        let s = body.semi_axes();
        let (a2, b2, c2) = (s.x * s.x, s.y * s.y, s.z * s.z);
        Self {
            normal: std::array::from_fn(|i| planes[i].normal().to_array().map(T::from_f64)),
            k: std::array::from_fn(|i| T::from_f64(planes[i].restitution())),
            mass: T::from_f64(body.mass()),
            inv_mass: T::from_f64(1.0 / body.mass()),
            inertia: body.inertia().to_array().map(T::from_f64),
            inv_inertia: body.inertia().recip().to_array().map(T::from_f64),
            semi2: [a2, b2, c2].map(T::from_f64),
            dsq: [
                (s.y - s.z) * (s.y + s.z),
                (s.z - s.x) * (s.z + s.x),
                (s.x - s.y) * (s.x + s.y),
            ]
            .map(T::from_f64),
            nn: std::array::from_fn(|i| {
                std::array::from_fn(|j| T::from_f64(planes[i].normal().dot(planes[j].normal())))
            }),
            g0: std::array::from_fn(|i| {
                std::array::from_fn(|j| {
                    T::from_f64(planes[i].normal().dot(planes[j].normal()))
                        * T::from_f64(1.0 / body.mass())
                })
            }),
            length: T::from_f64(body.length_scale()),
            det_min: T::from_f64(if f32_lanes { 1e-3 } else { 1e-8 }),
            graze: T::from_f64(if f32_lanes { 1e-5 } else { 0.0 }),
            accept: T::from_f64(if f32_lanes {
                1e-5
            } else {
                crate::physics::ACCEPT_RELATIVE
            }),
            feasible: T::from_f64(if f32_lanes {
                1e-3
            } else {
                crate::physics::FEASIBILITY_RELATIVE
            }),
            axes: {
                let axis = |n: [f64; 3]| {
                    let k = n.iter().position(|x| x.abs() == 1.0)?;
                    (n.iter().filter(|&&x| x == 0.0).count() == 2).then_some(k)
                };
                let ks: Vec<usize> = planes
                    .iter()
                    .filter_map(|p| axis(p.normal().to_array()))
                    .collect();
                (ks.len() == N).then(|| std::array::from_fn(|i| ks[i]))
            },
        }
    }
}

/// Contact geometry and pre-impact quantities of a block. Cache-line
/// aligned (as are [`LawOut`] and `sampler::Inputs`): every lane array then
/// starts on a 64-byte line, so full-width loads never split lines.
#[repr(C, align(64))]
pub struct Geometry<T, const N: usize> {
    pub vn: [[T; BLOCK]; N],
    pub rho: [[[T; BLOCK]; 3]; N],
    /// G per lane: only the upper triangle (`g[i][j]`, i ≤ j) is written.
    pub g: [[[T; BLOCK]; N]; N],
    pub t_before: [T; BLOCK],
    pub status: [u32; BLOCK],
}

/// Per-law results of a block.
#[repr(C, align(64))]
pub struct LawOut<T, const N: usize> {
    pub lambda: [[T; BLOCK]; N],
    pub vn_after: [[T; BLOCK]; N],
    pub v_after: [[T; BLOCK]; 3],
    pub w_after: [[T; BLOCK]; 3],
    pub t_after: [T; BLOCK],
    pub status: [u32; BLOCK],
}

impl<T: Real, const N: usize> Geometry<T, N> {
    pub fn new() -> Box<Self> {
        Box::new(Self {
            vn: [[T::ZERO; BLOCK]; N],
            rho: [[[T::ZERO; BLOCK]; 3]; N],
            g: [[[T::ZERO; BLOCK]; N]; N],
            t_before: [T::ZERO; BLOCK],
            status: [0; BLOCK],
        })
    }
}

impl<T: Real, const N: usize> LawOut<T, N> {
    pub fn new() -> Box<Self> {
        Box::new(Self {
            lambda: [[T::ZERO; BLOCK]; N],
            vn_after: [[T::ZERO; BLOCK]; N],
            v_after: [[T::ZERO; BLOCK]; 3],
            w_after: [[T::ZERO; BLOCK]; 3],
            t_after: [T::ZERO; BLOCK],
            status: [0; BLOCK],
        })
    }
}

/// G_ij of lane s: per lane with rotational coupling, else the constant
/// `nn / m` (ρ = 0), which the geometry pass then never writes.
#[inline(always)]
fn g_at<T: Real, const N: usize, const ROT: bool>(
    c: &Consts<T, N>,
    geo: &Geometry<T, N>,
    i: usize,
    j: usize,
    s: usize,
) -> T {
    if ROT {
        // G is symmetric: only its upper triangle is stored.
        geo.g[i.min(j)][i.max(j)][s]
    } else {
        c.g0[i][j]
    }
}

/// Geometry pass: support points, lever arms, normal velocities, G, T⁻.
///
/// `ROT = false` is the kernel without rotational coupling (a sphere: ρ = 0
/// whatever the orientation): no support points, lever arms or per-lane G.
/// ω still enters T⁻ and the grazing scale, so both kernels give the same
/// answer on a sphere.
#[inline(always)]
pub fn geometry<T: Real, const N: usize, const ROT: bool>(
    c: &Consts<T, N>,
    x: &Inputs<T>,
    out: &mut Geometry<T, N>,
    conditioning: bool,
) {
    let det_ok0 = well_conditioned(&c.g0, c.det_min);
    // Planes along the axes (every shipped scene) read rows of A and
    // components of v instead of multiplying by the normals' zeros and
    // ones: the same values (S3 f32 about 3.5 % faster end to end, S1
    // about 2.5 %; Zen 4, 2026-11-24).
    if ROT {
        // The lever arms, G and its conditioning in a pass of their own:
        // the chain from A through the support point's square root and
        // division to ρ is long, and in one loop with the rest the CPU
        // overlapped too little of it across iterations (S3 about 2–4 %
        // faster split). G's multiply-adds stay with the square roots and
        // divisions, which they overlap (S3 about 1.5 % faster than G in
        // the second pass).
        // G's conditioning test unless the caller's laws take it from the
        // determinant they compute anyway (Newton's LCP: S3 about 2 %).
        match (c.axes, conditioning) {
            (Some(rows), true) => lever_arms::<T, N, true, true>(c, rows, x, out),
            (Some(rows), false) => lever_arms::<T, N, true, false>(c, rows, x, out),
            (None, true) => lever_arms::<T, N, false, true>(c, [0; N], x, out),
            (None, false) => lever_arms::<T, N, false, false>(c, [0; N], x, out),
        }
    }
    match c.axes {
        Some(rows) => normal_velocities::<T, N, ROT, true>(c, rows, det_ok0, x, out),
        None => normal_velocities::<T, N, ROT, false>(c, [0; N], det_ok0, x, out),
    }
}

/// Normal velocities, grazing and approach bits and T⁻ of every lane (the
/// second geometry pass). `AXES` as in [`lever_arms`].
#[inline(always)]
fn normal_velocities<T: Real, const N: usize, const ROT: bool, const AXES: bool>(
    c: &Consts<T, N>,
    rows: [usize; N],
    det_ok0: bool,
    x: &Inputs<T>,
    out: &mut Geometry<T, N>,
) {
    for s in 0..BLOCK {
        let v = [x.v[0][s], x.v[1][s], x.v[2][s]];
        let w = [x.w[0][s], x.w[1][s], x.w[2][s]];
        let v2 = dot3(v, v);
        // The grazing test exists in f32 only (`graze` is 0 in f64): f64
        // lanes skip its two square roots.
        let f32_lanes = T::EPSILON.to_f64() > 1e-10;
        let vscale = if f32_lanes {
            c.length.mul_add(dot3(w, w).sqrt(), v2.sqrt())
        } else {
            T::ZERO
        };
        // With rotation, the first pass left the conditioning test's bit.
        let mut status = if ROT {
            out.status[s]
        } else {
            bit(!det_ok0, RECOMPUTE)
        };
        for i in 0..N {
            let mut vn = if AXES {
                c.normal[i][rows[i]] * x.v[rows[i]][s]
            } else {
                dot3(c.normal[i], v)
            };
            if ROT {
                let rho = [out.rho[i][0][s], out.rho[i][1][s], out.rho[i][2][s]];
                vn = rho[2].mul_add(w[2], rho[1].mul_add(w[1], rho[0].mul_add(w[0], vn)));
            }
            out.vn[i][s] = vn;
            status |= ((vn < T::ZERO) as u32) << (APPROACHING_SHIFT + i as u32);
            status |= bit(f32_lanes && vn.abs() < c.graze * vscale, RECOMPUTE);
        }
        out.t_before[s] = T::HALF
            * c.mass.mul_add(
                v2,
                dot3(
                    [
                        c.inertia[0] * w[0],
                        c.inertia[1] * w[1],
                        c.inertia[2] * w[2],
                    ],
                    w,
                ),
            );
        out.status[s] = status;
    }
}

/// The lever arms, G and its conditioning bit of every lane (the first
/// geometry pass). `AXES`: the touching normals are ±e_k, k = `rows[i]`.
#[inline(always)]
fn lever_arms<T: Real, const N: usize, const AXES: bool, const CONDITIONING: bool>(
    c: &Consts<T, N>,
    rows: [usize; N],
    x: &Inputs<T>,
    out: &mut Geometry<T, N>,
) {
    for s in 0..BLOCK {
        // u = Aᵀ n (the normal in the body frame) and h = √(uᵀ diag(a², b², c²) u).
        let u: [[T; 3]; N] = if AXES {
            // ± row k of A: the sign drops out of h, ρ and G (all even in u).
            std::array::from_fn(|i| std::array::from_fn(|col| x.a[3 * rows[i] + col][s]))
        } else {
            let a: [T; 9] = std::array::from_fn(|k| x.a[k][s]);
            std::array::from_fn(|i| {
                std::array::from_fn(|col| dot3([a[col], a[3 + col], a[6 + col]], c.normal[i]))
            })
        };
        let h: [T; N] = std::array::from_fn(|i| {
            dot3(
                [
                    c.semi2[0] * u[i][0],
                    c.semi2[1] * u[i][1],
                    c.semi2[2] * u[i][2],
                ],
                u[i],
            )
            .sqrt()
        });
        let minus_inv_h: [T; N] = std::array::from_fn(|i| -T::ONE / h[i]);
        let mut rho = [[T::ZERO; 3]; N];
        for i in 0..N {
            rho[i] = [
                c.dsq[0] * u[i][1] * u[i][2] * minus_inv_h[i],
                c.dsq[1] * u[i][2] * u[i][0] * minus_inv_h[i],
                c.dsq[2] * u[i][0] * u[i][1] * minus_inv_h[i],
            ];
            for k in 0..3 {
                out.rho[i][k][s] = rho[i][k];
            }
        }
        // G is symmetric: the upper triangle is computed and
        // stored (`g_at` reads the stored half).
        let mut g = [[T::ZERO; N]; N];
        for i in 0..N {
            for j in i..N {
                let mut gij = c.nn[i][j] * c.inv_mass;
                for k in 0..3 {
                    gij = (rho[i][k] * rho[j][k]).mul_add(c.inv_inertia[k], gij);
                }
                g[i][j] = gij;
                g[j][i] = g[i][j];
                out.g[i][j][s] = g[i][j];
            }
        }
        out.status[s] = bit(CONDITIONING && !well_conditioned(&g, c.det_min), RECOMPUTE);
    }
}

/// `a · b` with fused steps.
#[inline(always)]
fn dot3<T: Real>(a: [T; 3], b: [T; 3]) -> T {
    a[2].mul_add(b[2], a[1].mul_add(b[1], a[0] * b[0]))
}

/// Whether det S ≥ `det_min` for S the unit-diagonal scaling of G, i.e.
/// det G ≥ det_min · Π Gᵢᵢ (the diagonal is positive), without a division.
/// False for NaN.
#[inline(always)]
fn well_conditioned<T: Real, const N: usize>(g: &[[T; N]; N], det_min: T) -> bool {
    let det = match N {
        1 => g[0][0],
        2 => g[0][0] * g[1][1] - g[0][1] * g[0][1],
        _ => {
            g[0][0] * (g[1][1] * g[2][2] - g[1][2] * g[2][1])
                - g[0][1] * (g[1][0] * g[2][2] - g[1][2] * g[2][0])
                + g[0][2] * (g[1][0] * g[2][1] - g[1][1] * g[2][0])
        }
    };
    conditioned_with(g, det, det_min)
}

/// [`well_conditioned`]'s test given det G.
#[inline(always)]
fn conditioned_with<T: Real, const N: usize>(g: &[[T; N]; N], det: T, det_min: T) -> bool {
    match N {
        1 => true,
        2 => det >= det_min * (g[0][0] * g[1][1]),
        _ => det >= det_min * (g[0][0] * g[1][1] * g[2][2]),
    }
}

/// Solves `G_SS λ_S = −q_S` for the subset MASK in closed form.
#[inline(always)]
fn solve_subset<T: Real, const N: usize, const MASK: usize>(g: &[[T; N]; N], q: &[T; N]) -> [T; N] {
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
fn cramer3<T: Real, const N: usize>(g: &[[T; N]; N], q: &[T; N]) -> ([T; 3], T) {
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
fn violation<T: Real, const N: usize, const MASK: usize>(
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
struct Choice<T, const N: usize> {
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
fn lcp_lane<T: Real, const N: usize>(
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
fn full_support<T: Real, const N: usize>(
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
fn lcp_block<T: Real, const N: usize, const ROT: bool>(
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
fn lcp_lanes<T: Real, const N: usize, const ROT: bool>(
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
fn each_lane<T: Real, const N: usize, const ROT: bool, const CERTIFY: bool>(
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
fn lane_g<T: Real, const N: usize, const ROT: bool>(
    c: &Consts<T, N>,
    geo: &Geometry<T, N>,
    s: usize,
) -> [[T; N]; N] {
    std::array::from_fn(|i| std::array::from_fn(|j| g_at::<T, N, ROT>(c, geo, i, j, s)))
}

/// Impulse pass for the exact laws and the paper's law.
///
/// `CPL = false` is the kernel without coupled contacts (one plane, or G
/// diagonal by geometry): every law then has the closed form
/// `λ_i = −(1 + k_i) v_n,i / G_ii` on approaching contacts and no LCP is
/// solved (physics.md: the LCP decouples when G is diagonal, and Poisson's
/// and PGS's fixed points coincide with Newton's).
#[inline(always)]
pub fn impulses<T: Real, const N: usize, const ROT: bool, const CPL: bool>(
    c: &Consts<T, N>,
    law: Law,
    geo: &Geometry<T, N>,
    out: &mut LawOut<T, N>,
) {
    let law = if CPL { law } else { Law::Paper };
    match law {
        Law::Paper => {
            for s in 0..BLOCK {
                for i in 0..N {
                    let vn = geo.vn[i][s];
                    out.lambda[i][s] = select(
                        vn < T::ZERO,
                        -(T::ONE + c.k[i]) * vn / g_at::<T, N, ROT>(c, geo, i, i, s),
                        T::ZERO,
                    );
                }
                out.status[s] = geo.status[s];
            }
        }
        Law::Newton => {
            // q in `vn_after`, which `post` then overwrites: a local array
            // cost a memset per block (LLVM zeroes it before the loop).
            let q = &mut out.vn_after;
            for i in 0..N {
                for s in 0..BLOCK {
                    let vn = geo.vn[i][s];
                    q[i][s] = vn + c.k[i] * vn.min(T::ZERO);
                }
            }
            let mut ok = [true; BLOCK];
            let mut conditioned = [true; BLOCK];
            lcp_block::<T, N, ROT>(
                c,
                geo,
                &out.vn_after,
                &mut out.lambda,
                &mut ok,
                &mut conditioned,
            );
            // G's conditioning (`geometry` leaves it to this law when it
            // is the only one; the same bit either way).
            for s in 0..BLOCK {
                out.status[s] = geo.status[s] | bit(!(ok[s] & conditioned[s]), RECOMPUTE);
            }
        }
        Law::Poisson => {
            // Compression, then restitution: two LCPs per lane.
            let mut lc = [[T::ZERO; BLOCK]; N];
            let mut ok1 = [true; BLOCK];
            let mut conditioned = [true; BLOCK];
            lcp_block::<T, N, ROT>(c, geo, &geo.vn, &mut lc, &mut ok1, &mut conditioned);
            let mut q = [[T::ZERO; BLOCK]; N];
            for s in 0..BLOCK {
                let g = lane_g::<T, N, ROT>(c, geo, s);
                let klc: [T; N] = std::array::from_fn(|i| c.k[i] * lc[i][s]);
                for i in 0..N {
                    let mut x = geo.vn[i][s];
                    for j in 0..N {
                        x += g[i][j] * (lc[j][s] + klc[j]);
                    }
                    q[i][s] = x;
                }
            }
            // The restitution phase's supports are mixed (about 44 % of S3's
            // lanes are neither empty nor full), so no certificate is tried.
            let mut ok2 = [true; BLOCK];
            lcp_lanes::<T, N, ROT>(c, geo, &q, &mut out.lambda, &mut ok2, &mut conditioned);
            for s in 0..BLOCK {
                for i in 0..N {
                    out.lambda[i][s] = lc[i][s] + c.k[i] * lc[i][s] + out.lambda[i][s];
                }
                out.status[s] = geo.status[s] | bit(!(ok1[s] && ok2[s]), RECOMPUTE);
            }
        }
        Law::Pgs { sweeps } => {
            for i in 0..N {
                out.lambda[i] = [T::ZERO; BLOCK];
            }
            // Sweeps outermost, so the inner loop over lanes vectorises.
            for _ in 0..sweeps {
                for s in 0..BLOCK {
                    let mut lam: [T; N] = std::array::from_fn(|i| out.lambda[i][s]);
                    for i in 0..N {
                        let vn = geo.vn[i][s];
                        let mut w = vn + c.k[i] * vn.min(T::ZERO);
                        for j in 0..N {
                            w += g_at::<T, N, ROT>(c, geo, i, j, s) * lam[j];
                        }
                        lam[i] = (lam[i] - w / g_at::<T, N, ROT>(c, geo, i, i, s)).max(T::ZERO);
                    }
                    for i in 0..N {
                        out.lambda[i][s] = lam[i];
                    }
                }
            }
            out.status = geo.status;
        }
    }
}

/// Post pass: velocities, normal velocities and energy after the impulses.
/// Without rotational coupling (`ROT = false`) ω⁺ = ω⁻.
#[inline(always)]
pub fn post<T: Real, const N: usize, const ROT: bool>(
    c: &Consts<T, N>,
    x: &Inputs<T>,
    geo: &Geometry<T, N>,
    out: &mut LawOut<T, N>,
) {
    let f32_lanes = T::EPSILON.to_f64() > 1e-10;
    let gain = T::from_f64(crate::physics::ENERGY_GAIN_RELATIVE);
    let ambiguous = T::from_f64(64.0) * T::EPSILON;
    for s in 0..BLOCK {
        let lam: [T; N] = std::array::from_fn(|i| out.lambda[i][s]);
        let mut dv = [T::ZERO; 3];
        let mut dl = [T::ZERO; 3];
        let mut active = 0u32;
        for i in 0..N {
            for k in 0..3 {
                dv[k] = lam[i].mul_add(c.normal[i][k], dv[k]);
                if ROT {
                    dl[k] = lam[i].mul_add(geo.rho[i][k][s], dl[k]);
                }
            }
            active |= ((lam[i] > T::ZERO) as u32) << (ACTIVE_SHIFT + i as u32);
        }
        let v: [T; 3] = std::array::from_fn(|k| dv[k].mul_add(c.inv_mass, x.v[k][s]));
        let w: [T; 3] = std::array::from_fn(|k| {
            if ROT {
                dl[k].mul_add(c.inv_inertia[k], x.w[k][s])
            } else {
                x.w[k][s]
            }
        });
        let mut work = T::ZERO;
        let mut work_abs = T::ZERO;
        for i in 0..N {
            let mut vn = geo.vn[i][s];
            for j in 0..N {
                vn = g_at::<T, N, ROT>(c, geo, i, j, s).mul_add(lam[j], vn);
            }
            out.vn_after[i][s] = vn;
            work += lam[i] * (geo.vn[i][s] + vn);
            work_abs += lam[i] * (geo.vn[i][s].abs() + vn.abs());
        }
        let t0 = geo.t_before[s];
        let direct = T::HALF
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
        // f32: T⁺ = T⁻ + ΔT with ΔT = ½Σλ(v_n⁻ + v_n⁺) exactly (physics.md),
        // accurate relative to ΔT rather than to T.
        let dt = T::HALF * work;
        let t1 = if f32_lanes { t0 + dt } else { direct };
        let gained = if f32_lanes {
            dt > gain * t0
        } else {
            t1 > t0 + gain * t0
        };
        // Rounding bound of dt: a few ε of the sum of |terms|. Only when
        // the threshold lies within it is the f32 flag in doubt.
        let unsure = f32_lanes && (dt - gain * t0).abs() <= ambiguous * (work_abs + gain * t0);
        for k in 0..3 {
            out.v_after[k][s] = v[k];
            out.w_after[k][s] = w[k];
        }
        out.t_after[s] = t1;
        out.status[s] |= active | bit(gained, ENERGY_GAIN) | bit(unsure, RECOMPUTE);
    }
}

/// Marks lanes where a plane outside the placement touches or is penetrated
/// (the f64 reference then decides). Scalar, and skipped entirely when every
/// plane of the scene is in the placement.
pub fn check_extra_planes<T: Real, const N: usize>(
    scene: &Scene,
    x: &Inputs<T>,
    geo: &mut Geometry<T, N>,
    count: usize,
) {
    if scene.planes().len() == N {
        return;
    }
    for (s, status) in geo.status.iter_mut().enumerate().take(count) {
        let a = lane_matrix(x, s);
        let centre = scene.centre(a);
        for (j, p) in scene.planes().iter().enumerate() {
            if scene.touching().contains(&j) {
                continue;
            }
            let u = a.transpose() * p.plane.normal();
            let h = (scene.body().semi_axes() * u).length();
            let d = p.plane.signed_distance(centre) - h;
            if d <= scene.tolerance() {
                *status |= RECOMPUTE;
            }
        }
    }
}

fn lane_matrix<T: Real>(x: &Inputs<T>, s: usize) -> DMat3 {
    let r: [f64; 9] = std::array::from_fn(|k| x.a[k][s].to_f64());
    DMat3::from_cols_array(&r).transpose()
}

/// Solves flagged lanes again with the f64 reference on the same inputs and
/// writes the answers back, with the reference's flags.
pub fn recompute<T: Real, const N: usize>(
    scene: &Scene,
    law: Law,
    x: &Inputs<T>,
    out: &mut LawOut<T, N>,
    count: usize,
) {
    // Most blocks have no flagged lane: one vectorised test first.
    let mut any = 0u32;
    for st in &out.status[..count] {
        any |= st & RECOMPUTE;
    }
    if any == 0 {
        return;
    }
    let planes: Vec<_> = scene.planes().iter().map(|p| p.plane).collect();
    for s in 0..count {
        if out.status[s] & RECOMPUTE == 0 {
            continue;
        }
        let a = lane_matrix(x, s);
        let state = State {
            velocity: DVec3::new(x.v[0][s].to_f64(), x.v[1][s].to_f64(), x.v[2][s].to_f64()),
            omega: DVec3::new(x.w[0][s].to_f64(), x.w[1][s].to_f64(), x.w[2][s].to_f64()),
        };
        let pose = Pose {
            rotation: a,
            centre: scene.centre(a),
        };
        let mut status = RECOMPUTED;
        let Ok(o) = solve_impact(scene.body(), pose, state, &planes, law, scene.tolerance()) else {
            out.status[s] = status | UNSOLVED;
            continue;
        };
        if o.contacts
            .iter()
            .any(|c| c.geometry.distance < -scene.tolerance())
        {
            status |= PENETRATING;
        }
        for (i, &p) in scene.touching().iter().enumerate() {
            let ct = &o.contacts[p];
            out.lambda[i][s] = T::from_f64(ct.impulse);
            out.vn_after[i][s] = T::from_f64(ct.normal_velocity_after);
            status |= ((ct.impulse > 0.0) as u32) << (ACTIVE_SHIFT + i as u32);
            status |= (ct.approaching as u32) << (APPROACHING_SHIFT + i as u32);
        }
        for k in 0..3 {
            out.v_after[k][s] = T::from_f64(o.after.velocity[k]);
            out.w_after[k][s] = T::from_f64(o.after.omega[k]);
        }
        out.t_after[s] = T::from_f64(o.energy_after);
        status |= bit(o.flags.energy_gain, ENERGY_GAIN)
            | bit(o.flags.degenerate, DEGENERATE)
            | bit(o.flags.jammed, JAMMED)
            | bit(o.flags.unsolved, UNSOLVED);
        out.status[s] = status;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lanes::mix64;
    use crate::scene::{load_scene, Overrides};

    fn consts<T: Real, const N: usize>(name: &str) -> Consts<T, N> {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("configs")
            .join(name);
        Consts::new(&load_scene(&path, &Overrides::default()).expect("shipped scene"))
    }

    /// `lcp_block` (certified empty and full supports, the rest enumerated
    /// in compacted chunks or, when many, in place) returns exactly what
    /// `lcp_lane` returns, lane by lane, on random SPD matrices: in blocks
    /// of mostly clear-cut LCPs (all contacts engaged, or none), and in
    /// blocks of LCPs built at and near the boundary between supports
    /// (impulses and slacks from 0 to 1 over ten decades), where the
    /// certificate must refuse.
    fn block_is_lane_by_lane<T: Real, const N: usize>(scene: &str) {
        let c = consts::<T, N>(scene);
        let mut state = 1u64;
        let mut next = || {
            state += 1;
            (mix64(state) >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut fast, mut slow, mut gathered, mut ill) = (0, 0, 0, 0);
        for block in 0..200 {
            let easy = block % 2 == 0;
            let mut geo = Geometry::<T, N>::new();
            let mut q = [[T::ZERO; BLOCK]; N];
            for s in 0..BLOCK {
                // G = BᵀB + εI with B random: symmetric positive definite;
                // in one lane of 32, B with two equal columns and ε = 0 (G
                // singular to rounding: ill-conditioned in both types).
                let mut b: [[f64; 3]; 3] =
                    std::array::from_fn(|_| std::array::from_fn(|_| next() - 0.5));
                let singular = s % 32 == 5;
                if singular {
                    for row in b.iter_mut() {
                        row[N - 1] = row[0];
                    }
                }
                let eps = if singular { 0.0 } else { 1e-3 };
                let g: [[f64; N]; N] = std::array::from_fn(|i| {
                    std::array::from_fn(|j| {
                        (0..3).map(|k| b[k][i] * b[k][j]).sum::<f64>()
                            + if i == j { eps } else { 0.0 }
                    })
                });
                for i in 0..N {
                    for j in i..N {
                        geo.g[i][j][s] = T::from_f64(g[i][j]);
                    }
                }
                // λ* ≥ 0 and w* ≥ 0, complementary, q = w* − Gλ*; or q at random.
                let tiny = |x: f64| 10f64.powf(-10.0 * x);
                let kind = next();
                let hard = !easy || kind >= 0.95;
                let lam: [f64; N] = std::array::from_fn(|_| {
                    if easy && kind < 0.9 {
                        0.05 + next()
                    } else if (easy && kind < 0.95) || next() < 0.3 {
                        0.0
                    } else {
                        tiny(next())
                    }
                });
                for i in 0..N {
                    let w = match (lam[i] > 0.0, hard) {
                        (true, _) => 0.0,
                        (false, true) => tiny(next()),
                        (false, false) => next(),
                    };
                    let glam: f64 = (0..N).map(|j| g[i][j] * lam[j]).sum();
                    let random = !easy && s % 4 == 0;
                    q[i][s] = T::from_f64(if random { next() - 0.7 } else { w - glam });
                }
            }
            let mut lam = [[T::ZERO; BLOCK]; N];
            let mut ok = [false; BLOCK];
            let mut conditioned = [false; BLOCK];
            lcp_block::<T, N, true>(&c, &geo, &q, &mut lam, &mut ok, &mut conditioned);
            let uncertain = (0..BLOCK)
                .filter(|&s| {
                    let qs: [T; N] = std::array::from_fn(|i| q[i][s]);
                    !full_support(&c, &lane_g::<T, N, true>(&c, &geo, s), &qs).1
                })
                .count();
            gathered += (uncertain > 0 && uncertain <= BLOCK / 4) as usize;
            for s in 0..BLOCK {
                let g = lane_g::<T, N, true>(&c, &geo, s);
                let qs: [T; N] = std::array::from_fn(|i| q[i][s]);
                let (want, want_ok) = lcp_lane(&c, &g, &qs);
                let got: [T; N] = std::array::from_fn(|i| lam[i][s]);
                assert_eq!((got, ok[s]), (want, want_ok), "lane {s}: G {g:?}, q {qs:?}");
                // The conditioning bit Newton's law takes from the LCP is
                // the geometry pass's.
                let want_conditioned = well_conditioned(&g, c.det_min);
                assert_eq!(conditioned[s], want_conditioned, "lane {s}: G {g:?}");
                ill += !want_conditioned as usize;
                if full_support(&c, &g, &qs).1 {
                    fast += 1;
                } else {
                    slow += 1;
                }
            }
        }
        // Every route was exercised: certified lanes, enumerated lanes, and
        // blocks whose few uncertain lanes were gathered.
        assert!(
            fast > 1000 && slow > 1000,
            "{fast} certified, {slow} enumerated"
        );
        assert!(gathered > 50, "{gathered} blocks gathered");
        assert!(ill > 0, "no ill-conditioned G drawn");
    }

    /// The geometry passes' axis route (rows of A, components of v) gives
    /// what the general one (products with the normals) gives, bit for bit,
    /// on drawn blocks: the corner's three planes, the same with walls
    /// facing −x and −y, and the floor alone, in both precisions.
    fn axis_geometry_is_the_general_one<T: Real, const N: usize>(text: &str) {
        let raw = Scene::parse("axes.toml", text).expect("toml");
        let scene = Scene::validate("axes.toml", text, raw).expect("valid scene");
        let fast = Consts::<T, N>::new(&scene);
        assert!(fast.axes.is_some(), "every normal is an axis");
        let general = Consts {
            axes: None,
            ..fast.clone()
        };
        let sampler = crate::sampler::Sampler::new(&scene);
        let mut x = Inputs::<T>::new();
        let (mut a, mut b) = (Geometry::<T, N>::new(), Geometry::<T, N>::new());
        let mut approaching = 0;
        for block in 0..50 {
            sampler.fill(block * BLOCK as u64, &mut x);
            geometry::<T, N, true>(&fast, &x, &mut a, true);
            geometry::<T, N, true>(&general, &x, &mut b, true);
            let bits = |g: &Geometry<T, N>| {
                let mut v: Vec<f64> = g.vn.iter().flatten().map(|t| t.to_f64()).collect();
                v.extend(g.rho.iter().flatten().flatten().map(|t| t.to_f64()));
                v.extend(
                    (0..N)
                        .flat_map(|i| (i..N).flat_map(move |j| g.g[i][j]))
                        .map(|t| t.to_f64()),
                );
                v.extend(g.t_before.iter().map(|t| t.to_f64()));
                v.extend(g.status.iter().map(|&s| s as f64));
                v.into_iter().map(f64::to_bits).collect::<Vec<u64>>()
            };
            assert_eq!(bits(&a), bits(&b), "block {block}");
            approaching += a
                .status
                .iter()
                .filter(|&&s| s & ((1 << N) - 1) != 0)
                .count();
        }
        assert!(
            approaching > 1000,
            "{approaching} lanes with an approaching contact"
        );
    }

    #[test]
    fn axis_geometry_is_the_general_one_on_axis_planes() {
        let corner = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/corner3.toml"),
        )
        .expect("shipped scene");
        let facing_back = corner
            .replace("normal = [1.0, 0.0, 0.0]", "normal = [-1.0, 0.0, 0.0]")
            .replace("normal = [0.0, 1.0, 0.0]", "normal = [0.0, -1.0, 0.0]")
            .replace("mean = [-1.0, -1.0, -1.0]", "mean = [1.0, 1.0, -1.0]");
        assert_ne!(facing_back, corner);
        let floor = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/floor.toml"),
        )
        .expect("shipped scene");
        for text in [&corner, &facing_back] {
            axis_geometry_is_the_general_one::<f32, 3>(text);
            axis_geometry_is_the_general_one::<f64, 3>(text);
        }
        axis_geometry_is_the_general_one::<f32, 1>(&floor);
        axis_geometry_is_the_general_one::<f64, 1>(&floor);
    }

    #[test]
    fn lcp_block_is_lcp_lane_f64_three_contacts() {
        block_is_lane_by_lane::<f64, 3>("corner3.toml");
    }

    #[test]
    fn lcp_block_is_lcp_lane_f32_three_contacts() {
        block_is_lane_by_lane::<f32, 3>("corner3.toml");
    }

    #[test]
    fn lcp_block_is_lcp_lane_two_contacts() {
        block_is_lane_by_lane::<f64, 2>("corner2_paper.toml");
        block_is_lane_by_lane::<f32, 2>("corner2_paper.toml");
    }
}
