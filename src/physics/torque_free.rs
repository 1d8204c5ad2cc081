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

use glam::{DMat3, DVec3};

/// Carlson's R_F(x, y, z) (x, y, z ≥ 0, at most one zero), by duplication to
/// a relative error below 1e-16.
pub fn carlson_rf(x: f64, y: f64, z: f64) -> f64 {
    const ERRTOL: f64 = 0.0025;
    let (mut x, mut y, mut z) = (x, y, z);
    loop {
        let (sx, sy, sz) = (x.sqrt(), y.sqrt(), z.sqrt());
        let lambda = sx * (sy + sz) + sy * sz;
        x = 0.25 * (x + lambda);
        y = 0.25 * (y + lambda);
        z = 0.25 * (z + lambda);
        let ave = (x + y + z) / 3.0;
        let (dx, dy, dz) = ((ave - x) / ave, (ave - y) / ave, (ave - z) / ave);
        if dx.abs().max(dy.abs()).max(dz.abs()) <= ERRTOL {
            let e2 = dx * dy - dz * dz;
            let e3 = dx * dy * dz;
            return (1.0 + (e2 / 24.0 - 0.1 - 3.0 / 44.0 * e3) * e2 + e3 / 14.0) / ave.sqrt();
        }
    }
}

/// Carlson's R_C(x, y) for x ≥ 0, y > 0, in closed form (the arctangent
/// forms, accurate also for x close to y).
pub fn carlson_rc(x: f64, y: f64) -> f64 {
    if x < y {
        let d = y - x;
        (d / x).sqrt().atan() / d.sqrt()
    } else if x > y {
        let d = x - y;
        (d / x).sqrt().atanh() / d.sqrt()
    } else {
        1.0 / y.sqrt()
    }
}

/// Carlson's R_J(x, y, z, p) for x, y, z ≥ 0 (at most one zero) and p > 0,
/// by duplication to a relative error of about 1e-16 ([`carlson_rf_rj`]).
pub fn carlson_rj(x: f64, y: f64, z: f64, p: f64) -> f64 {
    carlson_rf_rj(x, y, z, p).1
}

/// R_F(x, y, z) and R_J(x, y, z, p) together: the two duplications share
/// x, y and z, so one loop serves both (iterated until both series
/// converge).
pub fn carlson_rf_rj(x: f64, y: f64, z: f64, p: f64) -> (f64, f64) {
    const C1: f64 = 3.0 / 14.0;
    const C2: f64 = 1.0 / 3.0;
    const C3: f64 = 3.0 / 22.0;
    const C4: f64 = 3.0 / 26.0;
    const C5: f64 = 0.75 * C3;
    const C6: f64 = 1.5 * C4;
    const C7: f64 = 0.5 * C2;
    const C8: f64 = C3 + C3;
    let (mut x, mut y, mut z, mut p) = (x, y, z, p);
    let (mut sum, mut fac) = (0.0, 1.0);
    loop {
        let (sx, sy, sz) = (x.sqrt(), y.sqrt(), z.sqrt());
        let lambda = sx * (sy + sz) + sy * sz;
        let alpha = (p * (sx + sy + sz) + sx * sy * sz).powi(2);
        let beta = p * (p + lambda).powi(2);
        sum += fac * carlson_rc(alpha, beta);
        fac *= 0.25;
        x = 0.25 * (x + lambda);
        y = 0.25 * (y + lambda);
        z = 0.25 * (z + lambda);
        p = 0.25 * (p + lambda);
        let ave = 0.2 * (x + y + z + p + p);
        let (dx, dy, dz, dp) = (
            (ave - x) / ave,
            (ave - y) / ave,
            (ave - z) / ave,
            (ave - p) / ave,
        );
        let ave3 = (x + y + z) / 3.0;
        let (ex, ey, ez) = ((ave3 - x) / ave3, (ave3 - y) / ave3, (ave3 - z) / ave3);
        if dx.abs().max(dy.abs()).max(dz.abs()).max(dp.abs()) <= 0.0015
            && ex.abs().max(ey.abs()).max(ez.abs()) <= 0.0025
        {
            let e2 = ex * ey - ez * ez;
            let e3 = ex * ey * ez;
            let rf = (1.0 + (e2 / 24.0 - 0.1 - 3.0 / 44.0 * e3) * e2 + e3 / 14.0) / ave3.sqrt();
            let ea = dx * (dy + dz) + dy * dz;
            let eb = dx * dy * dz;
            let ec = dp * dp;
            let ed = ea - 3.0 * ec;
            let ee = eb + 2.0 * dp * (ea - ec);
            let rj = 3.0 * sum
                + fac
                    * (1.0
                        + ed * (-C1 + C5 * ed - C6 * ee)
                        + eb * (C7 + dp * (-C8 + dp * C4))
                        + dp * ea * (C2 - dp * C3)
                        - C2 * dp * ec)
                    / (ave * ave.sqrt());
            return (rf, rj);
        }
    }
}

