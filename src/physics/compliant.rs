//! The compliant reference: the ceiling of the accuracy ladder
//! (physics.md, "Compliant reference").
//!
//! Each contact carries a Hertz force `F = K δ^{3/2} (1 + χ δ̇)₊` with
//! `K = (4/3) E* sqrt(R_e)`, `R_e = abc / h²` at the support point, and
//! Hunt–Crossley damping `χ = α(k) / v₀`, v₀ the contact's approach speed
//! when it first touches. The full rigid-body motion is integrated through
//! the impact with classical RK4 at a fixed step (the knob): centre,
//! orientation quaternion, velocity and body-frame angular velocity, so the
//! body rotates during contact and the support point moves over the surface.
//! The run stops when every contact has separated.
//!
//! Matching the damping to k: in units `L = (m v₀²/K)^{2/5}` and `L/v₀`
//! a single Hertz contact obeys `X'' = −X^{3/2}(1 + α X')₊`, `X(0) = 0`,
//! `X'(0) = 1`, whatever the mass, stiffness and speed, so its restitution
//! is a function of α alone. [`damping_for_restitution`] inverts it by
//! bisection, so an isolated contact rebounds with exactly its plane's k in
//! the stiff limit, and one-contact impacts converge to the rigid laws as
//! E* grows (tested). With several contacts the result is the physical answer
//! that the rigid laws approximate.
//!
//! Friction (friction.md, "Compliant reference"): a plane with `μ > 0` adds
//! regularised Coulomb, `f = −μ F_n c_t / sqrt(|c_t|² + ε²)` at the support
//! point, `ε` a fraction of the velocity scale `|v| + L|ω|` before the
//! impact. With a small ε the force is stiff while a contact sticks (its
//! time constant is about ε/μ of the contact duration), so it is not part
//! of the explicit RK4 step: after each step the friction impulse of the
//! step's normal impulse is applied by backward Euler. That step minimises
//! the strictly convex `½|u − u*|²_M + Σ μ_i Δp_i sqrt(|c_t,i(u)|² + ε²)`
//! over the velocities `u = (v, ω)`: each contact's impulse exactly, from
//! one scalar equation, and Gauss–Seidel over the contacts. So it is stable
//! for any ε and never adds energy. The splitting is first order in the
//! step, like the Hertz force's kinks. With every μ = 0 nothing of this
//! runs and the integration is the frictionless one, bit for bit.

use glam::{DMat3, DQuat, DVec3};

use super::friction::skew;
use super::{kinetic_energy, ContactGeometry, Ellipsoid, Plane, Pose, State};

/// Knobs of a compliant integration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompliantParams {
    /// Effective contact modulus E* (Pa); steel on steel is about 1.15e11.
    pub effective_modulus: f64,
    /// RK4 steps per estimated Hertz contact duration of the leading contact.
    pub steps_per_contact: u32,
    /// Regularisation of Coulomb friction relative to the velocity scale
    /// `|v| + L|ω|` before the impact: `ε = friction_regularisation × scale`
    /// (friction.md's default is [`CompliantParams::REGULARISATION`]).
    /// Unused when every μ is zero.
    pub friction_regularisation: f64,
}

impl CompliantParams {
    /// friction.md's default regularisation, `ε = 1e-6 (|v| + L|ω|)`.
    pub const REGULARISATION: f64 = 1e-6;

    /// E* and the step with the default regularisation.
    pub fn new(effective_modulus: f64, steps_per_contact: u32) -> Self {
        CompliantParams {
            effective_modulus,
            steps_per_contact,
            friction_regularisation: Self::REGULARISATION,
        }
    }
}

/// Hunt–Crossley damping α per distinct restitution, calibrated once
/// (each calibration integrates the dimensionless contact ~50 times).
pub fn damping_table(planes: &[Plane]) -> Vec<f64> {
    let mut seen: Vec<(f64, f64)> = Vec::new();
    planes
        .iter()
        .map(|p| {
            let k = p.restitution();
            match seen.iter().find(|(kk, _)| *kk == k) {
                Some(&(_, a)) => a,
                None => {
                    let a = damping_for_restitution(k);
                    seen.push((k, a));
                    a
                }
            }
        })
        .collect()
}

