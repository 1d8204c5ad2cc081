//! An independent check of the one-contact impulse: a stiff
//! frictionless linear spring–dashpot contact, integrated with RK4 through the
//! impact together with the full rigid-body motion (rotation during contact,
//! the contact point moving over the surface), converges to the closed-form
//! rigid law as the stiffness grows.
//!
//! The compliant model here is written from first principles and shares no
//! code with `impactmc::physics` except the body's validated constructor.
//! The damping ratio is chosen so that a linear oscillator of the initial
//! effective mass rebounds with exactly `k`: `ζ = −ln k / √(π² + ln² k)`.
//!
//! Run `cargo test --release --test it compliant_convergence -- --nocapture` to
//! print the convergence table quoted in the README.

use glam::{DMat3, DQuat, DVec3};
use impactmc::physics::{
    matrix_from_bryan, solve_impact, Bryan, Ellipsoid, Law, Plane, Pose, State,
};

#[derive(Clone, Copy)]
struct Rigid {
    x: DVec3,
    q: DQuat,
    v: DVec3,
    w: DVec3, // body frame
}

struct Contact {
    semi: DVec3,
    inertia: DVec3,
    mass: f64,
    n: DVec3,
    e: f64,
    stiffness: f64,
    damping: f64,
}

impl Contact {
    /// Penetration δ, its rate, and the body-frame support point.
    fn penetration(&self, s: &Rigid) -> (f64, f64, DVec3) {
        let a = DMat3::from_quat(s.q);
        let u = a.transpose() * self.n;
        let d2u = self.semi * self.semi * u;
        let h = (self.semi * u).length();
        let xs = -d2u / h;
        let delta = h - self.n.dot(s.x) - self.e;
        // The material point at x* moves with v + A(ω × x*); δ̇ = −n·that.
        let vp = s.v + a * s.w.cross(xs);
        (delta, -self.n.dot(vp), xs)
    }

    fn derivative(&self, s: &Rigid) -> Rigid {
        let (delta, rate, xs) = self.penetration(s);
        // The whole integration runs inside the contact phase, which ends
        // exactly at δ = 0 (located by bisection below), so the linear law
        // applies throughout.
        let force = self.stiffness * delta + self.damping * rate;
        let a = DMat3::from_quat(s.q);
        let u = a.transpose() * self.n;
        let torque = xs.cross(u * force);
        let jw = self.inertia * s.w;
        Rigid {
            x: s.v,
            q: s.q * DQuat::from_xyzw(0.5 * s.w.x, 0.5 * s.w.y, 0.5 * s.w.z, 0.0),
            v: self.n * (force / self.mass),
            w: (torque - s.w.cross(jw)) / self.inertia,
        }
    }
}

fn axpy(s: &Rigid, d: &Rigid, h: f64) -> Rigid {
    Rigid {
        x: s.x + d.x * h,
        q: s.q + d.q * h,
        v: s.v + d.v * h,
        w: s.w + d.w * h,
    }
}

fn rk4(c: &Contact, s: &Rigid, h: f64) -> Rigid {
    let k1 = c.derivative(s);
    let k2 = c.derivative(&axpy(s, &k1, h / 2.0));
    let k3 = c.derivative(&axpy(s, &k2, h / 2.0));
    let k4 = c.derivative(&axpy(s, &k3, h));
    let mut out = Rigid {
        x: s.x + (k1.x + k2.x * 2.0 + k3.x * 2.0 + k4.x) * (h / 6.0),
        q: s.q + (k1.q + k2.q * 2.0 + k3.q * 2.0 + k4.q) * (h / 6.0),
        v: s.v + (k1.v + k2.v * 2.0 + k3.v * 2.0 + k4.v) * (h / 6.0),
        w: s.w + (k1.w + k2.w * 2.0 + k3.w * 2.0 + k4.w) * (h / 6.0),
    };
    out.q = out.q.normalize();
    out
}

