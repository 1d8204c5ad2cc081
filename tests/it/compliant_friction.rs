//! The compliant reference with regularised Coulomb friction (friction.md,
//! "Compliant reference") against what it must reproduce without being
//! built from it: friction.md's closed form for a sphere (slide and stick),
//! the Coulomb cone, dissipation, and convergence in the step on a rough
//! corner.

use crate::support;

use glam::{DMat3, DVec3};
use impactmc::accuracy::{compliant_posts, errors, sample_input};
use impactmc::config::Overrides;
use impactmc::engine::evaluate_samples;
use impactmc::physics::{
    damping_table, kinetic_energy, solve_compliant, solve_compliant_with, CompliantError,
    CompliantParams, Ellipsoid, Law, Plane, Pose, State,
};
use support::rough_scene;

/// A sphere of radius `r` resting on the floor, struck with centre velocity
/// `(vt, 0, −vn)` and no spin.
fn sphere_on_rough_floor(mu: f64, k: f64, vt: f64, vn: f64) -> (f64, DVec3, DVec3, f64) {
    let r = 0.5;
    let m = 3.0;
    let body = Ellipsoid::new([r, r, r], m).unwrap();
    let floor = Plane::new([0.0, 0.0, 1.0], 0.0, k)
        .unwrap()
        .with_friction(mu)
        .unwrap();
    let pose = Pose {
        rotation: DMat3::IDENTITY,
        centre: DVec3::new(0.0, 0.0, r),
    };
    let state = State {
        velocity: DVec3::new(vt, 0.0, -vn),
        omega: DVec3::ZERO,
    };
    // Stiff enough that the contact lasts a tiny fraction of any motion.
    let o = solve_compliant(
        &body,
        pose,
        state,
        &[floor],
        CompliantParams::new(1e13, 400),
    )
    .unwrap();
    assert!(o.separated);
    // Contact-point velocity after: v + ω × (−r e_z) (the sphere's body
    // frame stays the world frame up to the tiny rotation in contact).
    let spin = o.after.omega;
    let slip = o.after.velocity + spin.cross(DVec3::new(0.0, 0.0, -r));
    (o.impulses[0], o.tangential[0], slip, m)
}

#[test]
fn sphere_slides_as_friction_md_closed_form() {
    // Slides throughout: |c⁻_t| = 2 > μ (1 + k) |c⁻_n| (1 + m R²/J) = 1.05.
    let (mu, k, vt, vn) = (0.2, 0.5, 2.0, 1.0);
    let (lambda, f, slip, m) = sphere_on_rough_floor(mu, k, vt, vn);
    let want_lambda = (1.0 + k) * m * vn;
    assert!((lambda / want_lambda - 1.0).abs() < 1e-3, "λ {lambda}");
    // f = −μ λ c⁻_t/|c⁻_t|.
    let want_f = DVec3::new(-mu * lambda, 0.0, 0.0);
    assert!((f - want_f).length() < 1e-9 * want_f.length(), "f {f}");
    // c⁺_t = c⁻_t + f (1/m + R²/J) = c⁻_t + 3.5 f/m.
    let want_slip = vt - 3.5 * mu * lambda / m;
    assert!((slip.x - want_slip).abs() < 1e-6, "slip {slip}");
    assert!(slip.y.abs() < 1e-12);
}

#[test]
fn sphere_sticks_as_friction_md_closed_form() {
    // Sticks: |c⁻_t| = 0.5 ≤ μ (1 + k) |c⁻_n| (1 + m R²/J) = 2.625.
    let (mu, k, vt, vn) = (0.5, 0.5, 0.5, 1.0);
    let (lambda, f, slip, m) = sphere_on_rough_floor(mu, k, vt, vn);
    // f = −c⁻_t / (1/m + R²/J), and the contact point ends at rest
    // (to the regularisation, ε = 1e-6 of the velocity scale).
    let want_f = -vt * m / 3.5;
    assert!((f.x / want_f - 1.0).abs() < 1e-5, "f {f}, want {want_f}");
    assert!(f.length() < mu * lambda);
    let tangential_slip = DVec3::new(slip.x, slip.y, 0.0).length();
    assert!(tangential_slip < 1e-9 * vt, "slip {slip}");
}

