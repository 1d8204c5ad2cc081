//! The constants of a block of torque-free motions, in f64 lanes: what
//! [`crate::physics::TorqueFree::new`] computes per motion, for many at
//! once and with no data-dependent loop. Where the reference iterates
//! until converged, the lanes take a fixed count that is enough for f64
//! and hold a lane's values once it has converged where the reference
//! stops (the Landen levels, the theta terms), so that the lanes' motion
//! is the reference's to rounding:
//!
//! - K from the Landen sequence's arithmetic–geometric mean the Jacobi
//!   functions need anyway (K = π/2M), and K′ from a second AGM of
//!   `AGM_STEPS` steps (quadratic convergence);
//! - the complete integral of the third kind Π(−ν | m) by Bulirsch's
//!   `cel` (R. Bulirsch, Numer. Math. 13, 1969), held per lane once
//!   converged (at most [`CEL_STEPS`] steps);
//! - the incomplete integrals of the first kind (the theta series' β, the
//!   initial phase) by Carlson's duplication for R_F, `RF_STEPS`
//!   duplications;
//! - the theta series' coefficients by one `exp` each.
//!
//! A lane whose motion is not closed-form (a steady spin, a motion within
//! [`SEPARATRIX`] of the separatrix, an elliptic parameter below
//! [`M_MIN`]) is marked so and left to the reference. The counts are
//! proved by `tests/it/flight_lanes.rs` against the reference over the
//! whole range of the parameter.

// Lane code indexes SoA arrays by lane on purpose: the index form is what
// the loop vectoriser sees through.
#![allow(clippy::needless_range_loop)]

use glam::DVec3;

use crate::lanes::dispatch::{multiversioned, BLOCK};
use crate::lanes::{select, sin_cos, Real};
use crate::physics::{carlson_rf_series, SEPARATRIX, THETA_TERMS};

use super::special::{agm_step, duplicate, exp, AGM_STEPS, RF_STEPS};

/// Most Landen levels of a [`crate::physics::Jacobi`].
pub(crate) const LEVELS: usize = 16;

/// Most steps of Bulirsch's `cel` (quadratic; at 1 − m ≥ 1e-6 it stops
/// within six).
pub const CEL_STEPS: usize = 10;
/// The smallest elliptic parameter the lanes take (m → 0 is a steady spin
/// about the largest or smallest axis, where K′ → ∞).
pub const M_MIN: f64 = 1e-14;

/// One relabelling of the body's axes (module notes of
/// [`crate::physics::torque_free`]), with what follows from it alone.
#[derive(Debug, Clone, Copy)]
struct Axes {
    /// Body → relabelled body, row-major.
    perm: [[f64; 3]; 3],
    inertia: [f64; 3],
    /// The sign of I₃ − I₁.
    s_sign: f64,
    nu: f64,
    /// sin ψ and cos²ψ with tan ψ = 1/√ν.
    sin_psi: f64,
    cos2_psi: f64,
}

/// What every motion of a body shares: its two relabellings.
#[derive(Debug, Clone, Copy)]
pub struct SetupConsts {
    j: [f64; 3],
    /// The smallest, middle and largest moment's axes.
    order: [usize; 3],
    /// For M² ≥ 2E·I₂ (about axis 3 the largest moment) and the other.
    about_largest: Axes,
    about_smallest: Axes,
}

impl SetupConsts {
    /// For principal moments `j`, all distinct.
    pub fn new(j: DVec3) -> Self {
        let j = j.to_array();
        let mut order = [0usize, 1, 2];
        order.sort_by(|&a, &b| j[a].total_cmp(&j[b]));
        let [s, mid, l] = order;
        let axes = |axes: [usize; 3]| {
            let mut rows = [DVec3::ZERO; 3];
            for (r, &a) in rows.iter_mut().zip(&axes) {
                *r = DVec3::from_array(std::array::from_fn(|k| (k == a) as u8 as f64));
            }
            if rows[0].cross(rows[1]).dot(rows[2]) < 0.0 {
                rows[2] = -rows[2];
            }
            let i = [j[axes[0]], j[axes[1]], j[axes[2]]];
            let nu = i[2] * (i[1] - i[0]) / (i[0] * (i[2] - i[1]));
            Axes {
                perm: rows.map(|r| r.to_array()),
                inertia: i,
                s_sign: if i[2] > i[0] { 1.0 } else { -1.0 },
                nu,
                sin_psi: 1.0 / (1.0 + nu).sqrt(),
                cos2_psi: nu / (1.0 + nu),
            }
        };
        Self {
            j,
            order,
            about_largest: axes([s, mid, l]),
            about_smallest: axes([l, mid, s]),
        }
    }
}

