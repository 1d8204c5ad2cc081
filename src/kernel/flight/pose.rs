//! The torque-free attitude in lanes: a block of flights, each with the
//! constants of its closed-form motion ([`crate::physics::TorqueFree`]),
//! evaluated at one time per lane with the reference's formulas and no
//! data-dependent loop: one `sin_cos` for the Jacobi functions and the
//! descending Landen recurrence over the block's most levels (masked per
//! lane), the theta series over its fixed twelve terms (zeros past a
//! lane's own), one `atan2`, one `sin_cos` for the precession and two 3×3
//! products. The constants are the reference's own (its set-up stays
//! scalar here); lanes whose motion is steady or near the separatrix are
//! not closed-form and are left to the reference.

// Lane code indexes SoA arrays by lane on purpose: the index form is what
// the loop vectoriser sees through.
#![allow(clippy::needless_range_loop)]

use glam::{DMat3, DVec3};

use crate::lanes::dispatch::{multiversioned, BLOCK};
use crate::lanes::{select, sin_cos, Real};
use crate::physics::{TorqueFree, THETA_TERMS};

use super::setup::{self, LEVELS};

/// A 3×3 matrix per lane, column-major: `m[col][row][lane]`.
pub type Mat3Lanes<T> = [[[T; BLOCK]; 3]; 3];

/// The constants of a block of closed-form torque-free motions, per lane.
#[repr(C, align(64))]
pub struct PoseLanes<T> {
    /// Body → relabelled body (a signed permutation), and R₀ B(l₀)ᵀ.
    perm: Mat3Lanes<T>,
    base: Mat3Lanes<T>,
    inertia: [[T; BLOCK]; 3],
    amp: [[T; BLOCK]; 3],
    sign2: [T; BLOCK],
    sign3: [T; BLOCK],
    lambda: [T; BLOCK],
    tau0: [T; BLOCK],
    two_k: [T; BLOCK],
    rate: [T; BLOCK],
    amplitude: [T; BLOCK],
    periodic0: [T; BLOCK],
    /// Jacobi: the AGM limit, the levels used (as a number), and per level
    /// the AGM's a and √(emc).
    agm: [T; BLOCK],
    levels: [T; BLOCK],
    landen_a: [[T; BLOCK]; LEVELS],
    landen_b: [[T; BLOCK]; LEVELS],
    /// The most levels of any closed-form lane of the block.
    most_levels: usize,
    /// Theta: π/(2K) and the series' coefficients (zero past a lane's
    /// terms).
    scale: [T; BLOCK],
    theta_re: [[T; BLOCK]; THETA_TERMS],
    theta_im: [[T; BLOCK]; THETA_TERMS],
    /// The lane's motion is closed-form (else the reference's).
    closed: [bool; BLOCK],
}

impl<T: Real> PoseLanes<T> {
    pub fn new() -> Box<Self> {
        let z = [T::ZERO; BLOCK];
        Box::new(Self {
            perm: [[z; 3]; 3],
            base: [[z; 3]; 3],
            inertia: [z; 3],
            amp: [z; 3],
            sign2: z,
            sign3: z,
            lambda: z,
            tau0: z,
            two_k: [T::ONE; BLOCK],
            rate: z,
            amplitude: z,
            periodic0: z,
            agm: [T::ONE; BLOCK],
            levels: z,
            landen_a: [[T::ONE; BLOCK]; LEVELS],
            landen_b: [[T::ONE; BLOCK]; LEVELS],
            most_levels: 0,
            scale: z,
            theta_re: [z; THETA_TERMS],
            theta_im: [z; THETA_TERMS],
            closed: [false; BLOCK],
        })
    }

    /// Lane `s` takes the constants of `m`. False (and the lane is not
    /// closed-form) for a steady rotation or a motion near the separatrix.
    pub fn set(&mut self, s: usize, m: &TorqueFree) -> bool {
        let closed = m.steady.is_none() && m.rk4_step.is_none();
        self.closed[s] = closed;
        if !closed {
            return false;
        }
        let t = T::from_f64;
        let (perm, base) = (m.perm.to_cols_array_2d(), m.base.to_cols_array_2d());
        for c in 0..3 {
            for r in 0..3 {
                self.perm[c][r][s] = t(perm[c][r]);
                self.base[c][r][s] = t(base[c][r]);
            }
            self.inertia[c][s] = t(m.inertia[c]);
            self.amp[c][s] = t(m.amp[c]);
        }
        self.sign2[s] = t(m.sign2);
        self.sign3[s] = t(m.sign3);
        self.lambda[s] = t(m.lambda);
        self.tau0[s] = t(m.tau0);
        self.two_k[s] = t(m.two_k);
        self.rate[s] = t(m.rate);
        self.amplitude[s] = t(m.amplitude);
        self.periodic0[s] = t(m.periodic0);
        let j = &m.jacobi;
        self.agm[s] = t(j.agm);
        self.levels[s] = t(j.levels as f64);
        for i in 0..LEVELS {
            self.landen_a[i][s] = t(j.a[i]);
            self.landen_b[i][s] = t(j.b[i]);
        }
        self.most_levels = self.most_levels.max(j.levels);
        let p = &m.phase;
        self.scale[s] = t(p.scale);
        for n in 0..THETA_TERMS {
            let on = n < p.terms;
            self.theta_re[n][s] = t(if on { p.re[n] } else { 0.0 });
            self.theta_im[n][s] = t(if on { p.im[n] } else { 0.0 });
        }
        true
    }

