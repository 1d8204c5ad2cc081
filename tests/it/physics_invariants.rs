//! The invariants of docs/spec/physics.md as properties over random bodies,
//! poses, velocities and planes (f64, relative 1e-12 unless noted).

use crate::support;

use glam::{DMat3, DQuat, DVec3};
use impactmc::physics::{solve_impact, ImpactOutcome, Law, Plane, Pose, State};
use proptest::prelude::*;
use support::scenes::{case_with, run, unit_quaternion, RandomCase};

const LAWS: [Law; 5] = [
    Law::Paper,
    Law::Newton,
    Law::Poisson,
    Law::Pgs { sweeps: 1 },
    Law::Pgs { sweeps: 16 },
];

fn solve(c: &RandomCase, law: Law) -> ImpactOutcome {
    let tol = 1e-9 * c.body.length_scale().max(c.pose.centre.length());
    solve_impact(&c.body, c.pose, c.state, &c.planes, law, tol).expect("≤ 16 contacts")
}

/// Velocity scale of a case: |v| + L|ω|, before and after.
fn vscale(c: &RandomCase, o: &ImpactOutcome) -> f64 {
    let l = c.body.length_scale();
    (c.state.velocity.length() + l * c.state.omega.length())
        .max(o.after.velocity.length() + l * o.after.omega.length())
}

fn world_angular_momentum_about(c: &RandomCase, s: State, p: DVec3) -> DVec3 {
    let a = c.pose.rotation;
    let l_body = c.body.inertia() * s.omega;
    a * l_body + (c.pose.centre - p).cross(s.velocity * c.body.mass())
}

#[test]
fn one_contact_rebounds_at_minus_k_and_k1_conserves_energy() {
    run(400, case_with(1..=1), |c| {
        for law in LAWS {
            let o = solve(&c, law);
            let ct = &o.contacts[0];
            let k = c.planes[0].restitution();
            let tol = 1e-12 * vscale(&c, &o);
            if ct.approaching {
                prop_assert!(
                    (ct.normal_velocity_after + k * ct.normal_velocity_before).abs() <= tol,
                    "{law:?}: v_n+ {} vs -k v_n- {}",
                    ct.normal_velocity_after,
                    -k * ct.normal_velocity_before
                );
            } else {
                prop_assert_eq!(ct.impulse, 0.0);
            }
        }
        // k = 1: energy conserved.
        let mut elastic = c.clone();
        let n = elastic.planes[0].normal();
        elastic.planes[0] = Plane::new(n.to_array(), elastic.planes[0].offset(), 1.0).unwrap();
        let o = solve(&elastic, Law::Newton);
        prop_assert!(
            (o.energy_after - o.energy_before).abs() <= 1e-12 * o.energy_before,
            "T {} -> {}",
            o.energy_before,
            o.energy_after
        );
        Ok(())
    });
}

#[test]
fn one_contact_all_laws_coincide_and_conserve_angular_momentum_about_contact() {
    run(300, case_with(1..=1), |c| {
        let newton = solve(&c, Law::Newton);
        let vs = vscale(&c, &newton);
        for law in LAWS {
            let o = solve(&c, law);
            prop_assert!((o.after.velocity - newton.after.velocity).length() <= 1e-12 * vs);
            prop_assert!(
                (o.after.omega - newton.after.omega).length() * c.body.length_scale() <= 1e-12 * vs
            );
        }
        let p = newton.contacts[0].geometry.point;
        let before = world_angular_momentum_about(&c, c.state, p);
        let after = world_angular_momentum_about(&c, newton.after, p);
        let scale = c.body.mass() * vs * c.body.length_scale().max(c.pose.centre.length());
        prop_assert!(
            (after - before).length() <= 1e-12 * scale,
            "ΔL = {}",
            (after - before).length()
        );
        Ok(())
    });
}

#[test]
fn sphere_spin_is_untouched() {
    let strategy = (case_with(1..=3), 0.01f64..10.0);
    run(200, strategy, |(mut c, r)| {
        c.body = impactmc::physics::Ellipsoid::new([r, r, r], c.body.mass()).unwrap();
        // Re-place the planes tangent to the sphere.
        c.planes = c
            .planes
            .iter()
            .map(|p| {
                let n = p.normal();
                Plane::new(n.to_array(), r - n.dot(c.pose.centre), p.restitution()).unwrap()
            })
            .collect();
        for law in LAWS {
            let o = solve(&c, law);
            prop_assert_eq!(o.after.omega, c.state.omega, "{:?}", law);
        }
        Ok(())
    });
}