/// Result of a compliant integration.
#[derive(Debug, Clone, PartialEq)]
pub struct CompliantOutcome {
    pub after: State,
    pub energy_before: f64,
    pub energy_after: f64,
    /// Normal impulse ∫F dt per plane (N·s).
    pub impulses: Vec<f64>,
    /// Tangential (friction) impulse per plane, world frame (N·s); zero on
    /// planes with μ = 0.
    pub tangential: Vec<DVec3>,
    pub steps: u64,
    /// Contact duration (s) and the step used.
    pub duration: f64,
    pub step: f64,
    pub max_penetration: f64,
    /// False when the step budget ran out before every contact separated.
    pub separated: bool,
}

/// Why a compliant integration could not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CompliantError {
    #[error("effective_modulus must be finite and > 0, got {0}")]
    Modulus(f64),
    #[error("steps_per_contact must be >= 4, got {0}")]
    Steps(u32),
    #[error("friction_regularisation must be finite and > 0, got {0}")]
    Regularisation(f64),
    #[error("no contact is approaching: nothing to integrate")]
    NoImpact,
}

/// Restitution of the dimensionless Hertz–Hunt–Crossley contact with
/// damping α (fine RK4; exact to about 1e-9).
pub fn restitution_for_damping(alpha: f64) -> f64 {
    let f = |x: f64, v: f64| -> f64 {
        if x <= 0.0 {
            0.0
        } else {
            -x.powf(1.5) * (1.0 + alpha * v).max(0.0)
        }
    };
    let (mut x, mut v) = (0.0f64, 1.0f64);
    let h = 2e-4;
    for _ in 0..1_000_000 {
        let (k1x, k1v) = (v, f(x, v));
        let (k2x, k2v) = (v + 0.5 * h * k1v, f(x + 0.5 * h * k1x, v + 0.5 * h * k1v));
        let (k3x, k3v) = (v + 0.5 * h * k2v, f(x + 0.5 * h * k2x, v + 0.5 * h * k2v));
        let (k4x, k4v) = (v + h * k3v, f(x + h * k3x, v + h * k3v));
        let nx = x + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
        let nv = v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
        if nx <= 0.0 && nv < 0.0 {
            // Linear interpolation of the velocity to the crossing.
            let s = x / (x - nx);
            return -(v + s * (nv - v));
        }
        if nv <= 0.0 && nx <= 0.0 {
            return 0.0;
        }
        x = nx;
        v = nv;
    }
    0.0
}

