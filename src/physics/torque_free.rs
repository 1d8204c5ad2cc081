//! The exact torque-free motion of a triaxial rigid body (Landau &
//! Lifshitz, Mechanics §37): the body angular velocity in Jacobi elliptic
//! functions, and the attitude in closed form through the incomplete
//! elliptic integral of the third kind: its complete value and the initial
//! phase by Carlson's symmetric forms, once per motion, and its value at
//! any time by Jacobi's theta series ([`ThetaPhase`]).
//!
//! Axes are relabelled (by a proper rotation) so that the body turns about
//! axis 3: I₁ < I₂ < I₃ when M² ≥ 2E·I₂, else I₁ > I₂ > I₃. With the
//! invariants written without cancellation,
//! `D₃ = 2E·I₃ − M² = Σ Iᵢ(I₃ − Iᵢ)ωᵢ²` and
//! `D₁ = M² − 2E·I₁ = Σ Iᵢ(Iᵢ − I₁)ωᵢ²` (every term of one sign):
//!
//! - `ω₁ = A₁ cn τ`, `ω₂ = σs·A₂ sn τ`, `ω₃ = σ·A₃ dn τ`, `τ = τ₀ + λt`,
//!   with `A₁² = D₃/(I₁(I₃−I₁))`, `A₂² = D₃/(I₂(I₃−I₂))`,
//!   `A₃² = D₁/(I₃(I₃−I₁))`, `λ² = (I₃−I₂)D₁/(I₁I₂I₃)`,
//!   `k² = (I₂−I₁)D₃/((I₃−I₂)D₁)`, σ the sign of ω₃ and s that of I₃ − I₁;
//! - the attitude `R(t) = R₀ B(l₀)ᵀ Rz(φ(t) − φ₀) B(l(t))`, where
//!   `l = Jω/M` is the unit angular momentum in the body frame,
//!   `B(l) = Rx(θ) Rz(ψ)` takes l to e₃ (`l = (sinθ sinψ, sinθ cosψ, cosθ)`),
//!   and the precession angle about the fixed momentum is
//!   `φ(t) − φ₀ = M t/I₃ + M(I₃ − I₁)/(I₁I₃λ) · [Π(−ν; am τ) − Π(−ν; am τ₀)]`
//!   with `ν = I₃(I₂ − I₁)/(I₁(I₃ − I₂)) > 0`.
//!
//! Each evaluation costs the same whatever `t` (no steps), and the motion
//! keeps M (world vector) and E exactly up to rounding.

use glam::{DMat3, DQuat, DVec3};

use super::elliptic::{carlson_rf, carlson_rf_rj, Jacobi, ThetaPhase};
use super::Ellipsoid;

/// A body's torque-free motion from one state, prepared once (the
/// invariants, the elliptic parameter and integrals) and evaluated at any
/// time at the same cost.
#[derive(Debug, Clone)]
pub struct TorqueFree {
    /// Body coordinates → relabelled coordinates (a proper rotation).
    pub(crate) perm: DMat3,
    /// R₀ B(l₀)ᵀ, relabelled body → world up to the precession angle.
    pub(crate) base: DMat3,
    pub(crate) inertia: DVec3,
    pub(crate) amp: DVec3,
    /// σs and σ: the signs of ω₂ and ω₃ (see the module notes).
    pub(crate) sign2: f64,
    pub(crate) sign3: f64,
    pub(crate) lambda: f64,
    pub(crate) tau0: f64,
    /// 2K, the period of sn² in τ.
    pub(crate) two_k: f64,
    pub(crate) jacobi: Jacobi,
    /// Π(−ν; am τ) in theta form.
    pub(crate) phase: ThetaPhase,
    /// The precession angle's secular rate, `M/I₃ + swing · (Π(−ν)/K) λ`,
    /// its periodic amplitude, `swing · S`, and the periodic part at τ₀
    /// (`swing = M(I₃ − I₁)/(I₁ I₃ λ)`).
    pub(crate) rate: f64,
    pub(crate) amplitude: f64,
    pub(crate) periodic0: f64,
    /// A steady rotation (about a principal axis, or none): ω constant.
    pub(crate) steady: Option<DVec3>,
    /// Within [`SEPARATRIX`] of the separatrix, RK4 at this step instead.
    pub(crate) rk4_step: Option<f64>,
    pub(crate) rotation0: DMat3,
    pub(crate) omega0: DVec3,
    pub(crate) body_inertia: DVec3,
}

