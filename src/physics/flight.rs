//! Free flight between impacts, physics only: the centre follows a
//! parabola under gravity and the body rotates torque-free (the paper's
//! Euler equations, eq. 3). Time of impact with a set of planes is found by
//! conservative advancement, which never steps past a contact.
//!
//! - Axisymmetric bodies (a = b, so J₁ = J₂) have the exact closed form of
//!   regular precession: `R(t) = exp(α t [L̂]×) R₀ exp(β t [e₃]×)` with
//!   `α = |L|/J₁`, `β = ω₃ − α l₃` (l = L in the body frame, unit),
//!   because then `Ṙ = R [α l + β e₃]×` and `α l + β e₃` is the body
//!   angular velocity of momentum L.
//! - Triaxial bodies follow the exact solution in Jacobi elliptic functions
//!   ([`TorqueFree`]), or, when asked for, classical RK4 on (q, ω) at a
//!   fixed step (energy and angular momentum drift at fourth order).
//!
//! With a closed form the time of impact jumps: every pose is evaluated from
//! the flight's start, and the flight starts where the body's bounding
//! sphere first comes within the tolerance of a plane.

use glam::{DMat3, DVec3};

use super::torque_free::{rk4_rotation, TorqueFree};
use super::{ContactGeometry, Ellipsoid, Plane};

/// Position, orientation and velocities of a body in flight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    pub centre: DVec3,
    /// Body → world.
    pub rotation: DMat3,
    /// World frame (m/s).
    pub velocity: DVec3,
    /// Body frame (rad/s).
    pub omega: DVec3,
}

/// How rotation is advanced.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Rotation {
    /// Exact regular precession (requires a = b).
    Precession,
    /// The exact solution in Jacobi elliptic functions (any body).
    Elliptic,
    /// RK4 on quaternion and ω with at most this step (s).
    Rk4 { max_step: f64 },
}

impl Rotation {
    /// The exact closed form for the body: regular precession for a = b,
    /// the elliptic solution otherwise.
    pub fn exact_for(body: &Ellipsoid) -> Self {
        let s = body.semi_axes();
        if s.x == s.y {
            Rotation::Precession
        } else {
            Rotation::Elliptic
        }
    }

    /// Regular precession for a = b, else RK4 with at most `max_step`.
    pub fn for_body(body: &Ellipsoid, max_step: f64) -> Self {
        match Self::exact_for(body) {
            Rotation::Precession => Rotation::Precession,
            _ => Rotation::Rk4 { max_step },
        }
    }

    /// "precession", "elliptic" or "rk4".
    pub fn name(self) -> &'static str {
        match self {
            Rotation::Precession => "precession",
            Rotation::Elliptic => "elliptic",
            Rotation::Rk4 { .. } => "rk4",
        }
    }
}

fn axis_angle(axis: DVec3, angle: f64) -> DMat3 {
    if angle == 0.0 || axis == DVec3::ZERO {
        DMat3::IDENTITY
    } else {
        DMat3::from_axis_angle(axis.normalize(), angle)
    }
}

/// Torque-free rotation of an axisymmetric body (J₁ = J₂) over `t`.
pub fn precess(body: &Ellipsoid, rotation: DMat3, omega: DVec3, t: f64) -> (DMat3, DVec3) {
    let j = body.inertia();
    let l_body = j * omega;
    let l_norm = l_body.length();
    if l_norm == 0.0 {
        return (rotation, omega);
    }
    let l_world = rotation * l_body;
    let alpha = l_norm / j.x;
    let beta = omega.z - alpha * l_body.z / l_norm;
    let r = axis_angle(l_world, alpha * t) * rotation * axis_angle(DVec3::Z, beta * t);
    // ω₃ is constant; (ω₁, ω₂) turns by Ω t with Ω = (J₃ − J₁) ω₃ / J₁.
    let big_omega = (j.z - j.x) * omega.z / j.x;
    let (s, c) = (big_omega * t).sin_cos();
    let w = DVec3::new(
        omega.x * c - omega.y * s,
        omega.x * s + omega.y * c,
        omega.z,
    );
    (r, w)
}

