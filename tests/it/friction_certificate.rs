//! The fast paths of the f64 friction reference (docs/spec/friction.md),
//! each against the slow definition it replaces:
//! - the certificate B3 against the full single-contact search, on random
//!   single contacts (random bodies from spheres to thin rods and flat
//!   disks, long levers, μ up to 5), including the ambiguous ones, which it
//!   must never certify and which must stay flagged;
//! - the accelerated Gauss–Seidel against plain Gauss–Seidel, sample by
//!   sample on the rough corner (μ = 0.3), and that it does not run with
//!   μ ≥ 0.5.

use crate::support;
use crate::support::Rng;

use glam::{DMat3, DQuat, DVec3};
use impactmc::physics::friction::{
    certified, delassus, newton, newton_with, single_contact, single_contact_full, Case, Contacts,
};
use impactmc::physics::{ContactGeometry, Ellipsoid};
use impactmc::sampler::Sampler;

/// One random single contact: the Delassus block at the point of a random
/// body that touches a plane of random normal, a free contact velocity,
/// the normal bias of a random restitution, and μ.
struct Single1 {
    w: DMat3,
    n: DVec3,
    c: DVec3,
    b: f64,
    mu: f64,
    vscale: f64,
}

fn single(rng: &mut Rng) -> Single1 {
    // Semi-axes over four decades of aspect ratio: spheres, rods, disks.
    let axes = DVec3::new(
        10f64.powf(2.0 * rng.next() - 1.0),
        10f64.powf(2.0 * rng.next() - 1.0),
        10f64.powf(2.0 * rng.next() - 1.0),
    );
    let body = Ellipsoid::new(axes.to_array(), 0.1 + 10.0 * rng.next()).unwrap();
    let q = DQuat::from_xyzw(rng.normal(), rng.normal(), rng.normal(), rng.normal()).normalize();
    let rotation = DMat3::from_quat(q);
    let n = rng.unit();
    // The body point that touches the plane: −D²u/|Du|, u = Aᵀn.
    let u = rotation.transpose() * n;
    let x = -(axes * axes * u) / (axes * u).length();
    let w = delassus(&body, rotation, x, x);
    let v = DVec3::new(rng.normal(), rng.normal(), rng.normal());
    let omega = DVec3::new(rng.normal(), rng.normal(), rng.normal()) / body.length_scale();
    let mut c = v + rotation * omega.cross(x);
    if n.dot(c) > 0.0 {
        c -= 2.0 * n * n.dot(c);
    }
    let k = rng.next();
    let mu = 5.0 * rng.next().powi(2);
    Single1 {
        w,
        n,
        c,
        b: k * n.dot(c).min(0.0),
        mu,
        vscale: v.length() + body.length_scale() * omega.length(),
    }
}

/// Where B3 holds, the full search finds exactly the answer of the
/// certified shortcut (the same case, the impulse to 1e-10 of its size,
/// never ambiguous); where the full search finds several solutions, B3
/// does not hold and the solve still flags them. Over 2·10⁵ random
/// contacts (measured 2026-12-05: B3 holds on 55 % of them, 25 % of those
/// sticking; the full search finds 118 ambiguous ones).
#[test]
fn the_certificate_agrees_with_the_full_search() {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let (mut held, mut ambiguous, mut stick, mut slide) = (0, 0, 0, 0);
    let count = 200_000;
    for k in 0..count {
        let s = single(&mut rng);
        let full = single_contact_full(s.c, s.b, &s.w, s.n, s.mu, s.vscale);
        let fast = single_contact(s.c, s.b, &s.w, s.n, s.mu, s.vscale);
        let b3 = certified(&s.w, s.n, s.mu);
        if full.ambiguous {
            ambiguous += 1;
            assert!(!b3, "contact {k}: B3 holds on an ambiguous contact");
            assert!(fast.ambiguous, "contact {k}: no longer flagged");
        }
        if !b3 {
            assert_eq!(fast, full, "contact {k}: uncertified, yet another answer");
            continue;
        }
        held += 1;
        assert_eq!(fast.case, full.case, "contact {k}");
        assert!(!fast.ambiguous && !fast.unsolved, "contact {k}: {fast:?}");
        let scale = full.impulse.length().max(1e-300);
        assert!(
            (fast.impulse - full.impulse).length() <= 1e-10 * scale,
            "contact {k}: {:?} against {:?}",
            fast.impulse,
            full.impulse
        );
        stick += (fast.case == Case::Stick) as usize;
        slide += (fast.case == Case::Slide) as usize;
    }
    assert!(held > count / 5, "B3 held on {held} of {count}");
    assert!(stick > 1000 && slide > 1000, "stick {stick}, slide {slide}");
    assert!(ambiguous >= 10, "only {ambiguous} ambiguous contacts drawn");
}

/// The touching contacts of sample `i` of a contact-start scene, as the
/// reference's frictional laws see them.
fn contacts_of(scene: &impactmc::config::Scene, sampler: &Sampler, i: u64) -> Contacts {
    let (a, v, w) = sampler.reference(i);
    let centre = scene.centre(a);
    let body = scene.body();
    let planes: Vec<_> = scene.planes().iter().map(|p| p.plane).collect();
    let points: Vec<DVec3> = planes
        .iter()
        .map(|p| ContactGeometry::new(body, a, centre, p).body_point)
        .collect();
    Contacts::new(
        body,
        a,
        v,
        w,
        &points,
        &planes.iter().map(|p| p.normal()).collect::<Vec<_>>(),
        &planes.iter().map(|p| p.friction()).collect::<Vec<_>>(),
        &planes.iter().map(|p| p.restitution()).collect::<Vec<_>>(),
    )
}