/// How close to the separatrix (1 − k²) the closed form is used. Its error
/// grows like 1e-17/(1 − k²) (measured: 3e-13 at 5e-4, 2e-12 at 5e-6, 3e-10
/// at 5e-8); closer than this, RK4 at |ω|h = 1e-3 takes over (a fraction of
/// random spins of about this order).
pub const SEPARATRIX: f64 = 1e-6;

/// `Rx(θ) Rz(ψ)` for the unit vector `l = (sinθ sinψ, sinθ cosψ, cosθ)`:
/// the rotation that takes `l` to e₃.
fn to_pole(l: DVec3) -> DMat3 {
    // l is a unit vector: no overflow to guard against.
    let st = (l.x * l.x + l.y * l.y).sqrt();
    let (sp, cp) = if st > 0.0 {
        (l.x / st, l.y / st)
    } else {
        (0.0, 1.0)
    };
    let ct = l.z;
    let rz = DMat3::from_cols(DVec3::new(cp, sp, 0.0), DVec3::new(-sp, cp, 0.0), DVec3::Z);
    let rx = DMat3::from_cols(DVec3::X, DVec3::new(0.0, ct, st), DVec3::new(0.0, -st, ct));
    rx * rz
}

fn rot_z(a: f64) -> DMat3 {
    let (s, c) = a.sin_cos();
    DMat3::from_cols(DVec3::new(c, s, 0.0), DVec3::new(-s, c, 0.0), DVec3::Z)
}