/// Jacobi's sn, cn, dn of one parameter m = k² ∈ [0, 1], by the descending
/// Landen (AGM) sequence, which depends on m only and is kept.
#[derive(Debug, Clone, Copy)]
pub struct Jacobi {
    /// 1 − m.
    pub(crate) mc: f64,
    pub(crate) levels: usize,
    pub(crate) a: [f64; 16],
    pub(crate) b: [f64; 16],
    /// The AGM limit.
    pub(crate) agm: f64,
}

impl Jacobi {
    pub fn new(m: f64) -> Self {
        let mc = (1.0 - m).max(0.0);
        let mut s = Self {
            mc,
            levels: 0,
            a: [0.0; 16],
            b: [0.0; 16],
            agm: 1.0,
        };
        if mc == 0.0 {
            return s;
        }
        let (mut a, mut emc) = (1.0f64, mc);
        let mut c = 1.0;
        for i in 0..16 {
            s.levels = i + 1;
            s.a[i] = a;
            emc = emc.sqrt();
            s.b[i] = emc;
            c = 0.5 * (a + emc);
            if (a - emc).abs() <= 1e-8 * a {
                break;
            }
            emc *= a;
            a = c;
        }
        s.agm = c;
        s
    }

    /// (sn u, cn u, dn u).
    pub fn sncndn(&self, u: f64) -> (f64, f64, f64) {
        if self.mc == 0.0 {
            let cn = 1.0 / u.cosh();
            return (u.tanh(), cn, cn);
        }
        let v = u * self.agm;
        let (mut sn, cn0) = v.sin_cos();
        let mut cn = cn0;
        let mut dn = 1.0;
        if sn != 0.0 {
            let mut a = cn / sn;
            let mut c = self.agm * a;
            for i in (0..self.levels).rev() {
                let b = self.a[i];
                a *= c;
                c *= dn;
                dn = (self.b[i] + a) / (b + a);
                a = c / b;
            }
            let r = 1.0 / (c * c + 1.0).sqrt();
            sn = if sn >= 0.0 { r } else { -r };
            cn = c * sn;
        }
        (sn, cn, dn)
    }
}

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
            return crate::physics::flight::rk4_inertia(
                self.body_inertia,
                self.rotation0,
                self.omega0,
                t,
                h,
            );
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

/// Most terms of a [`ThetaPhase`] series: enough for q ≤ 0.55, that is for
/// every orbit the closed form is used on (1 − k² ≥ [`SEPARATRIX`]).
pub(crate) const THETA_TERMS: usize = 12;