/// The starts of a block of motions: attitude (body → world, row-major)
/// and body angular velocity per lane.
#[repr(C, align(64))]
pub struct SetupIn {
    pub rotation: [[f64; BLOCK]; 9],
    pub omega: [[f64; BLOCK]; 3],
}

/// The constants of a block of motions, per lane (the fields of
/// [`super::PoseLanes`], in f64).
#[repr(C, align(64))]
pub struct Setup {
    /// Body → relabelled body, and R₀ B(l₀)ᵀ: `m[col][row]`.
    pub perm: [[[f64; BLOCK]; 3]; 3],
    pub base: [[[f64; BLOCK]; 3]; 3],
    pub inertia: [[f64; BLOCK]; 3],
    pub amp: [[f64; BLOCK]; 3],
    pub sign2: [f64; BLOCK],
    pub sign3: [f64; BLOCK],
    pub lambda: [f64; BLOCK],
    pub tau0: [f64; BLOCK],
    pub two_k: [f64; BLOCK],
    pub rate: [f64; BLOCK],
    pub amplitude: [f64; BLOCK],
    pub periodic0: [f64; BLOCK],
    pub agm: [f64; BLOCK],
    pub levels: [f64; BLOCK],
    pub landen_a: [[f64; BLOCK]; LEVELS],
    pub landen_b: [[f64; BLOCK]; LEVELS],
    pub scale: [f64; BLOCK],
    pub theta_re: [[f64; BLOCK]; THETA_TERMS],
    pub theta_im: [[f64; BLOCK]; THETA_TERMS],
    /// Closed-form (else the reference's).
    pub closed: [bool; BLOCK],
}

/// The set-up's scratch space, per lane (every lane it reads in
/// `0..n` is written first).
#[repr(C, align(64))]
pub struct SetupWork {
    mm: [f64; BLOCK],
    nu: [f64; BLOCK],
    sin_psi: [f64; BLOCK],
    cos2_psi: [f64; BLOCK],
    big_m: [f64; BLOCK],
    lambda: [f64; BLOCK],
    i13: [f64; BLOCK],
    f_x: [f64; BLOCK],
    f_y: [f64; BLOCK],
    s_r: [f64; BLOCK],
    turns: [f64; BLOCK],
    a: [f64; BLOCK],
    emc: [f64; BLOCK],
    cc: [f64; BLOCK],
    levels: [f64; BLOCK],
    qc: [f64; BLOCK],
    e: [f64; BLOCK],
    em: [f64; BLOCK],
    p: [f64; BLOCK],
    ca: [f64; BLOCK],
    cb: [f64; BLOCK],
    fz: [f64; BLOCK],
    gx: [f64; BLOCK],
    gy: [f64; BLOCK],
    gz: [f64; BLOCK],
    ka: [f64; BLOCK],
    kb: [f64; BLOCK],
    r: [f64; BLOCK],
    gamma: [f64; BLOCK],
    kp: [f64; BLOCK],
    f_r: [f64; BLOCK],
    on: [bool; BLOCK],
    done: [bool; BLOCK],
    live: [bool; BLOCK],
}