impl TorqueFree {
    /// The motion of a body of principal moments `inertia` (all distinct)
    /// from attitude `rotation` (body → world) and body angular velocity
    /// `omega`.
    pub fn new(inertia: DVec3, rotation: DMat3, omega: DVec3) -> Self {
        let j = inertia.to_array();
        let w = omega.to_array();
        // Ascending order of the moments.
        let mut order = [0usize, 1, 2];
        order.sort_by(|&a, &b| j[a].total_cmp(&j[b]));
        let [s, mid, l] = order;
        // Which axis the body turns about: M² − 2E·I₂ from terms without
        // cancellation of the middle axis.
        let dm = j[s] * (j[s] - j[mid]) * w[s] * w[s] + j[l] * (j[l] - j[mid]) * w[l] * w[l];
        let axes = if dm >= 0.0 { [s, mid, l] } else { [l, mid, s] };
        let mut rows = [DVec3::ZERO; 3];
        for (r, &a) in rows.iter_mut().zip(&axes) {
            *r = DVec3::from_array(std::array::from_fn(|k| (k == a) as u8 as f64));
        }
        // A proper rotation: fix the sign of the third row.
        if rows[0].cross(rows[1]).dot(rows[2]) < 0.0 {
            rows[2] = -rows[2];
        }
        let perm = DMat3::from_cols(rows[0], rows[1], rows[2]).transpose();
        let i = DVec3::new(j[axes[0]], j[axes[1]], j[axes[2]]);
        let wp = perm * omega;
        let (i1, i2, i3) = (i.x, i.y, i.z);
        let (w1, w2, w3) = (wp.x, wp.y, wp.z);
        let big_m = (i * wp).length();
        let d3 = i1 * (i3 - i1) * w1 * w1 + i2 * (i3 - i2) * w2 * w2;
        let d1 = i2 * (i2 - i1) * w2 * w2 + i3 * (i3 - i1) * w3 * w3;
        let r0 = rotation * perm.transpose();
        let mut tf = Self {
            perm,
            base: r0,
            inertia: i,
            amp: DVec3::ZERO,
            sign2: 1.0,
            sign3: 1.0,
            lambda: 0.0,
            tau0: 0.0,
            two_k: 0.0,
            jacobi: Jacobi::new(0.0),
            phase: ThetaPhase::default(),
            rate: 0.0,
            amplitude: 0.0,
            periodic0: 0.0,
            steady: None,
            rk4_step: None,
            rotation0: rotation,
            omega0: omega,
            body_inertia: inertia,
        };
        // No spin, or a spin about one principal axis (D₃ = 0 for axis 3;
        // the middle axis is the unstable equilibrium on the separatrix):
        // ω is constant and the body turns about it.
        let on_axis = [w1, w2, w3].iter().filter(|w| **w != 0.0).count() <= 1;
        if big_m == 0.0 || d3 == 0.0 || on_axis {
            tf.steady = Some(omega);
            return tf;
        }
        let sign3 = if w3 >= 0.0 { 1.0 } else { -1.0 };
        let s_sign = if i3 > i1 { 1.0 } else { -1.0 };
        let amp = DVec3::new(
            (d3 / (i1 * (i3 - i1))).sqrt(),
            (d3 / (i2 * (i3 - i2))).sqrt(),
            (d1 / (i3 * (i3 - i1))).sqrt(),
        );
        let lambda = ((i3 - i2) * d1 / (i1 * i2 * i3)).sqrt();
        // m = 1 is the separatrix (probability zero), where K diverges: kept
        // just below it.
        let m = ((i2 - i1) * d3 / ((i3 - i2) * d1)).clamp(0.0, 1.0 - f64::EPSILON);
        if 1.0 - m < SEPARATRIX {
            // |ω| h = 1e-3: RK4's error is about 1e-13 per radian turned.
            tf.rk4_step = Some(1e-3 / omega.length());
            return tf;
        }
        let nu = i3 * (i2 - i1) / (i1 * (i3 - i2));
        let jacobi = Jacobi::new(m);
        let mc = 1.0 - m;
        let (k_complete, rj) = carlson_rf_rj(0.0, mc, 1.0, 1.0 + nu);
        let pi_complete = k_complete - nu / 3.0 * rj;
        // The initial phase: am τ₀ = atan2(sn τ₀, cn τ₀), reduced to
        // [−π/2, π/2] plus a multiple of π.
        let cn0 = w1 / amp.x;
        let sn0 = sign3 * s_sign * w2 / amp.y;
        let norm = cn0.hypot(sn0);
        let (cn0, sn0) = (cn0 / norm, sn0 / norm);
        let (turns, s_r, c_r) = if cn0 >= 0.0 {
            (0.0, sn0, cn0)
        } else if sn0 >= 0.0 {
            (1.0, -sn0, -cn0)
        } else {
            (-1.0, -sn0, -cn0)
        };
        let d_r = (1.0 - m * s_r * s_r).max(0.0);
        let f_r = s_r * carlson_rf(c_r * c_r, d_r, 1.0);
        let tau0 = 2.0 * turns * k_complete + f_r;
        let phase = ThetaPhase::new(m, nu, k_complete, pi_complete);
        let swing = big_m * (i3 - i1) / (i1 * i3 * lambda);
        let l0 = i * wp / big_m;
        tf.base = r0 * to_pole(l0).transpose();
        tf.amp = amp;
        tf.sign2 = sign3 * s_sign;
        tf.sign3 = sign3;
        tf.lambda = lambda;
        tf.tau0 = tau0;
        tf.two_k = 2.0 * k_complete;
        tf.jacobi = jacobi;
        tf.rate = big_m / i3 + swing * phase.slope * lambda;
        tf.amplitude = swing * phase.s;
        // τ₀ − f_r is a whole number of periods of the periodic part.
        tf.periodic0 = phase.periodic(f_r);
        tf.phase = phase;
        tf
    }

