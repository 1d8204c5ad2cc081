//! The impulse pass under each law, and the post pass (velocities, normal
//! velocities and energy after the impulses).

// Lane code indexes SoA arrays by lane and contact on purpose: the index
// form is what the loop vectoriser sees through.
#![allow(clippy::needless_range_loop, clippy::manual_memcpy)]

use crate::kernel::geometry::{dot3, g_at};
use crate::kernel::lcp::{lane_g, lcp_block, lcp_lanes};
use crate::kernel::{Consts, Geometry, LawOut, Status};
use crate::lanes::dispatch::BLOCK;
use crate::lanes::{select, Real};
use crate::physics::Law;
use crate::sampler::Inputs;

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
        // Without friction, stronge is newton.
        Law::Newton | Law::Stronge => {
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
                out.status[s] = geo.status[s]
                    | Status::when(!(ok[s] & conditioned[s]), Status::NEEDS_REFERENCE);
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
                out.status[s] =
                    geo.status[s] | Status::when(!(ok1[s] && ok2[s]), Status::NEEDS_REFERENCE);
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
    for s in 0..BLOCK {
        let lam: [T; N] = std::array::from_fn(|i| out.lambda[i][s]);
        let mut dv = [T::ZERO; 3];
        let mut dl = [T::ZERO; 3];
        let mut active = Status::NONE;
        for i in 0..N {
            for k in 0..3 {
                dv[k] = lam[i].mul_add(c.normal[i][k], dv[k]);
                if ROT {
                    dl[k] = lam[i].mul_add(geo.rho[i][k][s], dl[k]);
                }
            }
            active |= Status::when(lam[i] > T::ZERO, Status::active(i));
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
        let (t1, gained, unsure) = energy_after(c, geo.t_before[s], v, w, work, work_abs);
        for k in 0..3 {
            out.v_after[k][s] = v[k];
            out.w_after[k][s] = w[k];
        }
        out.t_after[s] = t1;
        out.status[s] |= active
            | Status::when(gained, Status::ENERGY_GAIN)
            | Status::when(unsure, Status::NEEDS_REFERENCE);
    }
}

/// T⁺ of a lane, whether it gained energy (`energy_gain`), and whether that
/// flag is in doubt, from v⁺, ω⁺, T⁻ and the work `Σ P·(c⁻ + c⁺)` of the
/// impulses (with `work_abs`, the same sum of absolute values). f32: T⁺ =
/// T⁻ + ½·work, exact in exact arithmetic (physics.md, friction.md), so
/// accurate relative to ΔT rather than to T; the flag is in doubt when the
/// threshold lies within the rounding bound of ΔT (a few ε of `work_abs`).
/// f64: T⁺ from v⁺ and ω⁺ directly.
#[inline(always)]
pub(crate) fn energy_after<T: Real, const N: usize>(
    c: &Consts<T, N>,
    t0: T,
    v: [T; 3],
    w: [T; 3],
    work: T,
    work_abs: T,
) -> (T, bool, bool) {
    let f32_lanes = T::EPSILON.to_f64() > 1e-10;
    let gain = T::from_f64(crate::physics::ENERGY_GAIN_RELATIVE);
    let ambiguous = T::from_f64(64.0) * T::EPSILON;
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
    let dt = T::HALF * work;
    let t1 = if f32_lanes { t0 + dt } else { direct };
    let gained = if f32_lanes {
        dt > gain * t0
    } else {
        t1 > t0 + gain * t0
    };
    let unsure = f32_lanes && (dt - gain * t0).abs() <= ambiguous * (work_abs + gain * t0);
    (t1, gained, unsure)
}
