//! Each touching plane's contact frame per lane: directions, levers and
//! the Delassus blocks in those coordinates (friction.md §2).

// Lane code indexes SoA arrays by lane and contact on purpose: the index
// form is what the loop vectoriser sees through.
#![allow(clippy::needless_range_loop, clippy::manual_memcpy)]

use crate::kernel::friction::state::Frame;
use crate::kernel::geometry::dot3;
use crate::kernel::{Consts, Geometry, Status};
use crate::lanes::dispatch::BLOCK;
use crate::lanes::Real;
use crate::sampler::Inputs;

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
    scales(c, x, &mut fr.vscale, &mut geo.t_before, &mut geo.status);
    let f32_lanes = T::EPSILON.to_f64() > 1e-10;
    for i in 0..N {
        let plane = Plane {
            dirs: [c.normal[i], c.fr.tangent[i][0], c.fr.tangent[i][1]],
            mu: c.fr.mu[i],
            approaching: Status::approaching(i),
            graze: if f32_lanes { c.graze } else { T::ZERO },
        };
        contact_frame(
            c,
            &plane,
            x,
            &fr.vscale,
            &mut fr.lever[i],
            &mut fr.c0[i],
            &mut fr.w[i],
            &mut fr.b3[i],
            &mut geo.vn[i],
            &mut geo.status,
        );
        fr.b3_all[i] = fr.b3[i].iter().all(|&b| b);
    }
}

/// Every lane's velocity scale `|v| + L|ω|` and kinetic energy before the
/// impact; the status starts empty.
#[inline(always)]
fn scales<T: Real, const N: usize>(
    c: &Consts<T, N>,
    x: &Inputs<T>,
    vscale: &mut [T; BLOCK],
    t_before: &mut [T; BLOCK],
    status: &mut [Status; BLOCK],
) {
    for s in 0..BLOCK {
        let v = [x.v[0][s], x.v[1][s], x.v[2][s]];
        let w = [x.w[0][s], x.w[1][s], x.w[2][s]];
        vscale[s] = c.length.mul_add(dot3(w, w).sqrt(), dot3(v, v).sqrt());
        t_before[s] = T::HALF
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
        status[s] = Status::NONE;
    }
}

/// One touching plane: its directions (n, t₁, t₂), μ, its approaching
/// bit, and the relative normal speed below which f32 lanes graze (0 in
/// f64).
struct Plane<T> {
    dirs: [[T; 3]; 3],
    mu: T,
    approaching: Status,
    graze: T,
}

/// One plane's contact frame in every lane: levers, pre-impact contact
/// velocities, Delassus blocks, B3, the normal velocity and the status
/// bits. Each array it writes is its own argument, so that, inlined, the
/// loop vectoriser knows none overlaps another.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn contact_frame<T: Real, const N: usize>(
    c: &Consts<T, N>,
    plane: &Plane<T>,
    x: &Inputs<T>,
    vscale: &[T; BLOCK],
    lever_out: &mut [[[T; BLOCK]; 3]; 3],
    c0: &mut [[T; BLOCK]; 3],
    w_out: &mut [[T; BLOCK]; 6],
    b3_out: &mut [bool; BLOCK],
    vn_out: &mut [T; BLOCK],
    status: &mut [Status; BLOCK],
) {
    let dirs = plane.dirs;
    for s in 0..BLOCK {
        let a: [T; 9] = std::array::from_fn(|k| x.a[k][s]);
        let v = [x.v[0][s], x.v[1][s], x.v[2][s]];
        let w = [x.w[0][s], x.w[1][s], x.w[2][s]];
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
                lever_out[d][k][s] = lever[d][k];
            }
            c0[d][s] = dot3(lever[d], w) + dot3(dirs[d], v);
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
            w_out[m][s] = blocks[m];
        }
        b3_out[s] = b3(blocks, plane.mu, c.fr.b3_bound);
        let vn = dot3(lever[0], w) + dot3(dirs[0], v);
        vn_out[s] = vn;
        status[s] |= Status::when(vn < T::ZERO, plane.approaching)
            | Status::when(vn.abs() < plane.graze * vscale[s], Status::NEEDS_REFERENCE);
    }
}

/// friction.md's certificate B3 from the Delassus block in the contact
/// frame (nn, nt₁, nt₂, t₁t₁, t₁t₂, t₂t₂) and μ: with
/// `S = W_tt − w_t w_tᵀ/W_nn`,
/// `(μ/W_nn)(|w_t| + sqrt(λ_max(S) · w_tᵀ S⁻¹ w_t)) < bound`.
#[inline(always)]
fn b3<T: Real>(w: [T; 6], mu: T, bound: T) -> bool {
    let [wnn, w1, w2, p, q, r] = w;
    let inv = T::ONE / wnn;
    let s00 = (-w1 * w1).mul_add(inv, p);
    let s01 = (-w1 * w2).mul_add(inv, q);
    let s11 = (-w2 * w2).mul_add(inv, r);
    let det = s00.mul_add(s11, -(s01 * s01));
    let half = T::HALF * (s00 - s11);
    let lambda_max = T::HALF * (s00 + s11) + half.mul_add(half, s01 * s01).sqrt();
    let quad = (s11 * w1).mul_add(
        w1,
        (s00 * w2).mul_add(w2, -(T::ONE + T::ONE) * s01 * w1 * w2),
    );
    let q_inv = (quad / det).max(T::ZERO);
    let wt = w1.mul_add(w1, w2 * w2).sqrt();
    (det > T::ZERO) & (s00 > T::ZERO) & ((mu * inv) * ((lambda_max * q_inv).sqrt() + wt) < bound)
}