impl SetupWork {
    pub fn new() -> Box<Self> {
        Box::new(Self {
            mm: [0.0; BLOCK],
            nu: [0.0; BLOCK],
            sin_psi: [0.0; BLOCK],
            cos2_psi: [0.0; BLOCK],
            big_m: [0.0; BLOCK],
            lambda: [0.0; BLOCK],
            i13: [0.0; BLOCK],
            f_x: [0.0; BLOCK],
            f_y: [0.0; BLOCK],
            s_r: [0.0; BLOCK],
            turns: [0.0; BLOCK],
            a: [0.0; BLOCK],
            emc: [0.0; BLOCK],
            cc: [0.0; BLOCK],
            levels: [0.0; BLOCK],
            qc: [0.0; BLOCK],
            e: [0.0; BLOCK],
            em: [0.0; BLOCK],
            p: [0.0; BLOCK],
            ca: [0.0; BLOCK],
            cb: [0.0; BLOCK],
            fz: [0.0; BLOCK],
            gx: [0.0; BLOCK],
            gy: [0.0; BLOCK],
            gz: [0.0; BLOCK],
            ka: [0.0; BLOCK],
            kb: [0.0; BLOCK],
            r: [0.0; BLOCK],
            gamma: [0.0; BLOCK],
            kp: [0.0; BLOCK],
            f_r: [0.0; BLOCK],
            on: [false; BLOCK],
            done: [false; BLOCK],
            live: [false; BLOCK],
        })
    }
}

impl SetupIn {
    pub fn new() -> Box<Self> {
        Box::new(Self {
            rotation: [[0.0; BLOCK]; 9],
            omega: [[0.0; BLOCK]; 3],
        })
    }
}

impl Setup {
    pub fn new() -> Box<Self> {
        let z = [0.0; BLOCK];
        Box::new(Self {
            perm: [[z; 3]; 3],
            base: [[z; 3]; 3],
            inertia: [z; 3],
            amp: [z; 3],
            sign2: z,
            sign3: z,
            lambda: z,
            tau0: z,
            two_k: z,
            rate: z,
            amplitude: z,
            periodic0: z,
            agm: z,
            levels: z,
            landen_a: [z; LEVELS],
            landen_b: [z; LEVELS],
            scale: z,
            theta_re: [z; THETA_TERMS],
            theta_im: [z; THETA_TERMS],
            closed: [false; BLOCK],
        })
    }
}