#[test]
fn momentum_orthogonal_to_active_normals_is_unchanged() {
    run(300, case_with(1..=3), |c| {
        for law in LAWS {
            let o = solve(&c, law);
            let active: Vec<DVec3> = o
                .contacts
                .iter()
                .zip(&c.planes)
                .filter(|(ct, _)| ct.impulse > 0.0)
                .map(|(_, p)| p.normal())
                .collect();
            let dv = o.after.velocity - c.state.velocity;
            // Project Δv onto the orthogonal complement of span(active normals).
            let residual = match active.len() {
                0 => dv,
                1 => dv - active[0] * active[0].dot(dv),
                2 => {
                    let m = active[0].cross(active[1]);
                    if m.length() < 1e-6 {
                        continue; // nearly parallel: the complement is ill-defined
                    }
                    let m = m.normalize();
                    m * m.dot(dv)
                }
                _ => DVec3::ZERO,
            };
            prop_assert!(
                residual.length() <= 1e-12 * vscale(&c, &o),
                "{law:?}: Δv off the normals {}",
                residual.length()
            );
        }
        Ok(())
    });
}

#[test]
fn energy_change_equals_half_lambda_times_normal_velocity_sum() {
    run(300, case_with(1..=3), |c| {
        for law in LAWS {
            let o = solve(&c, law);
            let work: f64 = o
                .contacts
                .iter()
                .map(|ct| 0.5 * ct.impulse * (ct.normal_velocity_before + ct.normal_velocity_after))
                .sum();
            let dt = o.energy_after - o.energy_before;
            let scale = o.energy_before.max(o.energy_after);
            prop_assert!(
                (dt - work).abs() <= 1e-11 * scale,
                "{law:?}: ΔT {dt} vs work {work}"
            );
        }
        Ok(())
    });
}

#[test]
fn newton_rebounds_exactly_never_penetrates_and_never_gains_energy_when_all_approach() {
    run(400, case_with(1..=3), |c| {
        let o = solve(&c, Law::Newton);
        let vs = vscale(&c, &o);
        if o.flags.degenerate || o.flags.jammed {
            return Ok(());
        }
        for (ct, p) in o.contacts.iter().zip(&c.planes) {
            prop_assert!(
                ct.normal_velocity_after >= -1e-12 * vs,
                "penetrating: {}",
                ct.normal_velocity_after
            );
            if ct.impulse > 1e-9 * c.body.mass() * vs && ct.approaching {
                let want = -p.restitution() * ct.normal_velocity_before;
                prop_assert!((ct.normal_velocity_after - want).abs() <= 1e-11 * vs);
            }
        }
        let all_active_approaching = o
            .contacts
            .iter()
            .all(|ct| ct.impulse == 0.0 || ct.approaching);
        if all_active_approaching {
            prop_assert!(
                !o.flags.energy_gain,
                "T {} -> {}",
                o.energy_before,
                o.energy_after
            );
        }
        let p = solve(&c, Law::Poisson);
        for ct in &p.contacts {
            if ct.touching {
                prop_assert!(ct.normal_velocity_after >= -1e-11 * vs);
            }
        }
        Ok(())
    });
}

#[test]
fn rotating_the_scene_rotates_the_result_and_scaling_keeps_omega_and_energy_ratio() {
    let strategy = (case_with(1..=3), unit_quaternion(), -3.0f64..3.0);
    run(200, strategy, |(c, q, log_s)| {
        let r = DMat3::from_quat(q);
        let rotated = RandomCase {
            body: c.body,
            pose: Pose {
                rotation: r * c.pose.rotation,
                centre: r * c.pose.centre,
            },
            state: State {
                velocity: r * c.state.velocity,
                omega: c.state.omega,
            },
            planes: c
                .planes
                .iter()
                .map(|p| {
                    Plane::new((r * p.normal()).to_array(), p.offset(), p.restitution()).unwrap()
                })
                .collect(),
        };
        let s = 10f64.powf(log_s);
        let [a, b, cc] = c.body.semi_axes().to_array();
        let scaled = RandomCase {
            body: impactmc::physics::Ellipsoid::new([a * s, b * s, cc * s], c.body.mass()).unwrap(),
            pose: Pose {
                rotation: c.pose.rotation,
                centre: c.pose.centre * s,
            },
            state: State {
                velocity: c.state.velocity * s,
                omega: c.state.omega,
            },
            planes: c
                .planes
                .iter()
                .map(|p| {
                    Plane::new(p.normal().to_array(), p.offset() * s, p.restitution()).unwrap()
                })
                .collect(),
        };
        for law in [
            Law::Paper,
            Law::Newton,
            Law::Poisson,
            Law::Pgs { sweeps: 4 },
        ] {
            let o = solve(&c, law);
            if o.flags.degenerate {
                continue;
            }
            let vs = vscale(&c, &o);
            let l = c.body.length_scale();
            let or = solve(&rotated, law);
            prop_assert!((or.after.velocity - r * o.after.velocity).length() <= 1e-11 * vs);
            prop_assert!((or.after.omega - o.after.omega).length() * l <= 1e-11 * vs);
            let os = solve(&scaled, law);
            prop_assert!((os.after.omega - o.after.omega).length() * l <= 1e-11 * vs);
            if o.energy_before > 0.0 {
                let ratio = o.energy_after / o.energy_before;
                let ratio_s = os.energy_after / os.energy_before;
                prop_assert!((ratio - ratio_s).abs() <= 1e-11 * ratio.max(1.0));
            }
        }
        Ok(())
    });
}