/// `Π(−ν; am u)` for any real `u` in Jacobi's theta form (Whittaker &
/// Watson §22.74, with the imaginary parameter of a negative
/// characteristic):
///
/// `Π(−ν; am u) = (Π(−ν)/K) u + S · arg Θ(u + iβ)`,
///
/// where `Θ(u) = θ₄(πu/2K, q)`, `q = exp(−πK′/K)`, `sc(β, k′) = √ν/k` and
/// `S = sn β cn β / dn β = √ν / √((k² + ν)(1 + ν))`. The argument is
/// periodic in u with period 2K and its series,
/// `Θ(u + iβ) = 1 + Σₙ 2(−1)ⁿ qⁿ² [cos 2nv cosh 2nw − i sin 2nv sinh 2nw]`
/// (`v = πu/2K`, `w = πβ/2K`), converges like `q^{n(n−1)}`: with
/// `γ = K′ − β = F(atan(1/√ν) | 1 − k²)` (so that no cancellation enters),
/// `qⁿ² e^{±2nw} = exp(−(π/K)(K′n² ∓ n(K′ − γ)))`. Each evaluation is one
/// `sin_cos`, a recurrence over a dozen terms and one `atan2`, with no
/// data-dependent loop: what Carlson's duplication needed for every pose.
#[derive(Debug, Clone, Copy, Default)]
pub struct ThetaPhase {
    /// π/(2K): u → v.
    pub(crate) scale: f64,
    /// Π(−ν)/K.
    pub(crate) slope: f64,
    pub(crate) s: f64,
    pub(crate) terms: usize,
    /// 2(−1)ⁿ qⁿ² cosh 2nw and 2(−1)ⁿ qⁿ² sinh 2nw, n = 1, 2, …
    pub(crate) re: [f64; THETA_TERMS],
    pub(crate) im: [f64; THETA_TERMS],
}

impl ThetaPhase {
    /// For parameter m = k² ∈ (0, 1) and ν > 0, given K(m) and Π(−ν | m).
    pub fn new(m: f64, nu: f64, k_complete: f64, pi_complete: f64) -> Self {
        let mc = 1.0 - m;
        // K′ = K(1 − m): infinite at m = 0 (equal moments I₁ = I₂, where
        // also ν = 0 and Π(0; am u) = u).
        let k_prime = if m > 0.0 {
            carlson_rf(0.0, m, 1.0)
        } else {
            f64::INFINITY
        };
        // γ = K′ − β = F(ψ | 1 − m) with tan ψ = 1/√ν (ψ = π/2 at ν = 0).
        let (sin_psi, cos2_psi) = (1.0 / (1.0 + nu).sqrt(), nu / (1.0 + nu));
        let gamma = if nu > 0.0 {
            sin_psi * carlson_rf(cos2_psi, 1.0 - mc * sin_psi * sin_psi, 1.0)
        } else {
            k_prime
        };
        let r = std::f64::consts::PI / k_complete;
        let mut s = Self {
            scale: 0.5 * r,
            slope: pi_complete / k_complete,
            // (No periodic part at ν = 0.)
            s: if nu > 0.0 {
                (nu / ((m + nu) * (1.0 + nu))).sqrt()
            } else {
                0.0
            },
            terms: 0,
            re: [0.0; THETA_TERMS],
            im: [0.0; THETA_TERMS],
        };
        for n in 1..=THETA_TERMS {
            let nf = n as f64;
            // qⁿ² e^{±2nw} = exp(−(π/K)(K′n(n ∓ 1) ± nγ)), written without
            // K′ − γ (and without ∞ · 0 when K′ is infinite).
            let below = if n == 1 {
                0.0
            } else {
                k_prime * nf * (nf - 1.0)
            };
            let up = (-r * (below + nf * gamma)).exp();
            let down = if k_prime.is_finite() {
                (-r * (k_prime * nf * (nf + 1.0) - nf * gamma)).exp()
            } else {
                0.0
            };
            let sign = if n % 2 == 0 { 1.0 } else { -1.0 };
            s.re[n - 1] = sign * (up + down);
            s.im[n - 1] = sign * (up - down);
            s.terms = n;
            if up < 1e-18 {
                break;
            }
        }
        s
    }