/// The motion `t` seconds later: a parabola under `gravity` (world vector,
/// m/s²) and torque-free rotation.
pub fn advance(body: &Ellipsoid, m: &Motion, gravity: DVec3, rotation: Rotation, t: f64) -> Motion {
    let (r, w) = match rotation {
        Rotation::Precession => precess(body, m.rotation, m.omega, t),
        Rotation::Elliptic => TorqueFree::new(body.inertia(), m.rotation, m.omega).at(t),
        Rotation::Rk4 { max_step } => rk4_rotation(body, m.rotation, m.omega, t, max_step),
    };
    Motion {
        centre: m.centre + m.velocity * t + gravity * (0.5 * t * t),
        rotation: r,
        velocity: m.velocity + gravity * t,
        omega: w,
    }
}

/// A time of impact.
#[derive(Debug, Clone, PartialEq)]
pub struct Impact {
    /// Time from the start of the flight (s).
    pub time: f64,
    pub motion: Motion,
    /// Signed distance of every plane at that moment (m).
    pub distances: Vec<f64>,
    /// Conservative-advancement iterations used.
    pub iterations: u32,
}

/// The first time within `horizon` at which some plane's distance falls to
/// `tolerance` (m), by conservative advancement: each step is the smallest
/// distance divided by a bound on how fast any distance can shrink
/// (|v·n| plus gravity over the step plus |ω|(a − c)), or by a second-order
/// bound from the actual rate, so no step passes a contact. With a closed-form
/// rotation the search starts where the bounding sphere first comes within
/// `tolerance` of a plane. `None` if no contact within the horizon.
pub fn time_of_impact(
    body: &Ellipsoid,
    start: &Motion,
    planes: &[Plane],
    gravity: DVec3,
    rotation: Rotation,
    tolerance: f64,
    horizon: f64,
) -> Option<Impact> {
    // |ω| is bounded over the whole flight by what the conserved energy and
    // momentum allow ([`spin_bound`]).
    let j = body.inertia();
    let w_bound = spin_bound(j, start.omega);
    // |dh/dt| ≤ (a − c)|ω| and |d²h/dt²| ≤ |ω|² a²/c + a|ω|² + (a − c)|ω̇|
    // for the support distance h (a, c the largest and smallest semi-axes:
    // a − c is the largest offset of the support point from the normal
    // through the centre; |ω̇| from Euler's equations).
    let semi = body.semi_axes();
    let (a_max, a_min) = (semi.max_element(), semi.min_element());
    let reach = a_max;
    let offset = a_max - a_min;
    let j_spread = (j.max_element() - j.min_element()) / j.min_element();
    let w2 = w_bound * w_bound;
    let curvature = w2 * a_max * a_max / a_min + a_max * w2 + offset * w2 * j_spread;
    // A closed form evaluates every pose from the start; RK4 steps on from
    // the last pose.
    let elliptic = (rotation == Rotation::Elliptic)
        .then(|| TorqueFree::new(body.inertia(), start.rotation, start.omega));
    let closed = !matches!(rotation, Rotation::Rk4 { .. });
    let pose_at = |t: f64| -> Motion {
        let (r, w) = match &elliptic {
            Some(tf) => tf.at(t),
            None => precess(body, start.rotation, start.omega, t),
        };
        Motion {
            centre: start.centre + start.velocity * t + gravity * (0.5 * t * t),
            rotation: r,
            velocity: start.velocity + gravity * t,
            omega: w,
        }
    };
    let mut t = 0.0;
    if closed {
        t = sphere_clearance(reach, start, planes, gravity, tolerance).min(horizon);
    }
    let mut m = if t > 0.0 { pose_at(t) } else { *start };
    // A plane the body starts on and leaves (just after an impact) is not an
    // impact; it is armed again once clear of the tolerance, and an impact
    // if it turns back toward the body while still within it.
    // (A bit per plane: no allocation per flight.)
    assert!(planes.len() <= 64, "at most 64 planes in flight");
    let mut armed = planes.iter().enumerate().fold(0u64, |bits, (i, p)| {
        let g = ContactGeometry::new(body, m.rotation, m.centre, p);
        let on = g.distance > tolerance || g.normal_velocity(p, m.velocity, m.omega) < 0.0;
        bits | (on as u64) << i
    });
    for iterations in 0..100_000u32 {
        let mut hit = false;
        // Each plane bounds its own step: its gap closes at most at
        // max(0, −n·v) + |ω|(a − c), plus max(0, −n·g) t (gravity along the
        // wall's normal only), so a plane the body moves away from does not
        // hold the others back.
        let mut dt = f64::INFINITY;
        for (i, p) in planes.iter().enumerate() {
            let g = ContactGeometry::new(body, m.rotation, m.centre, p);
            if g.distance > tolerance {
                armed |= 1 << i;
            }
            let gap = if armed >> i & 1 == 1 {
                hit |= g.distance <= tolerance;
                g.distance - 0.5 * tolerance
            } else {
                hit |= g.normal_velocity(p, m.velocity, m.omega) < 0.0;
                // It may dip at most one tolerance below zero before it is
                // caught: within contact_tolerance, so it impacts then.
                g.distance + tolerance
            }
            .max(0.0);
            let n = p.normal();
            let s = (-n.dot(m.velocity)).max(0.0) + w_bound * offset;
            let acc = (-n.dot(gravity)).max(0.0);
            // Largest dt with (s + acc·dt)·dt ≤ gap.
            let linear = if acc > 0.0 {
                2.0 * gap / (s + (s * s + 4.0 * acc * gap).sqrt())
            } else if s > 0.0 {
                gap / s
            } else {
                f64::INFINITY
            };
            // Second bound, from the gap's actual rate ḋ = v_n (the support
            // point's normal velocity) and a bound on its second derivative:
            // d(t+τ) ≥ d − c τ − ½ B τ² with c = −ḋ of either sign (a plane
            // the body is leaving allows the time it takes to turn back).
            // Near contact it converges like Newton's method. Either bound
            // alone is safe, so the larger step is.
            let c = -g.normal_velocity(p, m.velocity, m.omega);
            let b = acc + curvature;
            let root = (c * c + 2.0 * b * gap).sqrt();
            let quadratic = if c >= 0.0 {
                2.0 * gap / (c + root)
            } else if b > 0.0 {
                (root - c) / b
            } else {
                f64::INFINITY
            };
            dt = dt.min(linear.max(quadratic));
        }
        if hit {
            return Some(Impact {
                time: t,
                motion: m,
                distances: planes
                    .iter()
                    .map(|p| ContactGeometry::new(body, m.rotation, m.centre, p).distance)
                    .collect(),
                iterations,
            });
        }
        if t >= horizon || !dt.is_finite() && horizon.is_infinite() {
            return None;
        }
        let dt = dt.min(horizon - t).max(0.0);
        if closed {
            t += dt;
            m = pose_at(t);
        } else {
            m = advance(body, &m, gravity, rotation, dt);
            t += dt;
        }
    }
    None
}