/// Integrates one impact with contact duration ≈ `duration` (s); returns
/// the post-impact (v, ω).
fn compliant_impact(
    body: &Ellipsoid,
    start: Rigid,
    n: DVec3,
    k: f64,
    g: f64,
    duration: f64,
) -> (DVec3, DVec3) {
    let zeta = if k > 0.0 {
        -k.ln() / (std::f64::consts::PI.powi(2) + k.ln().powi(2)).sqrt()
    } else {
        1.0
    };
    let omega_d = std::f64::consts::PI / duration;
    let omega_n = omega_d / (1.0 - zeta * zeta).sqrt();
    let c = Contact {
        semi: body.semi_axes(),
        inertia: body.inertia(),
        mass: body.mass(),
        n,
        e: 0.0,
        stiffness: omega_n * omega_n / g,
        damping: 2.0 * zeta * omega_n / g,
    };
    let steps_per_duration = 4000.0;
    let h = duration / steps_per_duration;
    let mut s = start;
    // Step until δ returns to 0, then locate that moment by bisection on the
    // length of the last step, so the exit is exact to rounding.
    for step in 0.. {
        let next = rk4(&c, &s, h);
        let (delta, _, _) = c.penetration(&next);
        if step > 10 && delta <= 0.0 {
            let (mut lo, mut hi) = (0.0, h);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if c.penetration(&rk4(&c, &s, mid)).0 > 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            s = rk4(&c, &s, hi);
            break;
        }
        s = next;
        assert!(
            step < 100 * steps_per_duration as usize,
            "contact never ended"
        );
    }
    (s.v, s.w)
}

#[test]
fn compliant_contact_converges_to_the_rigid_law() {
    let body = Ellipsoid::new([1.0, 1.0, 2.0], 500.0).unwrap();
    let a = matrix_from_bryan(Bryan {
        psi: 0.4,
        theta: -0.7,
        phi: 1.3,
    });
    let k = 0.6;
    let plane = Plane::new([0.0, 0.0, 1.0], 0.0, k).unwrap();
    // Place the body touching the floor.
    let u = a.transpose() * DVec3::Z;
    let h = (body.semi_axes() * u).length();
    let x0 = DVec3::new(0.2, -0.1, h);
    let v = DVec3::new(0.3, -0.2, -1.0);
    let w = DVec3::new(0.5, -0.8, 0.3);
    let rigid = solve_impact(
        &body,
        Pose {
            rotation: a,
            centre: x0,
        },
        State {
            velocity: v,
            omega: w,
        },
        &[plane],
        Law::Newton,
        1e-12,
    )
    .unwrap();
    // Inverse inertance of the contact from first principles (not from the
    // code under test): ρ = x* × u with x* the support point, G = 1/m + ρ·J⁻¹ρ.
    let g = {
        let u = a.transpose() * DVec3::Z;
        let xs = -(body.semi_axes() * body.semi_axes() * u) / (body.semi_axes() * u).length();
        let rho = xs.cross(u);
        1.0 / body.mass() + (rho * rho / body.inertia()).element_sum()
    };
    let start = Rigid {
        x: x0,
        q: DQuat::from_mat3(&a),
        v,
        w,
    };
    let scale = v.length() + body.length_scale() * w.length();
    println!("| contact duration (s) | |Δv⁺|/scale | L|Δω⁺|/scale |");
    println!("|---|---|---|");
    let mut errors = Vec::new();
    for duration in [1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6] {
        let (v2, w2) = compliant_impact(&body, start, DVec3::Z, k, g, duration);
        let ev = (v2 - rigid.after.velocity).length() / scale;
        let ew = (w2 - rigid.after.omega).length() * body.length_scale() / scale;
        println!("| {duration:.0e} | {ev:.2e} | {ew:.2e} |");
        errors.push(ev.max(ew));
    }
    // The error falls with the contact time (first order: rotation during
    // contact is O(ω·duration)) and reaches 1e-6 by 1 µs.
    for pair in errors.windows(2) {
        let ratio = pair[0] / pair[1];
        assert!(
            (5.0..20.0).contains(&ratio),
            "not first order (ratio {ratio}): {errors:?}"
        );
    }
    assert!(*errors.last().unwrap() < 1e-6, "errors {errors:?}");
    assert!(
        errors[0] > 1e-3,
        "the softest contact should differ visibly: {errors:?}"
    );
}
