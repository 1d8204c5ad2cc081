//! Free flight and time of impact, physics only: a dropped sphere
//! hits at sqrt(v0² + 2gH); axisymmetric precession in closed form matches
//! an independent RK4 integration and conserves L and T exactly; RK4 for
//! triaxial bodies conserves them at fourth order; conservative advancement
//! never tunnels through a plane, even for fast-spinning thin bodies, with
//! the exact rotation or RK4.

use glam::{DMat3, DVec3};
use impactmc::physics::{
    advance, precess, rk4_rotation, time_of_impact, ContactGeometry, Ellipsoid, Motion, Plane,
    Rotation,
};
use proptest::prelude::*;

const G: f64 = 9.81;

fn floor() -> Plane {
    Plane::new([0.0, 0.0, 1.0], 0.0, 0.8).unwrap()
}

#[test]
fn dropped_sphere_hits_at_the_free_fall_speed() {
    let body = Ellipsoid::new([0.3, 0.3, 0.3], 2.0).unwrap();
    for (h, v0z, vx) in [
        (1.0, 0.0, 0.0),
        (2.5, 1.5, 0.7),
        (0.01, 3.0, -2.0),
        (10.0, -2.0, 0.1),
    ] {
        // v0z > 0 means thrown downward; negative, thrown up first.
        let start = Motion {
            centre: DVec3::new(0.0, 0.0, 0.3 + h),
            rotation: DMat3::IDENTITY,
            velocity: DVec3::new(vx, 0.0, -v0z),
            omega: DVec3::new(3.0, -1.0, 2.0),
        };
        let g = DVec3::new(0.0, 0.0, -G);
        let hit = time_of_impact(
            &body,
            &start,
            &[floor()],
            g,
            Rotation::Precession,
            1e-13,
            100.0,
        )
        .expect("falls onto the floor");
        let want_speed = (v0z * v0z + 2.0 * G * h).sqrt();
        let got = -hit.motion.velocity.z;
        assert!(
            ((got - want_speed) / want_speed).abs() < 1e-12,
            "H {h}: {got} vs {want_speed}"
        );
        let want_t = (-v0z + want_speed) / G;
        assert!(
            (hit.time - want_t).abs() < 1e-12 * (1.0 + want_t),
            "t {} vs {want_t}",
            hit.time
        );
        assert!(hit.distances[0] >= 0.0 && hit.distances[0] <= 1e-13);
    }
}

fn momentum_world(body: &Ellipsoid, r: DMat3, w: DVec3) -> DVec3 {
    r * (body.inertia() * w)
}

fn rot_energy(body: &Ellipsoid, w: DVec3) -> f64 {
    0.5 * (body.inertia() * w * w).element_sum()
}

#[test]
fn axisymmetric_precession_matches_rk4_and_conserves_exactly() {
    let body = Ellipsoid::new([0.5, 0.5, 2.0], 10.0).unwrap();
    let r0 = DMat3::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 2.0);
    let w0 = DVec3::new(1.5, -0.7, 4.0);
    let t = 3.0;
    let (r, w) = precess(&body, r0, w0, t);
    // L (world) and T are constants of the motion: exact to rounding.
    let l0 = momentum_world(&body, r0, w0);
    assert!((momentum_world(&body, r, w) - l0).length() < 1e-13 * l0.length());
    assert!((rot_energy(&body, w) - rot_energy(&body, w0)).abs() < 1e-13 * rot_energy(&body, w0));
    assert!((r.transpose() * r - DMat3::IDENTITY).abs_diff_eq(DMat3::ZERO, 1e-14));
    // An independent integration converges to it at fourth order.
    let mut errs = Vec::new();
    for step in [1e-2, 5e-3, 2.5e-3] {
        let (ri, wi) = rk4_rotation(&body, r0, w0, t, step);
        let e = (ri - r)
            .to_cols_array()
            .iter()
            .map(|x| x.abs())
            .fold(0.0, f64::max)
            + (wi - w).length() / w0.length();
        errs.push(e);
    }
    assert!(errs[2] < 1e-8, "{errs:?}");
    for k in 0..2 {
        let ratio = errs[k] / errs[k + 1];
        assert!(ratio > 12.0 && ratio < 20.0, "order: {errs:?}");
    }
}