/// The Hunt–Crossley damping α whose isolated contact rebounds with `k`
/// (bisection on [`restitution_for_damping`], which decreases in α).
pub fn damping_for_restitution(k: f64) -> f64 {
    if k >= 1.0 {
        return 0.0;
    }
    let k = k.max(1e-6);
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    while restitution_for_damping(hi) > k {
        hi *= 4.0;
        if hi > 1e9 {
            return hi;
        }
    }
    for _ in 0..50 {
        let mid = 0.5 * (lo + hi);
        if restitution_for_damping(mid) > k {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[derive(Clone, Copy)]
struct Y {
    x: DVec3,
    q: DQuat,
    v: DVec3,
    w: DVec3,
}

impl Y {
    fn add(&self, d: &Y, h: f64) -> Y {
        Y {
            x: self.x + d.x * h,
            q: DQuat::from_xyzw(
                self.q.x + d.q.x * h,
                self.q.y + d.q.y * h,
                self.q.z + d.q.z * h,
                self.q.w + d.q.w * h,
            ),
            v: self.v + d.v * h,
            w: self.w + d.w * h,
        }
    }
}

struct System<'a> {
    body: &'a Ellipsoid,
    planes: &'a [Plane],
    modulus: f64,
    /// Hunt–Crossley α per plane.
    alpha: Vec<f64>,
    /// Approach speed at first touch per plane (0 until it touches).
    v0: Vec<f64>,
    floor_speed: f64,
}

impl System<'_> {
    /// Normal force magnitude of each plane at state `y`, with δ and δ̇.
    fn forces(&self, y: &Y, out: &mut [f64], geo: &mut Vec<ContactGeometry>) {
        let r = DMat3::from_quat(y.q);
        geo.clear();
        for (i, p) in self.planes.iter().enumerate() {
            let g = ContactGeometry::new(self.body, r, y.x, p);
            let delta = -g.distance;
            let rate = -g.normal_velocity(p, y.v, y.w);
            out[i] = if delta > 0.0 {
                let s = self.body.semi_axes();
                let re = s.x * s.y * s.z / (g.support * g.support);
                let k = 4.0 / 3.0 * self.modulus * re.sqrt();
                // Before the step that records its touch, a contact that
                // entered mid-step uses its current rate (never a tiny floor,
                // which would make the damping explode).
                let v0 = if self.v0[i] > 0.0 {
                    self.v0[i]
                } else {
                    rate.max(self.floor_speed)
                };
                k * delta.powf(1.5) * (1.0 + self.alpha[i] / v0 * rate).max(0.0)
            } else {
                0.0
            };
            geo.push(g);
        }
    }

    fn derivative(&self, y: &Y, f: &mut [f64], geo: &mut Vec<ContactGeometry>) -> Y {
        self.forces(y, f, geo);
        let mut force = DVec3::ZERO;
        let mut torque = DVec3::ZERO;
        for (i, p) in self.planes.iter().enumerate() {
            force += p.normal() * f[i];
            // Body-frame torque of f·u at x*: x* × u f = ρ f.
            torque += geo[i].lever * f[i];
        }
        let j = self.body.inertia();
        let w = y.w;
        let wdot = (torque - w.cross(j * w)) / j;
        // q̇ = ½ q ⊗ (0, ω_body).
        let qd = y.q * DQuat::from_xyzw(w.x, w.y, w.z, 0.0);
        Y {
            x: y.v,
            q: DQuat::from_xyzw(qd.x * 0.5, qd.y * 0.5, qd.z * 0.5, qd.w * 0.5),
            v: force / self.body.mass(),
            w: wdot,
        }
    }
}

/// One rough contact of a friction step: its tangential velocity is the
/// linear map `c_t = P v + K ω` of the velocities, with `P = I − n nᵀ` and
/// `K = −P A [x*]×` (ω in the body frame, `x*` the body-frame support
/// point).
struct Rough {
    plane: usize,
    /// `μ Δp`: the friction bound of this step's normal impulse (N·s).
    bound: f64,
    p: DMat3,
    k: DMat3,
    /// Orthonormal tangent basis and the eigen-decomposition of the
    /// contact's tangential Delassus block in it: `W e_j = w_j e_j`.
    e: [DVec3; 2],
    w: [f64; 2],
    /// The impulse of this step so far (world, tangential).
    f: DVec3,
}

impl Rough {
    fn velocity(&self, v: DVec3, w: DVec3) -> DVec3 {
        self.p * v + self.k * w
    }
}

/// The friction impulse of one contact alone, by backward Euler: the
/// `f = −a c / sqrt(|c|² + ε²)` with `c = c₀ + W f`, where `c₀` is the
/// contact's tangential velocity without its own impulse. Then
/// `c = (I + (a/s) W)⁻¹ c₀` with `s = sqrt(|c|² + ε²)`, a scalar equation
/// `φ(s) = sqrt(|c(s)|² + ε²) − s = 0` on `[ε, sqrt(|c₀|² + ε²)]`, where φ
/// changes sign and has one root (the contact's step minimises a strictly
/// convex function). Newton's method on φ, kept inside the bracket by
/// bisection in `ln s`, finds it to rounding.
fn rough_contact(r: &Rough, c0: DVec3, e2: f64) -> DVec3 {
    let a = r.bound;
    let alpha = [r.e[0].dot(c0), r.e[1].dot(c0)];
    // c_j(s) = α_j s / (s + a w_j), and φ and φ′ at s.
    let eval = |s: f64| -> (f64, f64, [f64; 2]) {
        let mut c = [0.0; 2];
        let mut dc2 = 0.0;
        for j in 0..2 {
            let d = s + a * r.w[j];
            c[j] = alpha[j] * s / d;
            dc2 += 2.0 * c[j] * alpha[j] * a * r.w[j] / (d * d);
        }
        let root = (c[0] * c[0] + c[1] * c[1] + e2).sqrt();
        (root - s, dc2 / (2.0 * root) - 1.0, c)
    };
    let (mut lo, mut hi) = (
        e2.sqrt(),
        (alpha[0] * alpha[0] + alpha[1] * alpha[1] + e2).sqrt(),
    );
    let (phi_hi, _, _) = eval(hi);
    if phi_hi >= 0.0 {
        // W does not contract c₀ (no impulse can move this contact).
        return DVec3::ZERO;
    }
    let mut s = hi;
    for _ in 0..200 {
        let (phi, dphi, _) = eval(s);
        if phi >= 0.0 {
            lo = s;
        } else {
            hi = s;
        }
        if phi == 0.0 || hi - lo <= 4.0 * f64::EPSILON * hi {
            break;
        }
        let newton = s - phi / dphi;
        s = if newton > lo && newton < hi && dphi < 0.0 {
            newton
        } else {
            (lo * hi).sqrt()
        };
        if (s - lo).min(hi - s) <= f64::EPSILON * s {
            // The bracket cannot be split further at this precision.
            break;
        }
    }
    let (_, _, c) = eval(s);
    let ct = r.e[0] * c[0] + r.e[1] * c[1];
    -ct * (a / s)
}

/// The backward-Euler friction impulse of one step: `y`'s velocities move
/// to the minimiser of `½|u − u*|²_M + Σ μ_i Δp_i sqrt(|c_t,i|² + ε²)`,
/// whose optimality condition is `M (u − u*) = Σ B_iᵀ f_i` with
/// `f_i = −μ_i Δp_i c_t,i / sqrt(|c_t,i|² + ε²)` at the new velocities.
/// Each contact's impulse is solved exactly with the others held
/// ([`rough_contact`]); with several rough contacts these block visits
/// sweep (Gauss–Seidel, which converges on this strictly convex problem)
/// until no impulse moves by more than 1e-13 of its bound, at most 1 000
/// sweeps. The velocities always move by exactly the impulses reported.
fn friction_step(
    body: &Ellipsoid,
    planes: &[Plane],
    y: &mut Y,
    step_impulse: &[f64],
    epsilon: f64,
    tangential: &mut [DVec3],
) {
    let r = DMat3::from_quat(y.q);
    let m = body.mass();
    let inv_j = body.inertia().recip();
    let mut rough: Vec<Rough> = planes
        .iter()
        .enumerate()
        .filter(|(i, p)| p.friction() > 0.0 && step_impulse[*i] > 0.0)
        .map(|(i, p)| {
            let g = ContactGeometry::new(body, r, y.x, p);
            let n = p.normal();
            let proj = DMat3::IDENTITY - DMat3::from_cols(n * n.x, n * n.y, n * n.z);
            let k = -(proj * r * skew(g.body_point));
            // W = P/m + K J⁻¹ Kᵀ on the tangent plane.
            let w3 = proj * (1.0 / m) + k * DMat3::from_diagonal(inv_j) * k.transpose();
            let t1 = n.any_orthonormal_vector();
            let t2 = n.cross(t1);
            let (w11, w12, w22) = (t1.dot(w3 * t1), t1.dot(w3 * t2), t2.dot(w3 * t2));
            // Eigen-decomposition of the symmetric 2×2 block.
            let half = 0.5 * (w11 - w22);
            let root = half.hypot(w12);
            let mean = 0.5 * (w11 + w22);
            let angle = 0.5 * w12.atan2(half);
            let (sn, cs) = angle.sin_cos();
            Rough {
                plane: i,
                bound: p.friction() * step_impulse[i],
                p: proj,
                k,
                e: [t1 * cs + t2 * sn, t2 * cs - t1 * sn],
                w: [mean + root, (mean - root).max(0.0)],
                f: DVec3::ZERO,
            }
        })
        .collect();
    if rough.is_empty() {
        return;
    }
    let e2 = epsilon * epsilon;
    let (mut v, mut w) = (y.v, y.w);
    let sweeps = if rough.len() == 1 { 1 } else { 1000 };
    for _ in 0..sweeps {
        let mut moved = 0.0f64;
        for c in rough.iter_mut() {
            // The contact's velocity without its own impulse.
            let w_f = c.f / m + c.k * (inv_j * (c.k.transpose() * c.f));
            let c0 = c.velocity(v, w) - c.p * w_f;
            let f = rough_contact(c, c0, e2);
            let df = f - c.f;
            v += df / m;
            w += inv_j * (c.k.transpose() * df);
            c.f = f;
            moved = moved.max(df.length() / c.bound);
        }
        if moved <= 1e-13 {
            break;
        }
    }
    for c in &rough {
        tangential[c.plane] += c.f;
    }
    y.v = v;
    y.w = w;
}

/// Integrates the compliant impact of `body` at `pose` with velocities
/// `state` against `planes` until every contact has separated.
pub fn solve_compliant(
    body: &Ellipsoid,
    pose: Pose,
    state: State,
    planes: &[Plane],
    params: CompliantParams,
) -> Result<CompliantOutcome, CompliantError> {
    solve_compliant_with(body, pose, state, planes, params, &damping_table(planes))
}

/// [`solve_compliant`] with the damping of each plane precomputed by
/// [`damping_table`] (what a loop over many samples should call).
pub fn solve_compliant_with(
    body: &Ellipsoid,
    pose: Pose,
    state: State,
    planes: &[Plane],
    params: CompliantParams,
    alpha: &[f64],
) -> Result<CompliantOutcome, CompliantError> {
    if !(params.effective_modulus.is_finite() && params.effective_modulus > 0.0) {
        return Err(CompliantError::Modulus(params.effective_modulus));
    }
    if params.steps_per_contact < 4 {
        return Err(CompliantError::Steps(params.steps_per_contact));
    }
    if !(params.friction_regularisation.is_finite() && params.friction_regularisation > 0.0) {
        return Err(CompliantError::Regularisation(
            params.friction_regularisation,
        ));
    }
    let energy_before = kinetic_energy(body, state.velocity, state.omega);
    // The leading contact: the fastest approaching one among those touching.
    let mut lead: Option<(f64, f64)> = None; // (speed, effective mass)
    let s = body.semi_axes();
    for p in planes {
        let g = ContactGeometry::new(body, pose.rotation, pose.centre, p);
        let vn = g.normal_velocity(p, state.velocity, state.omega);
        if g.distance <= 1e-9 * body.length_scale() && vn < 0.0 {
            let inv_m = 1.0 / body.mass() + (g.lever * g.lever / body.inertia()).element_sum();
            let speed = -vn;
            if lead.is_none_or(|(sp, _)| speed > sp) {
                lead = Some((speed, 1.0 / inv_m));
            }
        }
    }
    let (v_lead, m_eff) = lead.ok_or(CompliantError::NoImpact)?;
    // Hertz contact duration of the leading contact with R_e of its start.
    let k_est = 4.0 / 3.0 * params.effective_modulus * (s.x * s.y * s.z).sqrt() / s.max_element();
    let length = (m_eff * v_lead * v_lead / k_est).powf(0.4);
    let duration_est = 2.94 * length / v_lead;
    let h = duration_est / params.steps_per_contact as f64;

    let mut sys = System {
        body,
        planes,
        modulus: params.effective_modulus,
        alpha: alpha.to_vec(),
        v0: vec![0.0; planes.len()],
        floor_speed: 1e-6 * v_lead,
    };
    let mut y = Y {
        x: pose.centre,
        q: DQuat::from_mat3(&pose.rotation).normalize(),
        v: state.velocity,
        w: state.omega,
    };
    let n = planes.len();
    let mut impulses = vec![0.0; n];
    let mut tangential = vec![DVec3::ZERO; n];
    let rough = planes.iter().any(|p| p.friction() > 0.0);
    let vscale = state.velocity.length() + body.length_scale() * state.omega.length();
    let epsilon = params.friction_regularisation * vscale;
    let mut step_impulse = vec![0.0; n];
    let (mut f1, mut f2, mut f3, mut f4) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let mut geo = Vec::with_capacity(n);
    let mut max_pen = 0.0f64;
    let max_steps = 200 * params.steps_per_contact as u64;
    let mut steps = 0;
    let mut separated = false;
    while steps < max_steps {
        // Record the approach speed of contacts touching for the first time.
        {
            let r = DMat3::from_quat(y.q);
            for (i, p) in planes.iter().enumerate() {
                if sys.v0[i] == 0.0 {
                    let g = ContactGeometry::new(body, r, y.x, p);
                    let vn = g.normal_velocity(p, y.v, y.w);
                    if g.distance <= 1e-9 * body.length_scale() && vn < 0.0 {
                        sys.v0[i] = -vn;
                    }
                }
            }
        }
        let k1 = sys.derivative(&y, &mut f1, &mut geo);
        let k2 = sys.derivative(&y.add(&k1, 0.5 * h), &mut f2, &mut geo);
        let k3 = sys.derivative(&y.add(&k2, 0.5 * h), &mut f3, &mut geo);
        let k4 = sys.derivative(&y.add(&k3, h), &mut f4, &mut geo);
        let d = k1.add(&k2, 2.0).add(&k3, 2.0).add(&k4, 1.0);
        y = y.add(&d, h / 6.0);
        y.q = y.q.normalize();
        for i in 0..n {
            step_impulse[i] = h / 6.0 * (f1[i] + 2.0 * f2[i] + 2.0 * f3[i] + f4[i]);
            impulses[i] += step_impulse[i];
        }
        if rough {
            friction_step(
                body,
                planes,
                &mut y,
                &step_impulse,
                epsilon,
                &mut tangential,
            );
        }
        steps += 1;
        // Separated: no plane penetrated and none approaching.
        let r = DMat3::from_quat(y.q);
        let mut done = true;
        for p in planes {
            let g = ContactGeometry::new(body, r, y.x, p);
            max_pen = max_pen.max(-g.distance);
            if g.distance < 0.0 || g.normal_velocity(p, y.v, y.w) < 0.0 && g.distance <= 0.0 {
                done = false;
            }
        }
        if done {
            separated = true;
            break;
        }
    }
    let after = State {
        velocity: y.v,
        omega: y.w,
    };
    Ok(CompliantOutcome {
        energy_after: kinetic_energy(body, after.velocity, after.omega),
        after,
        energy_before,
        impulses,
        tangential,
        steps,
        duration: steps as f64 * h,
        step: h,
        max_penetration: max_pen,
        separated,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn damping_matches_restitution() {
        assert!((restitution_for_damping(0.0) - 1.0).abs() < 1e-6);
        for k in [0.1, 0.5, 0.8, 0.95] {
            let a = damping_for_restitution(k);
            assert!((restitution_for_damping(a) - k).abs() < 1e-6, "k {k}");
        }
        // Hunt–Crossley's own estimate α ≈ 3(1 − k)/2 holds near k = 1.
        let a = damping_for_restitution(0.98);
        assert!((a / (1.5 * 0.02) - 1.0).abs() < 0.05, "α {a}");
    }
}