multiversioned! {
    /// The constants of the motions in lanes `0..n` of `x`, into `out`. In
    /// passes over the lanes, each loop the vectoriser takes: the
    /// invariants and initial phase per lane; the Landen levels, `cel`'s
    /// steps and the duplications one step at a time over every lane; the
    /// theta series and the rest.
    pub fn setup(c: &SetupConsts, x: &SetupIn, n: usize, k: &mut SetupWork, out: &mut Setup) {
        crate::lanes::dispatch::align_frame();
        let n = n.min(BLOCK);
        let [o_s, o_mid, o_l] = c.order;
        let (ja, jb) = (&c.about_largest, &c.about_smallest);
        let SetupWork {
            mm, nu, sin_psi, cos2_psi, big_m, lambda, i13, f_x, f_y, s_r, turns, a, emc, cc,
            levels, qc, e, em, p, ca, cb, fz, gx, gy, gz, ka, kb, r, gamma, kp, f_r, on, done,
            live,
        } = k;
        for s in 0..n {
            let w = [x.omega[0][s], x.omega[1][s], x.omega[2][s]];
            let j = c.j;
            let dm = j[o_s] * (j[o_s] - j[o_mid]) * w[o_s] * w[o_s]
                + j[o_l] * (j[o_l] - j[o_mid]) * w[o_l] * w[o_l];
            let up = dm >= 0.0;
            let pick = |a: f64, b: f64| select(up, a, b);
            let perm: [[f64; 3]; 3] = std::array::from_fn(|r| {
                std::array::from_fn(|k| pick(ja.perm[r][k], jb.perm[r][k]))
            });
            let i: [f64; 3] = std::array::from_fn(|k| pick(ja.inertia[k], jb.inertia[k]));
            let s_sign = pick(ja.s_sign, jb.s_sign);
            nu[s] = pick(ja.nu, jb.nu);
            sin_psi[s] = pick(ja.sin_psi, jb.sin_psi);
            cos2_psi[s] = pick(ja.cos2_psi, jb.cos2_psi);
            let wp: [f64; 3] = std::array::from_fn(|r| {
                perm[r][0] * w[0] + perm[r][1] * w[1] + perm[r][2] * w[2]
            });
            let (i1, i2, i3) = (i[0], i[1], i[2]);
            let (w1, w2, w3) = (wp[0], wp[1], wp[2]);
            let li = [i1 * w1, i2 * w2, i3 * w3];
            big_m[s] = (li[0] * li[0] + li[1] * li[1] + li[2] * li[2]).sqrt();
            let d3 = i1 * (i3 - i1) * w1 * w1 + i2 * (i3 - i2) * w2 * w2;
            let d1 = i2 * (i2 - i1) * w2 * w2 + i3 * (i3 - i1) * w3 * w3;
            let nonzero = (w1 != 0.0) as u32 + (w2 != 0.0) as u32 + (w3 != 0.0) as u32;
            let steady = big_m[s] == 0.0 || d3 == 0.0 || nonzero <= 1;
            let sign3 = select(w3 >= 0.0, 1.0, -1.0);
            let amp = [
                (d3 / (i1 * (i3 - i1))).sqrt(),
                (d3 / (i2 * (i3 - i2))).sqrt(),
                (d1 / (i3 * (i3 - i1))).sqrt(),
            ];
            lambda[s] = ((i3 - i2) * d1 / (i1 * i2 * i3)).sqrt();
            let m = ((i2 - i1) * d3 / ((i3 - i2) * d1)).clamp(0.0, 1.0 - f64::EPSILON);
            let closed = !steady && 1.0 - m >= SEPARATRIX && m >= M_MIN;
            // A lane that is not closed-form computes on harmless values.
            let m = select(closed, m, 0.5);
            mm[s] = m;
            out.closed[s] = closed;
            i13[s] = (i3 - i1) / (i1 * i3);
            out.rate[s] = big_m[s] / i3;
            // The initial phase: am τ₀ = atan2(sn τ₀, cn τ₀), in [−π/2, π/2]
            // plus a multiple of π.
            let cn0 = w1 / amp[0];
            let sn0 = sign3 * s_sign * w2 / amp[1];
            let norm = (cn0 * cn0 + sn0 * sn0).sqrt();
            let (cn0, sn0) = (cn0 / norm, sn0 / norm);
            let right = cn0 >= 0.0;
            turns[s] = select(right, 0.0, select(sn0 >= 0.0, 1.0, -1.0));
            s_r[s] = select(right, sn0, -sn0);
            let c_r = select(right, cn0, -cn0);
            f_x[s] = c_r * c_r;
            f_y[s] = (1.0 - m * s_r[s] * s_r[s]).max(0.0);
            // base = R₀ permᵀ B(l₀)ᵀ, B(l) = Rx(θ) Rz(ψ).
            let bm = big_m[s];
            let l0 = [li[0] / bm, li[1] / bm, li[2] / bm];
            let st = (l0[0] * l0[0] + l0[1] * l0[1]).sqrt();
            let tilted = st > 0.0;
            let safe = select(tilted, st, 1.0);
            let spsi = select(tilted, l0[0] / safe, 0.0);
            let cpsi = select(tilted, l0[1] / safe, 1.0);
            let ct = l0[2];
            // B = Rx Rz, row-major: Rz = [[c, −s, 0], [s, c, 0], [0, 0, 1]],
            // Rx = [[1, 0, 0], [0, ct, −st], [0, st, ct]].
            let b = [
                [cpsi, -spsi, 0.0],
                [ct * spsi, ct * cpsi, -st],
                [st * spsi, st * cpsi, ct],
            ];
            // R₀ permᵀ, row-major (R₀ row-major in x).
            let r0: [[f64; 3]; 3] = std::array::from_fn(|row| {
                std::array::from_fn(|col| {
                    x.rotation[3 * row][s] * perm[col][0]
                        + x.rotation[3 * row + 1][s] * perm[col][1]
                        + x.rotation[3 * row + 2][s] * perm[col][2]
                })
            });
            for row in 0..3 {
                for col in 0..3 {
                    // (R₀ permᵀ Bᵀ)[row][col] = Σ_k r0[row][k] B[col][k].
                    out.base[col][row][s] =
                        r0[row][0] * b[col][0] + r0[row][1] * b[col][1] + r0[row][2] * b[col][2];
                    out.perm[col][row][s] = perm[row][col];
                }
                out.inertia[row][s] = i[row];
                out.amp[row][s] = amp[row];
            }
            out.sign2[s] = sign3 * s_sign;
            out.sign3[s] = sign3;
            out.lambda[s] = lambda[s];
        }
        // The descending Landen sequence (Jacobi::new), held where the
        // reference stops; its mean gives K = π/2M.
        for s in 0..n {
            (a[s], emc[s], cc[s]) = (1.0, 1.0 - mm[s], 1.0);
            (on[s], levels[s]) = (true, 0.0);
        }
        for l in 0..LEVELS {
            let level = (l + 1) as f64;
            for s in 0..n {
                out.landen_a[l][s] = a[s];
                let root = emc[s].sqrt();
                out.landen_b[l][s] = root;
                let c1 = 0.5 * (a[s] + root);
                levels[s] = select(on[s], level, levels[s]);
                cc[s] = select(on[s], c1, cc[s]);
                let stop = (a[s] - root).abs() <= 1e-8 * a[s];
                let next = on[s] && !stop;
                emc[s] = select(next, root * a[s], emc[s]);
                a[s] = select(next, c1, a[s]);
                on[s] = next;
            }
        }
        // Π(−ν | m) by Bulirsch's cel(√(1 − m), 1 + ν, 1, 1), held once
        // converged (relative 1e-8 of the mean: its error is the square).
        const CA: f64 = 1e-8;
        for s in 0..n {
            done[s] = false;
            qc[s] = (1.0 - mm[s]).sqrt();
            e[s] = qc[s];
            em[s] = 1.0;
            p[s] = (1.0 + nu[s]).sqrt();
            ca[s] = 1.0;
            cb[s] = 1.0 / p[s];
        }
        for _ in 0..CEL_STEPS {
            for s in 0..n {
                let f = ca[s];
                let a1 = ca[s] + cb[s] / p[s];
                let g = e[s] / p[s];
                let b1 = 2.0 * (cb[s] + f * g);
                let p1 = g + p[s];
                let g1 = em[s];
                let em1 = qc[s] + em[s];
                let stop = (g1 - qc[s]).abs() <= g1 * CA;
                let qc1 = 2.0 * e[s].sqrt();
                let e1 = qc1 * em1;
                let go = !done[s];
                ca[s] = select(go, a1, ca[s]);
                cb[s] = select(go, b1, cb[s]);
                p[s] = select(go, p1, p[s]);
                em[s] = select(go, em1, em[s]);
                qc[s] = select(go && !stop, qc1, qc[s]);
                e[s] = select(go && !stop, e1, e[s]);
                done[s] |= stop;
            }
        }
        // R_F for the initial phase, R_F(cos²ψ, 1 − (1 − m) sin²ψ, 1) for
        // γ, and the AGM of 1 and √m for K′, a step at a time.
        for s in 0..n {
            (fz[s], gz[s], ka[s]) = (1.0, 1.0, 1.0);
            gx[s] = cos2_psi[s];
            gy[s] = 1.0 - (1.0 - mm[s]) * sin_psi[s] * sin_psi[s];
            kb[s] = mm[s].sqrt();
        }
        for _ in 0..RF_STEPS.max(AGM_STEPS) {
            for s in 0..n {
                [f_x[s], f_y[s], fz[s]] = duplicate([f_x[s], f_y[s], fz[s]]);
                [gx[s], gy[s], gz[s]] = duplicate([gx[s], gy[s], gz[s]]);
                (ka[s], kb[s]) = agm_step(ka[s], kb[s]);
            }
        }
        for s in 0..n {
            let k_complete = std::f64::consts::FRAC_PI_2 / cc[s];
            let pi_complete =
                std::f64::consts::FRAC_PI_2 * (cb[s] + ca[s] * em[s]) / (em[s] * (em[s] + p[s]));
            f_r[s] = s_r[s] * carlson_rf_series(f_x[s], f_y[s], fz[s]);
            out.tau0[s] = 2.0 * turns[s] * k_complete + f_r[s];
            kp[s] = std::f64::consts::FRAC_PI_2 / (0.5 * (ka[s] + kb[s]));
            gamma[s] = sin_psi[s] * carlson_rf_series(gx[s], gy[s], gz[s]);
            r[s] = std::f64::consts::PI / k_complete;
            out.scale[s] = 0.5 * r[s];
            out.two_k[s] = 2.0 * k_complete;
            out.agm[s] = cc[s];
            out.levels[s] = levels[s];
            let m = mm[s];
            let ps = (nu[s] / ((m + nu[s]) * (1.0 + nu[s]))).sqrt();
            let swing = big_m[s] * i13[s] / lambda[s];
            out.rate[s] += swing * (pi_complete / k_complete) * lambda[s];
            out.amplitude[s] = swing * ps;
        }
        // The theta series' coefficients (ThetaPhase::new), held past the
        // reference's last term.
        for s in 0..n {
            live[s] = true;
        }
        for t in 0..THETA_TERMS {
            let nf = (t + 1) as f64;
            let sign = if t % 2 == 1 { 1.0 } else { -1.0 };
            for s in 0..n {
                let below = select(t == 0, 0.0, kp[s] * nf * (nf - 1.0));
                let up = exp(-r[s] * (below + nf * gamma[s]));
                let down = exp(-r[s] * (kp[s] * nf * (nf + 1.0) - nf * gamma[s]));
                out.theta_re[t][s] = select(live[s], sign * (up + down), 0.0);
                out.theta_im[t][s] = select(live[s], sign * (up - down), 0.0);
                live[s] = live[s] && up >= 1e-18;
            }
        }
        // The periodic part at f_r (ThetaPhase::periodic).
        for s in 0..n {
            let (s1, c1) = sin_cos(2.0 * out.scale[s] * f_r[s]);
            let (mut re, mut im) = (1.0f64, 0.0f64);
            let (mut cp, mut sp, mut cn_, mut sn_) = (1.0f64, 0.0f64, c1, s1);
            for t in 0..THETA_TERMS {
                re += out.theta_re[t][s] * cn_;
                im -= out.theta_im[t][s] * sn_;
                let (c2, s2) = (2.0 * c1 * cn_ - cp, 2.0 * c1 * sn_ - sp);
                (cp, sp, cn_, sn_) = (cn_, sn_, c2, s2);
            }
            out.periodic0[s] = Real::atan2(im, re);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::TorqueFree;
    use crate::sampler::rng::mix64;
    use glam::DMat3;

    fn uniform(state: &mut u64) -> f64 {
        *state += 1;
        (mix64(*state) >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Every constant of the lanes' set-up equals the reference's
    /// (`TorqueFree::new`) to 1e-13, lane by lane, over random spins of
    /// four bodies, spins near each principal axis (elliptic parameter
    /// down to 1e-14) and near the separatrix (1 − m down to 1e-6); and the
    /// lanes take exactly the reference's closed-form motions.
    #[test]
    fn lane_setup_is_the_reference() {
        let mut st = 11u64;
        let mut closed = 0;
        let mut near = [0usize; 2];
        for semi in [
            [0.5, 0.3, 0.2],
            [0.03, 0.02, 0.01],
            [0.2, 0.5, 0.3],
            [0.4, 0.39, 0.1],
        ] {
            let body = crate::physics::Ellipsoid::new(semi, 2.0).unwrap();
            let c = SetupConsts::new(body.inertia());
            for _ in 0..40 {
                let mut x = SetupIn::new();
                let mut want = Vec::new();
                for s in 0..BLOCK {
                    let q = glam::DQuat::from_xyzw(
                        uniform(&mut st) - 0.5,
                        uniform(&mut st) - 0.5,
                        uniform(&mut st) - 0.5,
                        uniform(&mut st) - 0.5,
                    )
                    .normalize();
                    let r = DMat3::from_quat(q);
                    let mut w = DVec3::new(
                        uniform(&mut st) - 0.5,
                        uniform(&mut st) - 0.5,
                        uniform(&mut st) - 0.5,
                    ) * 20.0;
                    match s % 4 {
                        // Near a principal axis: the others' components small.
                        1 => {
                            let k = s / 4 % 3;
                            let eps = 10f64.powf(-7.0 * uniform(&mut st));
                            w = DVec3::from_array(std::array::from_fn(|i| {
                                if i == k {
                                    w[i]
                                } else {
                                    w[i] * eps
                                }
                            }));
                        }
                        // Near the separatrix: 2E·I₂ = M² nearly.
                        2 => {
                            let j = body.inertia();
                            let (i1, i2, i3) = (j.x, j.y, j.z);
                            // ω₁²·i1(i2 − i1) = ω₃²·i3(i3 − i2)·(1 + δ).
                            let delta = 10f64.powf(-1.0 - 6.0 * uniform(&mut st));
                            let w3 = w.z;
                            let w1 = (w3 * w3 * i3 * (i3 - i2) * (1.0 + delta) / (i1 * (i2 - i1)))
                                .abs()
                                .sqrt();
                            w = DVec3::new(w1, w.y, w3);
                        }
                        _ => {}
                    }
                    let rows = r.transpose().to_cols_array();
                    for k in 0..9 {
                        x.rotation[k][s] = rows[k];
                    }
                    for k in 0..3 {
                        x.omega[k][s] = w[k];
                    }
                    want.push(TorqueFree::new(body.inertia(), r, w));
                }
                let mut got = Setup::new();
                setup(&c, &x, BLOCK, &mut SetupWork::new(), &mut got);
                for (s, tf) in want.iter().enumerate() {
                    let reference_closed = tf.steady.is_none() && tf.rk4_step.is_none();
                    let m = 1.0 - tf.jacobi.mc;
                    let lanes_take = reference_closed && m >= M_MIN;
                    assert_eq!(got.closed[s], lanes_take, "{semi:?} lane {s}: m = {m}");
                    if !lanes_take {
                        continue;
                    }
                    closed += 1;
                    near[0] += (m < 1e-6) as usize;
                    near[1] += (1.0 - m < 1e-4) as usize;
                    let close = |what: &str, a: f64, b: f64, scale: f64| {
                        assert!(
                            (a - b).abs() <= 1e-13 * scale.max(b.abs()),
                            "{semi:?} lane {s} (m = {m}): {what} {a} vs {b}"
                        );
                    };
                    let (perm, base) = (tf.perm.to_cols_array_2d(), tf.base.to_cols_array_2d());
                    for col in 0..3 {
                        for row in 0..3 {
                            close("perm", got.perm[col][row][s], perm[col][row], 1.0);
                            close("base", got.base[col][row][s], base[col][row], 1.0);
                        }
                        close("inertia", got.inertia[col][s], tf.inertia[col], 0.0);
                        close("amp", got.amp[col][s], tf.amp[col], tf.amp.max_element());
                    }
                    close("sign2", got.sign2[s], tf.sign2, 1.0);
                    close("sign3", got.sign3[s], tf.sign3, 1.0);
                    close("lambda", got.lambda[s], tf.lambda, 0.0);
                    close("2K", got.two_k[s], tf.two_k, 0.0);
                    // The initial phase is as sensitive to the rounding of ω
                    // as 1/√(1 − m) near the separatrix (the reference as
                    // much as the lanes: d_r = 1 − m sn² ≥ 1 − m cancels).
                    let phase = 1.0 / tf.jacobi.mc.sqrt();
                    close("tau0", got.tau0[s], tf.tau0, tf.two_k * phase);
                    close(
                        "rate",
                        got.rate[s],
                        tf.rate,
                        tf.rate.abs() + tf.amplitude.abs(),
                    );
                    close("amplitude", got.amplitude[s], tf.amplitude, tf.rate.abs());
                    close("periodic0", got.periodic0[s], tf.periodic0, phase);
                    close("agm", got.agm[s], tf.jacobi.agm, 0.0);
                    assert_eq!(got.levels[s], tf.jacobi.levels as f64, "levels, lane {s}");
                    for l in 0..tf.jacobi.levels {
                        close("landen a", got.landen_a[l][s], tf.jacobi.a[l], 0.0);
                        close("landen b", got.landen_b[l][s], tf.jacobi.b[l], 0.0);
                    }
                    close("scale", got.scale[s], tf.phase.scale, 0.0);
                    for n in 0..THETA_TERMS {
                        let on = n < tf.phase.terms;
                        let (re, im) = if on {
                            (tf.phase.re[n], tf.phase.im[n])
                        } else {
                            (0.0, 0.0)
                        };
                        close("theta re", got.theta_re[n][s], re, 1.0);
                        close("theta im", got.theta_im[n][s], im, 1.0);
                    }
                }
            }
        }
        assert!(closed > 20_000, "{closed} closed-form lanes");
        assert!(
            near[0] > 100 && near[1] > 100,
            "near an axis and the separatrix: {near:?}"
        );
    }
}
