//! The invariants of docs/spec/friction.md as properties over random bodies,
//! poses, velocities, planes and Coulomb coefficients (f64, relative 1e-12
//! unless noted).

use crate::support;

use glam::{DMat3, DVec3};
use impactmc::physics::friction::delassus;
use impactmc::physics::{solve_impact, Ellipsoid, ImpactOutcome, Law, Plane, Pose, State};
use proptest::prelude::*;
use support::scenes::{case_with, run, unit_quaternion, RandomCase};

/// Every plane of `c` with Coulomb coefficient `mu`.
fn with_friction(c: &RandomCase, mu: f64) -> RandomCase {
    let mut c = c.clone();
    for p in &mut c.planes {
        *p = p.with_friction(mu).unwrap();
    }
    c
}

fn solve(c: &RandomCase, law: Law) -> ImpactOutcome {
    let tol = 1e-9 * c.body.length_scale().max(c.pose.centre.length());
    solve_impact(&c.body, c.pose, c.state, &c.planes, law, tol).expect("a valid case")
}

/// |v| + L|ω|, before and after.
fn vscale(c: &RandomCase, o: &ImpactOutcome) -> f64 {
    let l = c.body.length_scale();
    (c.state.velocity.length() + l * c.state.omega.length())
        .max(o.after.velocity.length() + l * o.after.omega.length())
}

/// The contact point's velocity after the impact, world frame.
fn contact_velocity_after(c: &RandomCase, o: &ImpactOutcome, i: usize) -> DVec3 {
    o.after.velocity + c.pose.rotation * o.after.omega.cross(o.contacts[i].geometry.body_point)
}

/// The single-contact laws: the cone holds; Newton's normal law holds;
/// Newton's friction opposes the sliding it leaves (maximal dissipation);
/// `stronge` never gains energy.
#[test]
fn one_contact_cone_normal_law_sliding_and_stronge_energy() {
    run(300, (case_with(1..=1), 0.0f64..1.5), |(c, mu)| {
        let c = with_friction(&c, mu);
        let k = c.planes[0].restitution();
        for law in [
            Law::Newton,
            Law::Paper,
            Law::Pgs { sweeps: 1 },
            Law::Stronge,
        ] {
            let o = solve(&c, law);
            let ct = &o.contacts[0];
            let vs = vscale(&c, &o);
            let f = ct.tangential_impulse;
            prop_assert!(
                f.length() <= mu * ct.impulse * (1.0 + 1e-12) + 1e-300,
                "{law:?}: |f| {} > μλ {}",
                f.length(),
                mu * ct.impulse
            );
            prop_assert!(!o.flags.unsolved, "{law:?} unsolved");
            if law == Law::Stronge {
                prop_assert!(
                    o.energy_after <= o.energy_before * (1.0 + 1e-10),
                    "stronge gained energy: {} → {}",
                    o.energy_before,
                    o.energy_after
                );
                continue;
            }
            if !ct.approaching {
                prop_assert_eq!(ct.impulse, 0.0);
                continue;
            }
            // Active: c⁺_n = −k c⁻_n (the same for paper and pgs1 with one
            // contact).
            prop_assert!(
                (ct.normal_velocity_after + k * ct.normal_velocity_before).abs() <= 1e-12 * vs,
                "{law:?}: c+_n {} vs {}",
                ct.normal_velocity_after,
                -k * ct.normal_velocity_before
            );
            let n = c.planes[0].normal();
            let cp = contact_velocity_after(&c, &o, 0);
            let slip = cp - n * n.dot(cp);
            if slip.length() > 1e-9 * vs {
                // f = −μλ ŝ: full friction against the slip.
                let cos = f.dot(slip) / (f.length() * slip.length()).max(1e-300);
                prop_assert!(
                    mu == 0.0 || cos <= -1.0 + 1e-9,
                    "{law:?}: f not against the slip (cos {cos})"
                );
                prop_assert!(
                    (f.length() - mu * ct.impulse).abs() <= 1e-12 * mu * ct.impulse + 1e-300,
                    "{law:?}: sliding with |f| {} < μλ {}",
                    f.length(),
                    mu * ct.impulse
                );
            }
        }
        Ok(())
    });
}