/// Sample by sample on the rough corner (μ = 0.3 on every wall, 3,000
/// samples): the accelerated Gauss–Seidel gives plain Gauss–Seidel's
/// impulses to 1e-9 of the impulse scale m(|v| + L|ω|) and its flags, in
/// far fewer sweeps (measured 2026-12-05: at most 4e-12 apart, in 16.7
/// sweeps on average against 98.6).
#[test]
fn accelerated_gauss_seidel_is_plain_gauss_seidel_on_the_rough_corner() {
    let scene = support::shipped_scene("corner3_friction", "f64");
    let sampler = Sampler::new(&scene);
    let (mut fast_sweeps, mut plain_sweeps, mut worst) = (0u64, 0u64, 0f64);
    let count = 3000;
    for i in 0..count {
        let ct = contacts_of(&scene, &sampler, i);
        let fast = newton_with(&ct, true);
        let plain = newton_with(&ct, false);
        assert_eq!(
            (fast.jammed, fast.unconverged, fast.unsolved),
            (plain.jammed, plain.unconverged, plain.unsolved),
            "sample {i}"
        );
        for (p, q) in fast.impulses.iter().zip(&plain.impulses) {
            worst = worst.max((*p - *q).length() / ct.pscale);
        }
        fast_sweeps += fast.sweeps as u64;
        plain_sweeps += plain.sweeps as u64;
        // newton() accelerates here (every μ < 0.5).
        assert_eq!(newton(&ct), fast, "sample {i}");
    }
    assert!(
        worst <= 1e-9,
        "worst difference {worst:e} of the impulse scale"
    );
    let (f, p) = (
        fast_sweeps as f64 / count as f64,
        plain_sweeps as f64 / count as f64,
    );
    assert!(p > 50.0, "plain Gauss–Seidel took {p} sweeps on average");
    assert!(f < 0.4 * p, "accelerated {f} sweeps against plain {p}");
}

/// With μ ≥ 0.5 on a touching plane the acceleration must not run:
/// `newton` is plain Gauss–Seidel, bit for bit.
#[test]
fn no_acceleration_from_mu_one_half() {
    for mu in [0.5, 1.0] {
        let scene = support::rough_scene(
            "corner3",
            mu,
            &format!("no-acceleration-{mu}"),
            &impactmc::config::Overrides {
                precision: Some("f64".parse().unwrap()),
                ..Default::default()
            },
        );
        let sampler = Sampler::new(&scene);
        let mut slow = 0;
        for i in 0..500 {
            let ct = contacts_of(&scene, &sampler, i);
            let plain = newton_with(&ct, false);
            slow += (plain.sweeps > 16) as usize;
            assert_eq!(newton(&ct), plain, "μ = {mu}, sample {i}");
        }
        // Samples where an acceleration would have had room to act.
        assert!(slow > 50, "μ = {mu}: {slow} samples over 16 sweeps");
    }
}

/// The certificate against the full search on every golden friction case:
/// for each touching rough contact, the single-contact solve of its
/// pre-impact contact velocity with Newton's bias (the first visit of
/// every law). Where B3 holds the two agree and nothing is ambiguous;
/// where it does not, the solve is the full search.
#[test]
fn the_certificate_agrees_with_the_full_search_on_the_golden_cases() {
    #[derive(serde::Deserialize)]
    struct Entry {
        input: serde_json::Value,
        #[serde(default)]
        expect_error: bool,
    }
    #[derive(serde::Deserialize)]
    struct File {
        cases: Vec<Entry>,
    }
    let file: File =
        serde_json::from_str(&support::data_file("golden/friction_cases.json")).unwrap();
    let (mut contacts, mut held) = (0, 0);
    for (k, e) in file.cases.iter().enumerate() {
        if e.expect_error {
            continue;
        }
        let input: impactmc::config::case::CaseInput =
            serde_json::from_value(e.input.clone()).unwrap();
        let case = impactmc::config::case::Case::from_input(&input).unwrap();
        let (body, pose, state) = (&case.body, case.pose, case.state);
        let touch = 1e-9 * body.length_scale().max(pose.centre.length());
        for plane in &case.planes {
            let g = ContactGeometry::new(body, pose.rotation, pose.centre, plane);
            if g.distance.abs() > touch || plane.friction() == 0.0 {
                continue;
            }
            let x = g.body_point;
            let n = plane.normal();
            let w = delassus(body, pose.rotation, x, x);
            let c = state.velocity + pose.rotation * state.omega.cross(x);
            let b = plane.restitution() * n.dot(c).min(0.0);
            let vscale = state.velocity.length() + body.length_scale() * state.omega.length();
            let mu = plane.friction();
            let full = single_contact_full(c, b, &w, n, mu, vscale);
            let fast = single_contact(c, b, &w, n, mu, vscale);
            contacts += 1;
            if !certified(&w, n, mu) {
                assert_eq!(fast, full, "case {k}");
                continue;
            }
            held += 1;
            assert!(
                !full.ambiguous,
                "case {k}: B3 holds on an ambiguous contact"
            );
            assert_eq!(fast.case, full.case, "case {k}");
            assert!(
                (fast.impulse - full.impulse).length() <= 1e-10 * full.impulse.length().max(1e-300),
                "case {k}: {:?} against {:?}",
                fast.impulse,
                full.impulse
            );
        }
    }
    // Measured 2026-12-05: B3 holds on 317 of the 359 touching rough
    // contacts.
    assert!(
        contacts > 100 && held > contacts / 4,
        "{held} of {contacts}"
    );
}