/// Steps [`contact_near`] takes at most.
pub const CONTACT_STEPS: u32 = 40;

/// The contact next to `t0` of a flight from `start` (centre on its
/// parabola under `gravity`, attitude and body spin `attitude(t)`, `None`
/// where it cannot say), until the signed distance of the nearest plane
/// that can be hit is within `tolerance` of zero. A plane can be hit if it
/// is beyond `slack` (at least `tolerance`: how well the distances are
/// known) or closing, as [`time_of_impact`] arms them; so a plane the body
/// is leaving (the last impact's) is not taken for the contact. For a
/// search that stopped near a contact it could not resolve (f32 lanes stop
/// up to 256 ulp of the body short of it): the impact then happens at
/// contact, to `tolerance`.
///
/// Newton's method on that distance, whose rate is the support point's
/// normal velocity, safeguarded by bisection: once a time before the
/// contact (every plane that can be hit beyond `tolerance`, or none that
/// can) and one after it (the nearest below −`tolerance`) are known, a
/// Newton step that leaves them is replaced by their midpoint.
///
/// `None` (the flight is then flown again by the reference) where the
/// nearest plane is not closing and no time after the contact is known (a
/// graze), some plane is penetrated beyond `slack` and opening (a contact
/// passed), the time leaves `[0, horizon]` or `attitude` cannot say, or
/// [`CONTACT_STEPS`] steps do not converge. Also returns the steps taken.
#[allow(clippy::too_many_arguments)]
pub fn contact_near(
    body: &Ellipsoid,
    start: &Motion,
    planes: &[Plane],
    gravity: DVec3,
    mut attitude: impl FnMut(f64) -> Option<(DMat3, DVec3)>,
    t0: f64,
    (tolerance, slack): (f64, f64),
    horizon: f64,
) -> Option<(f64, Motion, u32)> {
    let mut t = t0;
    let (mut before, mut after) = (f64::NEG_INFINITY, f64::INFINITY);
    for steps in 1..=CONTACT_STEPS {
        let (rotation, omega) = attitude(t)?;
        let m = Motion {
            centre: start.centre + start.velocity * t + gravity * (0.5 * t * t),
            rotation,
            velocity: start.velocity + gravity * t,
            omega,
        };
        let (mut d, mut rate) = (f64::INFINITY, 0.0);
        for p in planes {
            let g = ContactGeometry::new(body, m.rotation, m.centre, p);
            let v = g.normal_velocity(p, m.velocity, m.omega);
            if g.distance < -slack && v >= 0.0 {
                return None;
            }
            let live = g.distance > slack || v < 0.0;
            if live && g.distance < d {
                (d, rate) = (g.distance, v);
            }
        }
        if d.abs() <= tolerance && rate < 0.0 {
            return Some((t, m, steps));
        }
        if d > tolerance {
            before = before.max(t);
        } else if d < -tolerance {
            after = after.min(t);
        }
        let newton = t - d / rate;
        t = if rate < 0.0 && d.is_finite() && newton > before && newton < after {
            newton
        } else if before.is_finite() && after.is_finite() {
            0.5 * (before + after)
        } else {
            return None;
        };
        if !(0.0..=horizon).contains(&t) {
            return None;
        }
    }
    None
}