/// With μ large enough that sticking is valid (the stick impulse
/// `W⁻¹(−b n − c⁻)` pushes, λ > 0, and lies inside the cone), an active
/// `newton` contact ends with no slip.
#[test]
fn large_friction_sticks() {
    run(200, case_with(1..=1), |c| {
        let c = with_friction(&c, 1e6);
        let o = solve(&c, Law::Newton);
        let x = o.contacts[0].geometry.body_point;
        let w = delassus(&c.body, c.pose.rotation, x, x);
        let n = c.planes[0].normal();
        let cm = c.state.velocity + c.pose.rotation * c.state.omega.cross(x);
        let b = c.planes[0].restitution() * n.dot(cm).min(0.0);
        let stick = w.inverse() * (-b * n - cm);
        let lambda = n.dot(stick);
        let stick_valid = lambda > 0.0 && (stick - lambda * n).length() <= 1e6 * lambda;
        if o.contacts[0].approaching && stick_valid {
            let n = c.planes[0].normal();
            let cp = contact_velocity_after(&c, &o, 0);
            let slip = (cp - n * n.dot(cp)).length();
            prop_assert!(slip <= 1e-9 * vscale(&c, &o), "slip {slip}");
        }
        Ok(())
    });
}

/// A sphere (`w_t = 0`): every law agrees with friction.md's closed form,
/// `λ = −(1+k) m c⁻_n`, stick iff `|c⁻_t| ≤ μ (1+k) m |c⁻_n| (1/m + R²/J)`.
#[test]
fn sphere_closed_form_for_every_law() {
    let strategy = (
        -1.0f64..1.0,
        -1.0f64..2.0,
        unit_quaternion(),
        support::scenes::unit_vector(),
        support::scenes::vec3(1.0),
        support::scenes::vec3(3.0),
        0.0f64..=1.0,
        0.0f64..1.5,
    );
    run(300, strategy, |(log_r, log_m, q, n, v, w, k, mu)| {
        let r = 10f64.powf(log_r);
        let m = 10f64.powf(log_m);
        let body = Ellipsoid::new([r, r, r], m).unwrap();
        let rotation = DMat3::from_quat(q);
        let centre = n * r;
        let plane = Plane::new(n.to_array(), 0.0, k)
            .unwrap()
            .with_friction(mu)
            .unwrap();
        let state = State {
            velocity: v - n * (n.dot(v).abs() + 0.1),
            omega: w,
        };
        let c = RandomCase {
            body,
            pose: Pose { rotation, centre },
            state,
            planes: vec![plane],
        };
        // The closed form.
        let x = -n * r;
        let cm = state.velocity + rotation * w.cross(rotation.transpose() * x);
        let cn = n.dot(cm);
        let ct = cm - n * cn;
        let j = body.inertia().x;
        let wtt = 1.0 / m + r * r / j;
        let lambda = -(1.0 + k) * m * cn;
        let f = if ct.length() <= mu * (1.0 + k) * m * cn.abs() * wtt {
            -ct / wtt
        } else {
            -mu * lambda * ct / ct.length()
        };
        let scale = m * (state.velocity.length() + r * w.length());
        for law in [
            Law::Newton,
            Law::Paper,
            Law::Pgs { sweeps: 1 },
            Law::Stronge,
        ] {
            let o = solve(&c, law);
            let got = &o.contacts[0];
            prop_assert!(
                (got.impulse - lambda).abs() <= 1e-12 * scale,
                "{law:?}: λ {} vs {lambda}",
                got.impulse
            );
            prop_assert!(
                (got.tangential_impulse - f).length() <= 1e-11 * scale,
                "{law:?}: f {} vs {f}",
                got.tangential_impulse
            );
        }
        Ok(())
    });
}

