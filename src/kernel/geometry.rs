//! The geometry pass: support points, lever arms, normal velocities, the
//! Delassus matrix G and its conditioning, and T⁻ (physics.md §2–§3).

// Lane code indexes SoA arrays by lane and contact on purpose: the index
// form is what the loop vectoriser sees through.
#![allow(clippy::needless_range_loop, clippy::manual_memcpy)]

use crate::kernel::{Consts, Geometry, Status};
use crate::lanes::dispatch::BLOCK;
use crate::lanes::Real;
use crate::sampler::Inputs;

/// G_ij of lane s: per lane with rotational coupling, else the constant
/// `nn / m` (ρ = 0), which the geometry pass then never writes.
#[inline(always)]
pub(crate) fn g_at<T: Real, const N: usize, const ROT: bool>(
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
    // ones: the same values, faster (docs/performance.md, "Axis planes").
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
pub(crate) fn normal_velocities<T: Real, const N: usize, const ROT: bool, const AXES: bool>(
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
            Status::when(!det_ok0, Status::NEEDS_REFERENCE)
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
            status |= Status::when(vn < T::ZERO, Status::approaching(i));
            status |= Status::when(
                f32_lanes && vn.abs() < c.graze * vscale,
                Status::NEEDS_REFERENCE,
            );
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
pub(crate) fn lever_arms<T: Real, const N: usize, const AXES: bool, const CONDITIONING: bool>(
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
        out.status[s] = Status::when(
            CONDITIONING && !well_conditioned(&g, c.det_min),
            Status::NEEDS_REFERENCE,
        );
    }
}

/// `a · b` with fused steps.
#[inline(always)]
pub(crate) fn dot3<T: Real>(a: [T; 3], b: [T; 3]) -> T {
    a[2].mul_add(b[2], a[1].mul_add(b[1], a[0] * b[0]))
}

/// Whether det S ≥ `det_min` for S the unit-diagonal scaling of G, i.e.
/// det G ≥ det_min · Π Gᵢᵢ (the diagonal is positive), without a division.
/// False for NaN.
#[inline(always)]
pub(crate) fn well_conditioned<T: Real, const N: usize>(g: &[[T; N]; N], det_min: T) -> bool {
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
pub(crate) fn conditioned_with<T: Real, const N: usize>(
    g: &[[T; N]; N],
    det: T,
    det_min: T,
) -> bool {
    match N {
        1 => true,
        2 => det >= det_min * (g[0][0] * g[1][1]),
        _ => det >= det_min * (g[0][0] * g[1][1] * g[2][2]),
    }
}