/// Torque-free attitude and body spin `dt` on from (`rotation`, `omega`),
/// to second order in the turn |ω dt|: the body-frame rotation vector
/// ω dt + ω̇ dt²/2 and the spin ω + ω̇ dt + ω̈ dt²/2 from Euler's equations
/// (J ω̇ = (J ω) × ω). Its error is of the order of the turn cubed (rad).
pub fn short_turn(body: &Ellipsoid, rotation: DMat3, omega: DVec3, dt: f64) -> (DMat3, DVec3) {
    let j = body.inertia();
    let w_dot = (j * omega).cross(omega) / j;
    let w_ddot = ((j * w_dot).cross(omega) + (j * omega).cross(w_dot)) / j;
    let th = (omega + w_dot * (0.5 * dt)) * dt;
    let t2 = th.length_squared();
    // Rodrigues, I + (sin θ/θ) K + ((1 − cos θ)/θ²) K², K = [θ]×: for a
    // short turn (θ ≤ 0.02) the series to θ⁴ are exact in f64.
    let (a, b) = if t2 <= 4e-4 {
        (
            1.0 - t2 / 6.0 * (1.0 - t2 / 20.0),
            0.5 - t2 / 24.0 * (1.0 - t2 / 30.0),
        )
    } else {
        let t = t2.sqrt();
        let (sin, cos) = t.sin_cos();
        (sin / t, (1.0 - cos) / t2)
    };
    let k = DMat3::from_cols(
        DVec3::new(0.0, th.z, -th.y),
        DVec3::new(-th.z, 0.0, th.x),
        DVec3::new(th.y, -th.x, 0.0),
    );
    let turn = DMat3::IDENTITY + k * a + k * k * b;
    (rotation * turn, omega + (w_dot + w_ddot * (0.5 * dt)) * dt)
}

/// A torque-free attitude carried from a known one by [`short_turn`]s of at
/// most `step` rad each, up to `most` rad away: for locating an impact near
/// a pose known only there (an f32 lane's). Each evaluation starts from the
/// known pose, so its error depends on how far it is, not on the
/// evaluations before it: about a sixth of a step's cube per step.
#[derive(Debug, Clone, Copy)]
pub struct Carried {
    t: f64,
    rotation: DMat3,
    omega: DVec3,
    step: f64,
    most: f64,
}

impl Carried {
    /// From (`rotation`, `omega`) at time `t`.
    pub fn new(t: f64, rotation: DMat3, omega: DVec3, step: f64, most: f64) -> Self {
        Self {
            t,
            rotation,
            omega,
            step,
            most,
        }
    }

    /// The attitude and body spin at `t`; `None` past `most`.
    pub fn at(&self, body: &Ellipsoid, t: f64) -> Option<(DMat3, DVec3)> {
        let dt = t - self.t;
        let turn = self.omega.length() * dt.abs();
        if turn > self.most {
            return None;
        }
        let n = (turn / self.step).ceil().max(1.0);
        let h = dt / n;
        let (mut r, mut w) = (self.rotation, self.omega);
        for _ in 0..n as usize {
            (r, w) = short_turn(body, r, w, h);
        }
        Some((r, w))
    }
}