/// Rotating the whole scene rotates the result: world vectors turn, body
/// quantities and energies stay (which also checks that the tangent basis
/// chosen inside the solve does not matter).
#[test]
fn rotating_the_scene_rotates_the_result() {
    run(
        200,
        (case_with(1..=3), 0.0f64..1.2, unit_quaternion()),
        |(c, mu, q)| {
            let c = with_friction(&c, mu);
            let r = DMat3::from_quat(q);
            let mut turned = c.clone();
            turned.pose = Pose {
                rotation: r * c.pose.rotation,
                centre: r * c.pose.centre,
            };
            turned.state.velocity = r * c.state.velocity;
            turned.planes = c
                .planes
                .iter()
                .map(|p| {
                    Plane::new((r * p.normal()).to_array(), p.offset(), p.restitution())
                        .unwrap()
                        .with_friction(p.friction())
                        .unwrap()
                })
                .collect();
            let laws: &[Law] = if c.planes.len() == 1 {
                &[
                    Law::Newton,
                    Law::Paper,
                    Law::Pgs { sweeps: 4 },
                    Law::Stronge,
                ]
            } else {
                &[Law::Newton, Law::Paper, Law::Pgs { sweeps: 4 }]
            };
            for &law in laws {
                let a = solve(&c, law);
                let b = solve(&turned, law);
                if a.flags.ambiguous || a.flags.jammed || a.flags.unconverged {
                    continue;
                }
                let vs = vscale(&c, &a);
                let scale = c.body.mass() * vs;
                // Stronge integrates to 1e-12 of the scale, not to rounding.
                let tol = if law == Law::Stronge { 1e-10 } else { 1e-11 };
                prop_assert!(
                    (r * a.after.velocity - b.after.velocity).length() <= tol * vs,
                    "{law:?}: v+ {} vs {}",
                    r * a.after.velocity,
                    b.after.velocity
                );
                prop_assert!(
                    (a.after.omega - b.after.omega).length() * c.body.length_scale() <= tol * vs,
                    "{law:?}: ω+"
                );
                for (x, y) in a.contacts.iter().zip(&b.contacts) {
                    prop_assert!(
                        (r * x.tangential_impulse - y.tangential_impulse).length() <= tol * scale,
                        "{law:?}: f {} vs {}",
                        r * x.tangential_impulse,
                        y.tangential_impulse
                    );
                }
            }
            Ok(())
        },
    );
}

/// Several contacts under `newton` (the Gauss–Seidel limit, when it
/// converged): every contact inside its cone and on Newton's normal law
/// (`c⁺_n + k min(c⁻_n, 0) ≥ 0`, zero where λ > 0), and sliding contacts
/// with friction against their slip.
#[test]
fn several_contacts_newton_limit_satisfies_every_contact_law() {
    run(200, (case_with(2..=3), 0.0f64..0.8), |(c, mu)| {
        let c = with_friction(&c, mu);
        let o = solve(&c, Law::Newton);
        if o.flags.jammed || o.flags.unconverged || o.flags.degenerate {
            return Ok(());
        }
        let vs = vscale(&c, &o);
        // The limit is reached to 1e-13 of the impulse scale per sweep; the
        // laws then hold to a few 1e-10 of the velocity scale.
        let tol = 1e-9 * vs;
        for (i, ct) in o.contacts.iter().enumerate() {
            let k = c.planes[i].restitution();
            let w = ct.normal_velocity_after + k * ct.normal_velocity_before.min(0.0);
            let f = ct.tangential_impulse;
            prop_assert!(f.length() <= mu * ct.impulse * (1.0 + 1e-12) + 1e-300);
            if !ct.touching {
                continue;
            }
            prop_assert!(w >= -tol, "contact {i}: w {w}");
            if ct.impulse > 1e-9 * c.body.mass() * vs {
                prop_assert!(w.abs() <= tol, "contact {i}: active with w {w}");
                let n = c.planes[i].normal();
                let cp = contact_velocity_after(&c, &o, i);
                let slip = cp - n * n.dot(cp);
                if slip.length() > 1e-6 * vs && mu > 0.0 {
                    let cos = f.dot(slip) / (f.length() * slip.length()).max(1e-300);
                    prop_assert!(cos <= -1.0 + 1e-6, "contact {i}: cos {cos}");
                }
            }
        }
        Ok(())
    });
}