#[test]
fn rough_corner_stays_in_the_cone_and_never_gains_energy() {
    let s = rough_scene("corner3", 0.3, "compliant-cone", &Overrides::default());
    let planes: Vec<Plane> = s.planes().iter().map(|p| p.plane).collect();
    // The draws only (any law draws the same samples; paper is the cheap one).
    let outcomes = evaluate_samples(&s, Law::Paper, 0, 120);
    let alpha = damping_table(&planes);
    let params = CompliantParams::new(1.15e11, 200);
    let mut rubbed = 0;
    for o in &outcomes {
        let (pose, state) = sample_input(&s, o);
        let c = match solve_compliant_with(s.body(), pose, state, &planes, params, &alpha) {
            Ok(c) => c,
            Err(CompliantError::NoImpact) => continue,
            Err(e) => panic!("{e}"),
        };
        assert!(c.separated);
        let t0 = kinetic_energy(s.body(), state.velocity, state.omega);
        assert!(
            c.energy_after <= t0 * (1.0 + 1e-9),
            "energy gained: {} > {t0}",
            c.energy_after
        );
        for (i, p) in planes.iter().enumerate() {
            let f = c.tangential[i];
            assert!(
                f.length() <= p.friction() * c.impulses[i] * (1.0 + 1e-12),
                "outside the cone on {i}: |f| {} > μλ {}",
                f.length(),
                p.friction() * c.impulses[i]
            );
            // Tangential: orthogonal to the plane's normal.
            assert!(f.dot(p.normal()).abs() <= 1e-12 * (1.0 + f.length()));
            if f.length() > 0.0 {
                rubbed += 1;
            }
        }
    }
    assert!(rubbed > 100, "friction acted on {rubbed} contacts");
}

#[test]
fn rough_corner_converges_as_the_step_shrinks() {
    let s = rough_scene("corner3", 0.3, "compliant-steps", &Overrides::default());
    let outcomes = evaluate_samples(&s, Law::Paper, 0, 60);
    let inputs: Vec<_> = outcomes.iter().map(|o| sample_input(&s, o)).collect();
    let (reference, _, _) = compliant_posts(&s, &inputs, CompliantParams::new(1.15e11, 1600));
    let mut previous = f64::INFINITY;
    let mut seen = Vec::new();
    for steps in [12u32, 50, 200] {
        let (posts, _, _) = compliant_posts(&s, &inputs, CompliantParams::new(1.15e11, steps));
        let e = errors(&posts, &reference).v_rms;
        seen.push((steps, e));
        assert!(e < previous, "error did not fall: {seen:?}");
        previous = e;
    }
    assert!(previous < 2e-2, "200 steps: {seen:?}");
}

#[test]
fn regularisation_must_be_positive() {
    let body = Ellipsoid::new([1.0, 1.0, 2.0], 1.0).unwrap();
    let floor = Plane::new([0.0, 0.0, 1.0], 0.0, 0.5).unwrap();
    let pose = Pose {
        rotation: DMat3::IDENTITY,
        centre: DVec3::new(0.0, 0.0, 2.0),
    };
    let state = State {
        velocity: DVec3::new(0.0, 0.0, -1.0),
        omega: DVec3::ZERO,
    };
    for bad in [0.0, -1e-6, f64::NAN] {
        let p = CompliantParams {
            friction_regularisation: bad,
            ..CompliantParams::new(1e11, 100)
        };
        let e = solve_compliant(&body, pose, state, &[floor], p).unwrap_err();
        assert!(e.to_string().contains("friction_regularisation"), "{e}");
    }
}