    /// Attitude (body → world) and body angular velocity `t` seconds on.
    pub fn at(&self, t: f64) -> (DMat3, DVec3) {
        if let Some(h) = self.rk4_step {
            return rk4_inertia(self.body_inertia, self.rotation0, self.omega0, t, h);
        }
        if let Some(w) = self.steady {
            let n = w.length();
            if n == 0.0 {
                return (self.rotation0, w);
            }
            return (self.rotation0 * DMat3::from_axis_angle(w / n, n * t), w);
        }
        let tau = self.tau0 + self.lambda * t;
        let turns = (tau / self.two_k).round();
        let tau_r = tau - turns * self.two_k;
        let (s, c, d) = self.jacobi.sncndn(tau_r);
        let flip = if turns.rem_euclid(2.0) == 0.0 {
            1.0
        } else {
            -1.0
        };
        let (sn, cn) = (flip * s, flip * c);
        let wp = DVec3::new(
            self.amp.x * cn,
            self.sign2 * self.amp.y * sn,
            self.sign3 * self.amp.z * d,
        );
        // φ − φ₀ = M t/I₃ + swing · [Π(−ν; am τ) − Π(−ν; am τ₀)], the
        // secular part of Π folded into `rate`.
        let phi = self.rate * t + self.amplitude * (self.phase.periodic(tau_r) - self.periodic0);
        let lp = self.inertia * wp;
        let r = self.base * rot_z(phi) * to_pole(lp / lp.length());
        (r * self.perm, self.perm.transpose() * wp)
    }
}

fn euler_rhs(j: DVec3, q: DQuat, w: DVec3) -> (DQuat, DVec3) {
    let qd = q * DQuat::from_xyzw(w.x, w.y, w.z, 0.0);
    (
        DQuat::from_xyzw(0.5 * qd.x, 0.5 * qd.y, 0.5 * qd.z, 0.5 * qd.w),
        -w.cross(j * w) / j,
    )
}

fn qadd(q: DQuat, d: DQuat, h: f64) -> DQuat {
    DQuat::from_xyzw(q.x + d.x * h, q.y + d.y * h, q.z + d.z * h, q.w + d.w * h)
}

/// Torque-free rotation over `t` by RK4 with steps of at most `max_step`.
pub fn rk4_rotation(
    body: &Ellipsoid,
    rotation: DMat3,
    omega: DVec3,
    t: f64,
    max_step: f64,
) -> (DMat3, DVec3) {
    rk4_inertia(body.inertia(), rotation, omega, t, max_step)
}

/// [`rk4_rotation`] for principal moments `j`.
pub(crate) fn rk4_inertia(
    j: DVec3,
    rotation: DMat3,
    omega: DVec3,
    t: f64,
    max_step: f64,
) -> (DMat3, DVec3) {
    let steps = ((t.abs() / max_step).ceil() as u64).max(1);
    let h = t / steps as f64;
    let mut q = DQuat::from_mat3(&rotation);
    let mut w = omega;
    for _ in 0..steps {
        let (q1, w1) = euler_rhs(j, q, w);
        let (q2, w2) = euler_rhs(j, qadd(q, q1, 0.5 * h), w + w1 * (0.5 * h));
        let (q3, w3) = euler_rhs(j, qadd(q, q2, 0.5 * h), w + w2 * (0.5 * h));
        let (q4, w4) = euler_rhs(j, qadd(q, q3, h), w + w3 * h);
        let dq = DQuat::from_xyzw(
            q1.x + 2.0 * q2.x + 2.0 * q3.x + q4.x,
            q1.y + 2.0 * q2.y + 2.0 * q3.y + q4.y,
            q1.z + 2.0 * q2.z + 2.0 * q3.z + q4.z,
            q1.w + 2.0 * q2.w + 2.0 * q3.w + q4.w,
        );
        q = qadd(q, dq, h / 6.0).normalize();
        w += (w1 + 2.0 * w2 + 2.0 * w3 + w4) * (h / 6.0);
    }
    (DMat3::from_quat(q), w)
}

#[cfg(test)]
mod motion_tests {
    use super::*;
    use crate::physics::Ellipsoid;

    fn bodies() -> Vec<Ellipsoid> {
        [
            [0.5, 0.3, 0.2],
            [0.03, 0.02, 0.01],
            [0.2, 0.5, 0.3],
            [0.3, 0.2, 0.5],
            [0.5, 0.49, 0.1],
            // Equal moments (I₁ = I₂): m = ν = 0 in the closed form.
            [0.4, 0.4, 0.1],
        ]
        .iter()
        .map(|s| Ellipsoid::new(*s, 2.0).unwrap())
        .collect()
    }