    /// Lane `s` takes the constants of lane `j` of `c` (computed in lanes
    /// by [`setup::setup`]). False if that motion is not closed-form.
    pub fn set_from(&mut self, s: usize, c: &setup::Setup, j: usize) -> bool {
        let closed = c.closed[j];
        self.closed[s] = closed;
        if !closed {
            return false;
        }
        let t = T::from_f64;
        for col in 0..3 {
            for row in 0..3 {
                self.perm[col][row][s] = t(c.perm[col][row][j]);
                self.base[col][row][s] = t(c.base[col][row][j]);
            }
            self.inertia[col][s] = t(c.inertia[col][j]);
            self.amp[col][s] = t(c.amp[col][j]);
        }
        self.sign2[s] = t(c.sign2[j]);
        self.sign3[s] = t(c.sign3[j]);
        self.lambda[s] = t(c.lambda[j]);
        self.tau0[s] = t(c.tau0[j]);
        self.two_k[s] = t(c.two_k[j]);
        self.rate[s] = t(c.rate[j]);
        self.amplitude[s] = t(c.amplitude[j]);
        self.periodic0[s] = t(c.periodic0[j]);
        self.agm[s] = t(c.agm[j]);
        self.levels[s] = t(c.levels[j]);
        for i in 0..LEVELS {
            self.landen_a[i][s] = t(c.landen_a[i][j]);
            self.landen_b[i][s] = t(c.landen_b[i][j]);
        }
        self.most_levels = self.most_levels.max(c.levels[j] as usize);
        self.scale[s] = t(c.scale[j]);
        for n in 0..THETA_TERMS {
            self.theta_re[n][s] = t(c.theta_re[n][j]);
            self.theta_im[n][s] = t(c.theta_im[n][j]);
        }
        true
    }

    /// Whether lane `s` is closed-form.
    pub fn closed(&self, s: usize) -> bool {
        self.closed[s]
    }
}

/// The attitudes and body angular velocities of a block.
#[repr(C, align(64))]
pub struct Poses<T> {
    pub rotation: Mat3Lanes<T>,
    pub omega: [[T; BLOCK]; 3],
}

impl<T: Real> Poses<T> {
    pub fn new() -> Box<Self> {
        Box::new(Self {
            rotation: [[[T::ZERO; BLOCK]; 3]; 3],
            omega: [[T::ZERO; BLOCK]; 3],
        })
    }

    /// Lane `s` as glam values (for comparisons with the reference).
    pub fn lane(&self, s: usize) -> (DMat3, DVec3) {
        let r = std::array::from_fn(|k| self.rotation[k / 3][k % 3][s].to_f64());
        let w = DVec3::from_array(std::array::from_fn(|k| self.omega[k][s].to_f64()));
        (DMat3::from_cols_array(&r), w)
    }
}

/// `a · b` for 3×3 matrices given by columns.
#[inline(always)]
fn mul<T: Real>(a: &[[T; 3]; 3], b: &[[T; 3]; 3]) -> [[T; 3]; 3] {
    std::array::from_fn(|c| {
        std::array::from_fn(|r| a[0][r] * b[c][0] + a[1][r] * b[c][1] + a[2][r] * b[c][2])
    })
}