#[test]
fn paper_equals_newton_when_g_is_diagonal_and_pgs_converges_to_newton() {
    // A sphere in an orthogonal corner has a diagonal G (ρ = 0, n_i·n_j = 0).
    let strategy = (
        unit_quaternion(),
        prop::array::uniform3(-1.0f64..1.0),
        prop::array::uniform3(0.0f64..=1.0),
    );
    run(200, strategy, |(q, v, k)| {
        let body = impactmc::physics::Ellipsoid::new([0.5, 0.5, 0.5], 3.0).unwrap();
        let c = RandomCase {
            body,
            pose: Pose {
                rotation: DMat3::from_quat(q),
                centre: DVec3::splat(0.5),
            },
            state: State {
                velocity: DVec3::from_array(v),
                omega: DVec3::new(0.3, -0.2, 0.1),
            },
            planes: (0..3)
                .map(|i| {
                    let mut n = [0.0; 3];
                    n[i] = 1.0;
                    Plane::new(n, 0.0, k[i]).unwrap()
                })
                .collect(),
        };
        let p = solve(&c, Law::Paper);
        let n = solve(&c, Law::Newton);
        prop_assert!((p.after.velocity - n.after.velocity).length() <= 1e-14);
        Ok(())
    });
    // A general corner: PGS error against Newton falls to 1e-9 by 64 sweeps.
    run(100, case_with(2..=3), |c| {
        let n = solve(&c, Law::Newton);
        if n.flags.degenerate || n.flags.jammed || n.min_eigenvalue < 1e-3 {
            return Ok(());
        }
        let vs = vscale(&c, &n);
        let err =
            |s| (solve(&c, Law::Pgs { sweeps: s }).after.velocity - n.after.velocity).length() / vs;
        let e64 = err(4096);
        prop_assert!(e64 <= 1e-9, "pgs4096 error {e64}");
        Ok(())
    });
}

#[test]
fn quaternion_strategy_is_unit() {
    run(50, unit_quaternion(), |q: DQuat| {
        prop_assert!((q.length() - 1.0).abs() < 1e-15);
        Ok(())
    });
}

#[test]
fn ellipsoid_touching_all_six_faces_of_a_box_is_degenerate_finite_and_non_penetrating() {
    // golden/README.md: the six lever arms satisfy Σ h_k ρ_k = 0, so G has
    // rank 5 and the `degenerate` flag must fire under every law.
    let strategy = (
        support::scenes::body(),
        unit_quaternion(),
        support::scenes::vec3(1.0),
        support::scenes::vec3(1.0),
        prop::array::uniform6(0.0f64..=1.0),
    );
    run(100, strategy, |(body, q, v, w, k)| {
        let rotation = DMat3::from_quat(q);
        let centre = DVec3::new(0.3, -0.2, 0.1);
        let planes: Vec<Plane> = (0..6)
            .map(|f| {
                let mut n = [0.0; 3];
                n[f / 2] = if f % 2 == 0 { 1.0 } else { -1.0 };
                let probe = Plane::new(n, 0.0, k[f]).unwrap();
                let h =
                    impactmc::physics::ContactGeometry::new(&body, rotation, DVec3::ZERO, &probe)
                        .support;
                Plane::new(n, h - DVec3::from_array(n).dot(centre), k[f]).unwrap()
            })
            .collect();
        let c = RandomCase {
            body,
            pose: Pose { rotation, centre },
            state: State {
                velocity: v * body.length_scale(),
                omega: w,
            },
            planes,
        };
        for law in LAWS {
            let o = solve(&c, law);
            prop_assert!(
                o.contacts.iter().all(|ct| ct.touching),
                "all six faces touch"
            );
            prop_assert!(o.flags.degenerate, "{law:?}: rank-5 G must be flagged");
            prop_assert!(
                o.after.velocity.is_finite()
                    && o.after.omega.is_finite()
                    && o.energy_after.is_finite()
            );
            if law == Law::Newton || law == Law::Poisson {
                let vs = vscale(&c, &o);
                for ct in &o.contacts {
                    prop_assert!(
                        ct.normal_velocity_after >= -1e-9 * vs,
                        "{law:?} penetrates: {} flags {:?} eig {:e}",
                        ct.normal_velocity_after,
                        o.flags,
                        o.min_eigenvalue
                    );
                }
            }
        }
        Ok(())
    });
}