/// The first time the body's bounding sphere (radius `reach` about the
/// centre) comes within `tolerance` of some plane: before it no plane can be
/// within the tolerance, whatever the rotation. Zero if the sphere is that
/// close at the start; infinite if it never is.
pub fn sphere_clearance(
    reach: f64,
    start: &Motion,
    planes: &[Plane],
    gravity: DVec3,
    tolerance: f64,
) -> f64 {
    let mut first = f64::INFINITY;
    for p in planes {
        let n = p.normal();
        // Gap of the sphere: g(t) = g0 + v t + ½ a t², first root g = 0.
        let g0 = p.signed_distance(start.centre) - reach - tolerance;
        if g0 <= 0.0 {
            return 0.0;
        }
        let v = n.dot(start.velocity);
        let a = n.dot(gravity);
        let root = if a == 0.0 {
            if v < 0.0 {
                -g0 / v
            } else {
                f64::INFINITY
            }
        } else {
            // ½a t² + v t + g0 = 0: the smallest positive root, from the
            // two forms without cancellation.
            let disc = v * v - 2.0 * a * g0;
            if disc < 0.0 {
                f64::INFINITY
            } else {
                let sign = if v >= 0.0 { 1.0 } else { -1.0 };
                let q = -0.5 * (v + sign * disc.sqrt());
                [q / (0.5 * a), g0 / q]
                    .into_iter()
                    .filter(|r| *r > 0.0 && r.is_finite())
                    .fold(f64::INFINITY, f64::min)
            }
        };
        // Rounding: stop a little early (the advancement finishes the way).
        first = first.min(root * (1.0 - 1e-12));
    }
    first
}

/// The largest |ω| a torque-free body can reach from `omega`: the maximum
/// of Σωᵢ² under the two conserved quantities Σ Jᵢωᵢ² = 2T and
/// Σ Jᵢ²ωᵢ² = M², a linear programme in ωᵢ² whose optimum has at most two
/// non-zero terms. With a relative margin of 1e-6 (RK4 keeps T and M only
/// to its error), and never above the energy bound √(2T/J_min).
pub fn spin_bound(j: DVec3, omega: DVec3) -> f64 {
    let w2 = omega * omega;
    let two_t = (j * w2).element_sum();
    let m2 = (j * j * w2).element_sum();
    let energy = two_t / j.min_element();
    let (j, mut best) = (j.to_array(), w2.element_sum());
    for (a, b) in [(0, 1), (0, 2), (1, 2)] {
        let det = j[a] * j[b] * (j[b] - j[a]);
        if det == 0.0 {
            // Equal moments act as one variable, which the other pairs
            // cover (a sphere keeps |ω|).
            continue;
        }
        let xa = (two_t * j[b] * j[b] - m2 * j[b]) / det;
        let xb = (m2 * j[a] - two_t * j[a] * j[a]) / det;
        if xa >= -1e-12 * energy && xb >= -1e-12 * energy {
            best = best.max(xa.max(0.0) + xb.max(0.0));
        }
    }
    (best.min(energy) * (1.0 + 1e-6)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Over long exact trajectories |ω| never exceeds the bound, comes
    /// within 1 % of it (it is the orbit's maximum, not only a bound; a
    /// steady spin excepted), and
    /// the bound never exceeds the energy bound.
    #[test]
    fn spin_bound_is_the_orbits_maximum() {
        for semi in [
            [0.5, 0.3, 0.2],
            [0.03, 0.02, 0.01],
            [0.2, 0.5, 0.3],
            [0.4, 0.4, 0.1],
        ] {
            let body = Ellipsoid::new(semi, 3.0).unwrap();
            let j = body.inertia();
            for w0 in [
                DVec3::new(1.0, 2.0, 3.0),
                DVec3::new(3.0, 0.2, 0.4),
                DVec3::new(0.01, -2.5, 1e-3),
                DVec3::new(0.0, 0.0, 5.0),
            ] {
                let bound = spin_bound(j, w0);
                let energy = ((j * w0 * w0).element_sum() / j.min_element()).sqrt();
                assert!(bound <= energy * (1.0 + 1e-6), "{semi:?} {w0}");
                let tf = TorqueFree::new(j, DMat3::IDENTITY, w0);
                let mut most = 0f64;
                for k in 0..20_000 {
                    most = most.max(tf.at(k as f64 * 1e-3).1.length());
                }
                assert!(most <= bound, "{semi:?} {w0}: {most} > {bound}");
                // A steady spin about the middle axis stays put, though the
                // separatrix through it reaches the bound.
                let steady = w0.x == 0.0 && w0.y == 0.0;
                assert!(
                    steady || most >= 0.99 * bound,
                    "{semi:?} {w0}: {most} vs {bound}"
                );
            }
        }
    }
}