multiversioned! {
    /// Every closed-form lane's attitude and body angular velocity at its
    /// time `t[s]` (seconds from the start of its motion). Other lanes'
    /// outputs are unspecified. Three passes over the lanes, each an inner
    /// loop the vectoriser takes: the Jacobi functions' start, the Landen
    /// levels (one pass per level, masked), the rest.
    pub fn poses<T: Real>(c: &PoseLanes<T>, t: &[T; BLOCK], out: &mut Poses<T>) {
        crate::lanes::dispatch::align_frame();
        let two = T::from_f64(2.0);
        let mut tau_r = [T::ZERO; BLOCK];
        let mut turns = [T::ZERO; BLOCK];
        let (mut sn0, mut cn0) = ([T::ZERO; BLOCK], [T::ZERO; BLOCK]);
        let (mut a, mut cc, mut dn) = ([T::ZERO; BLOCK], [T::ZERO; BLOCK], [T::ONE; BLOCK]);
        for s in 0..BLOCK {
            let tau = c.tau0[s] + c.lambda[s] * t[s];
            let k = (tau / c.two_k[s]).round();
            turns[s] = k;
            tau_r[s] = tau - k * c.two_k[s];
            let (sv, cv) = sin_cos(tau_r[s] * c.agm[s]);
            (sn0[s], cn0[s]) = (sv, cv);
            a[s] = cv / select(sv != T::ZERO, sv, T::ONE);
            cc[s] = c.agm[s] * a[s];
        }
        // Jacobi's sn, cn, dn by the descending Landen recurrence.
        for i in (0..c.most_levels).rev() {
            let level = T::from_f64(i as f64);
            for s in 0..BLOCK {
                let on = level < c.levels[s];
                let b = c.landen_a[i][s];
                let a1 = a[s] * cc[s];
                let c1 = cc[s] * dn[s];
                let d1 = (c.landen_b[i][s] + a1) / (b + a1);
                a[s] = select(on, c1 / b, a[s]);
                cc[s] = select(on, c1, cc[s]);
                dn[s] = select(on, d1, dn[s]);
            }
        }
        for s in 0..BLOCK {
            let nonzero = sn0[s] != T::ZERO;
            let r = T::ONE / (cc[s] * cc[s] + T::ONE).sqrt();
            let sn1 = select(sn0[s] >= T::ZERO, r, -r);
            let sn = select(nonzero, sn1, sn0[s]);
            let cn = select(nonzero, cc[s] * sn1, cn0[s]);
            let dn = select(nonzero, dn[s], T::ONE);
            // An odd number of half periods flips sn and cn.
            let half = turns[s] * T::HALF;
            let flip = select(half.round() == half, T::ONE, -T::ONE);
            let wp = [
                c.amp[0][s] * (flip * cn),
                c.sign2[s] * c.amp[1][s] * (flip * sn),
                c.sign3[s] * c.amp[2][s] * dn,
            ];
            // The theta series' argument, arg Θ(u + iβ).
            let (s1, c1) = sin_cos(two * c.scale[s] * tau_r[s]);
            let (mut re, mut im) = (T::ONE, T::ZERO);
            let (mut cp, mut sp) = (T::ONE, T::ZERO);
            let (mut cn_, mut sn_) = (c1, s1);
            for n in 0..THETA_TERMS {
                re += c.theta_re[n][s] * cn_;
                im = im - c.theta_im[n][s] * sn_;
                let (c2, s2) = (two * c1 * cn_ - cp, two * c1 * sn_ - sp);
                (cp, sp, cn_, sn_) = (cn_, sn_, c2, s2);
            }
            let periodic = im.atan2(re);
            let phi = c.rate[s] * t[s] + c.amplitude[s] * (periodic - c.periodic0[s]);
            // R = base · Rz(φ) · B(l), l = J ω / |J ω| in relabelled axes.
            let lp = [c.inertia[0][s] * wp[0], c.inertia[1][s] * wp[1], c.inertia[2][s] * wp[2]];
            let ln = (lp[0] * lp[0] + lp[1] * lp[1] + lp[2] * lp[2]).sqrt();
            let l = [lp[0] / ln, lp[1] / ln, lp[2] / ln];
            let st = (l[0] * l[0] + l[1] * l[1]).sqrt();
            let tilted = st > T::ZERO;
            let safe = select(tilted, st, T::ONE);
            let spsi = select(tilted, l[0] / safe, T::ZERO);
            let cpsi = select(tilted, l[1] / safe, T::ONE);
            let ct = l[2];
            let z = T::ZERO;
            let rz = [[cpsi, spsi, z], [-spsi, cpsi, z], [z, z, T::ONE]];
            let rx = [[T::ONE, z, z], [z, ct, st], [z, -st, ct]];
            let (sphi, cphi) = sin_cos(phi);
            let rphi = [[cphi, sphi, z], [-sphi, cphi, z], [z, z, T::ONE]];
            let base = std::array::from_fn(|col| std::array::from_fn(|row| c.base[col][row][s]));
            let perm: [[T; 3]; 3] =
                std::array::from_fn(|col| std::array::from_fn(|row| c.perm[col][row][s]));
            let rot = mul(&mul(&mul(&base, &rphi), &mul(&rx, &rz)), &perm);
            for col in 0..3 {
                for row in 0..3 {
                    out.rotation[col][row][s] = rot[col][row];
                }
                // ω = permᵀ ω': column `col` of perm dotted with ω'.
                out.omega[col][s] =
                    perm[col][0] * wp[0] + perm[col][1] * wp[1] + perm[col][2] * wp[2];
            }
        }
    }
}