    fn starts() -> Vec<(DMat3, DVec3)> {
        let a = DMat3::from_euler(glam::EulerRot::ZYX, 0.3, -1.1, 2.0);
        vec![
            (a, DVec3::new(1.0, 2.0, 3.0)),
            (a, DVec3::new(3.0, 0.2, 0.4)),
            (DMat3::IDENTITY, DVec3::new(-0.5, 4.0, -0.3)),
            (a, DVec3::new(0.01, -2.5, 1e-3)),
            (a, DVec3::new(-2.0, -1.0, -3.0)),
            (a, DVec3::new(0.0, 0.0, 5.0)),
            (a, DVec3::new(1e-9, 1e-9, 5.0)),
            (a, DVec3::new(0.0, 5.0, 0.0)),
            (a, DVec3::new(5.0, 0.0, 0.0)),
        ]
    }

    fn mat_err(a: DMat3, b: DMat3) -> f64 {
        (a - b)
            .to_cols_array()
            .iter()
            .fold(0f64, |m, x| m.max(x.abs()))
    }

    /// Against RK4 at a step so fine that its error is below 1e-10, over
    /// several periods, for bodies in any axis order, both families
    /// (rotation about the largest and the smallest moment) and near-steady
    /// spins.
    #[test]
    fn matches_a_fine_rk4_integration() {
        for body in bodies() {
            for &(r0, w0) in &starts() {
                let tf = TorqueFree::new(body.inertia(), r0, w0);
                for t in [0.0, 0.013, 0.41, 1.7, 3.0] {
                    let (r, w) = tf.at(t);
                    let (rr, wr) = rk4_rotation(&body, r0, w0, t, 5e-5);
                    let scale = w0.length().max(1e-300);
                    assert!(
                        mat_err(r, rr) < 1e-9,
                        "{:?} {w0} t {t}: attitude off by {}",
                        body.semi_axes(),
                        mat_err(r, rr)
                    );
                    assert!(
                        (w - wr).length() / scale < 1e-9,
                        "{:?} {w0} t {t}: ω {w} vs {wr}",
                        body.semi_axes()
                    );
                }
            }
        }
    }

    /// Spins near the middle axis (the separatrix, on both sides of the
    /// switch to RK4) against fine RK4.
    #[test]
    fn near_the_separatrix() {
        let body = Ellipsoid::new([0.2, 0.5, 0.3], 2.0).unwrap();
        let a = DMat3::from_euler(glam::EulerRot::ZYX, 0.3, -1.1, 2.0);
        for eps in [1e-1, 1e-2, 1e-3, 1e-4, 1e-6] {
            let w0 = DVec3::new(eps, 0.3 * eps, 5.0);
            let tf = TorqueFree::new(body.inertia(), a, w0);
            for t in [0.0, 0.5, 2.0, 5.0] {
                let (r, _) = tf.at(t);
                let (rr, _) = rk4_rotation(&body, a, w0, t, 2e-5);
                assert!(
                    mat_err(r, rr) < 1e-10,
                    "eps {eps} t {t}: {}",
                    mat_err(r, rr)
                );
            }
        }
    }

    /// World angular momentum and energy are kept to rounding at any time,
    /// and the attitude stays a rotation.
    #[test]
    fn keeps_momentum_and_energy() {
        for body in bodies() {
            let j = body.inertia();
            for &(r0, w0) in &starts() {
                let tf = TorqueFree::new(j, r0, w0);
                let l0 = r0 * (j * w0);
                let e0 = (j * w0 * w0).element_sum();
                for k in 0..50 {
                    let t = k as f64 * 7.3;
                    let (r, w) = tf.at(t);
                    let l = r * (j * w);
                    assert!(
                        (l - l0).length() <= 1e-12 * l0.length().max(1e-300),
                        "{w0} t {t}: {l} vs {l0}"
                    );
                    let e = (j * w * w).element_sum();
                    assert!((e - e0).abs() <= 1e-12 * e0.max(1e-300), "{w0} t {t}");
                    assert!(mat_err(r.transpose() * r, DMat3::IDENTITY) < 1e-13);
                    assert!((r.determinant() - 1.0).abs() < 1e-13);
                }
            }
        }
    }
}