    /// The periodic part, `arg Θ(u + iβ)` (period 2K in u).
    #[inline]
    pub fn periodic(&self, u: f64) -> f64 {
        let (s1, c1) = (2.0 * self.scale * u).sin_cos();
        let (mut re, mut im) = (1.0, 0.0);
        let (mut c_prev, mut s_prev) = (1.0, 0.0);
        let (mut c, mut s) = (c1, s1);
        for n in 0..self.terms {
            re += self.re[n] * c;
            im -= self.im[n] * s;
            let (cn, sn) = (2.0 * c1 * c - c_prev, 2.0 * c1 * s - s_prev);
            (c_prev, s_prev, c, s) = (c, s, cn, sn);
        }
        im.atan2(re)
    }

    /// `Π(−ν; am u)` (the motion uses its two parts apart).
    #[cfg(test)]
    pub fn value(&self, u: f64) -> f64 {
        self.slope * u + self.s * self.periodic(u)
    }
}

/// Π(−ν; φ) for |φ| ≤ π/2 given sin φ, cos φ and 1 − k² sin²φ (what the
/// theta form is tested against):
#[cfg(test)]
/// `s R_F(c², Δ², 1) − (ν/3) s³ R_J(c², Δ², 1, 1 + ν s²)`.
fn pi_partial(s: f64, c: f64, delta2: f64, nu: f64) -> f64 {
    if s == 0.0 {
        return 0.0;
    }
    let (rf, rj) = carlson_rf_rj(c * c, delta2, 1.0, 1.0 + nu * s * s);
    s * rf - nu / 3.0 * s * s * s * rj
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Carlson's own test values (Numer. Algorithms 10, 1995, Table 1–3).
    #[test]
    fn carlson_forms_match_published_values() {
        let rel = |a: f64, b: f64| ((a - b) / b).abs();
        assert!(rel(carlson_rf(1.0, 2.0, 0.0), 1.311_028_777_146_1) < 1e-13);
        assert!(rel(carlson_rf(2.0, 3.0, 4.0), 0.584_082_841_677_15) < 1e-13);
        assert!(rel(carlson_rc(0.0, 0.25), std::f64::consts::PI) < 1e-15);
        assert!(rel(carlson_rc(2.25, 2.0), std::f64::consts::LN_2) < 1e-14);
        assert!(rel(carlson_rj(0.0, 1.0, 2.0, 3.0), 0.776_886_237_785_82) < 1e-13);
        assert!(rel(carlson_rj(2.0, 3.0, 4.0, 5.0), 0.142_975_796_671_57) < 1e-13);
        // The joint loop gives both, to the same digits (mpmath values).
        for (x, y, z, p, rf, rj) in [
            (
                0.0,
                1.0,
                2.0,
                3.0,
                1.311_028_777_146_06,
                0.776_886_237_785_823,
            ),
            (
                2.0,
                3.0,
                4.0,
                5.0,
                0.584_082_841_677_152,
                0.142_975_796_671_568,
            ),
            (
                0.25,
                0.9,
                1.0,
                1.7,
                1.234_064_574_345_174,
                1.024_611_852_381_018,
            ),
        ] {
            let (a, b) = carlson_rf_rj(x, y, z, p);
            assert!(
                rel(a, rf) < 1e-14 && rel(b, rj) < 1e-14,
                "{x} {y} {z} {p}: {a} {b}"
            );
        }
    }

    /// Π(−ν | m) and K(m) for the tests, from Carlson's forms.
    fn complete(m: f64, nu: f64) -> (f64, f64) {
        let (k, rj) = carlson_rf_rj(0.0, 1.0 - m, 1.0, 1.0 + nu);
        (k, k - nu / 3.0 * rj)
    }

    /// The theta form of Π(−ν; am u) against `∫₀ᵘ dv / (1 + ν sn² v)` by
    /// mpmath's quadrature at 30 digits (`mp.quad` with `mp.ellipfun`,
    /// split at multiples of K, at the exact binary values of the f64
    /// inputs: near the separatrix Π moves by 10⁴ times a change of m), from
    /// m near 0 to the separatrix switch and ν from 10⁻³ to 10⁶.
    #[test]
    fn theta_phase_matches_quadrature() {
        for (m, nu, u, want) in [
            (1e-6, 0.2, 1.3, 1.2073581950497012),
            (0.3, 8.4, -2.1, -0.576_960_876_811_074_2),
            (0.5, 1e6, 0.77, 0.0015698890771730242),
            (0.7, 1e-3, 40.0, 39.97684025538245),
            (0.99, 300.0, -9.5, -0.292_543_836_618_876),
            (0.9999, 0.001, -5.9117, -5.906792649808501),
            (0.9999, 8.4, 12.25, 2.2663896348018595),
            (0.9999989, 0.001, -58.99, -58.938059583552172),
            (0.9999989, 8.4, 31.0, 4.4471479697732643),
            (0.9999989, 1e6, -3.0, -0.001572789783139142),
        ] {
            let (k, pc) = complete(m, nu);
            let got = ThetaPhase::new(m, nu, k, pc).value(u);
            assert!(
                (got - want).abs() <= 4e-15 * want.abs().max(1.0),
                "m {m} nu {nu} u {u}: {got} vs {want}"
            );
        }
    }

    /// The theta form against Carlson's (the reduced amplitude plus whole
    /// half-periods) over a grid, where Carlson's form is accurate
    /// (m ≤ 0.99: nearer the separatrix, sn at |u| ≈ K loses digits and the
    /// quadrature test above decides).
    #[test]
    fn theta_phase_matches_carlson() {
        for m in [1e-6, 0.01, 0.3, 0.7, 0.99] {
            let jac = Jacobi::new(m);
            for nu in [1e-3, 0.2, 1.0, 8.4, 300.0, 1e6] {
                let (k, pc) = complete(m, nu);
                let th = ThetaPhase::new(m, nu, k, pc);
                for i in -60..=60 {
                    let u = i as f64 * 0.37 * k / 3.0;
                    let turns = (u / (2.0 * k)).round();
                    let (s, c, _) = jac.sncndn(u - turns * 2.0 * k);
                    let want = 2.0 * turns * pc + pi_partial(s, c, (1.0 - m * s * s).max(0.0), nu);
                    let got = th.value(u);
                    let scale = pc.abs().max(1.0) * (1.0 + turns.abs());
                    assert!(
                        (got - want).abs() <= 1e-13 * scale,
                        "m {m} nu {nu} u {u}: {got} vs {want}"
                    );
                }
            }
        }
    }

    /// sn² + cn² = 1, dn² + m sn² = 1, and d sn/du = cn dn (by central
    /// differences), over a range of parameters.
    #[test]
    fn jacobi_identities() {
        for m in [0.0, 1e-6, 0.3, 0.9, 0.999_999, 1.0] {
            let j = Jacobi::new(m);
            for k in -40..40 {
                let u = k as f64 * 0.173;
                let (s, c, d) = j.sncndn(u);
                assert!((s * s + c * c - 1.0).abs() < 1e-14, "m {m} u {u}");
                assert!((d * d + m * s * s - 1.0).abs() < 1e-14, "m {m} u {u}");
                let h = 1e-5;
                let ds = (j.sncndn(u + h).0 - j.sncndn(u - h).0) / (2.0 * h);
                assert!((ds - c * d).abs() < 1e-8, "m {m} u {u}: {ds} vs {}", c * d);
            }
        }
        // m = 0: the circular functions.
        let _ = Jacobi::new(1.0).sncndn(0.3);
        let (s, c, d) = Jacobi::new(0.0).sncndn(0.7);
        assert!((s - 0.7f64.sin()).abs() < 1e-15 && (c - 0.7f64.cos()).abs() < 1e-15 && d == 1.0);
    }
}

#[cfg(test)]
mod motion_tests {
    use super::*;
    use crate::physics::flight::rk4_rotation;
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