#[test]
fn triaxial_rk4_conserves_energy_and_momentum_at_fourth_order() {
    let body = Ellipsoid::new([1.0, 0.6, 0.3], 5.0).unwrap();
    let r0 = DMat3::from_euler(glam::EulerRot::ZYX, 0.4, 0.2, -0.9);
    // Near the unstable intermediate axis: a hard case for the integrator.
    let w0 = DVec3::new(0.3, 5.0, 0.2);
    let (e0, l0) = (rot_energy(&body, w0), momentum_world(&body, r0, w0));
    let mut drift = Vec::new();
    for step in [4e-3, 2e-3, 1e-3] {
        let (r, w) = rk4_rotation(&body, r0, w0, 5.0, step);
        let de = (rot_energy(&body, w) - e0).abs() / e0;
        let dl = (momentum_world(&body, r, w) - l0).length() / l0.length();
        drift.push(de.max(dl));
    }
    assert!(drift[2] < 1e-7, "{drift:?}");
    for k in 0..2 {
        assert!(
            drift[k] / drift[k + 1] > 10.0,
            "not fourth order: {drift:?}"
        );
    }
}

fn corner() -> Vec<Plane> {
    vec![
        Plane::new([1.0, 0.0, 0.0], 0.0, 0.5).unwrap(),
        Plane::new([0.0, 1.0, 0.0], 0.0, 0.7).unwrap(),
        Plane::new([0.0, 0.0, 1.0], 0.0, 0.9).unwrap(),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, .. ProptestConfig::default() })]

    /// Fast-spinning thin bodies thrown into a corner: at no moment before
    /// the reported impact does any plane's distance fall below −tol (checked
    /// on a fine grid of the same trajectory), and at the impact the closest
    /// plane is within tolerance.
    #[test]
    fn time_of_impact_never_tunnels(
        thin in 0.002f64..0.05,
        long in 0.5f64..2.0,
        spin in prop::array::uniform3(-60.0f64..60.0),
        start in prop::array::uniform3(2.5f64..4.0),
        vel in prop::array::uniform3(-8.0f64..-0.5),
        axisymmetric in any::<bool>(),
        exact in any::<bool>(),
    ) {
        let semi = if axisymmetric { [thin, thin, long] } else { [long, thin, 3.0 * thin] };
        let body = Ellipsoid::new(semi, 1.0).unwrap();
        let planes = corner();
        // The exact rotation (with its bounding-sphere jump) or RK4.
        let rotation = if exact {
            Rotation::exact_for(&body)
        } else {
            Rotation::for_body(&body, 1e-4)
        };
        let m0 = Motion {
            centre: DVec3::from_array(start),
            rotation: DMat3::from_euler(glam::EulerRot::XYZ, spin[0], spin[1], spin[2]),
            velocity: DVec3::from_array(vel),
            omega: DVec3::from_array(spin),
        };
        let g = DVec3::new(0.0, 0.0, -G);
        let tol = 1e-9;
        let hit = time_of_impact(&body, &m0, &planes, g, rotation, tol, 10.0);
        let hit = hit.expect("a body thrown into the corner hits it");
        let dmin = hit.distances.iter().cloned().fold(f64::INFINITY, f64::min);
        prop_assert!(dmin <= tol && dmin >= -tol, "distance at impact {}", dmin);
        // Dense check of the trajectory before the impact.
        let n = 400;
        for k in 0..n {
            let t = hit.time * k as f64 / n as f64;
            let m = advance(&body, &m0, g, rotation, t);
            for p in &planes {
                let d = ContactGeometry::new(&body, m.rotation, m.centre, p).distance;
                prop_assert!(d > -tol, "tunnelled: d = {} at t = {} < {}", d, t, hit.time);
            }
        }
    }
}
