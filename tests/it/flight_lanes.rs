//! The torque-free attitude in lanes against the f64 reference
//! (`physics::TorqueFree::at`), lane by lane, on random triaxial bodies,
//! attitudes, spins and times, in both precisions.

use glam::{DMat3, DQuat, DVec3};
use impactmc::kernel::flight::{poses, PoseLanes, Poses};
use impactmc::lanes::dispatch::BLOCK;
use impactmc::lanes::Real;
use impactmc::physics::TorqueFree;

use crate::support::Rng;

/// A block of random motions and times: (motion, time) per lane.
fn block(rng: &mut Rng) -> Vec<(TorqueFree, f64)> {
    (0..BLOCK)
        .map(|_| {
            let axes = DVec3::new(0.2 + rng.next(), 0.2 + rng.next(), 0.2 + rng.next());
            let sq = axes * axes;
            let inertia = DVec3::new(sq.y + sq.z, sq.x + sq.z, sq.x + sq.y) * 0.2;
            let q = DQuat::from_xyzw(rng.normal(), rng.normal(), rng.normal(), rng.normal())
                .normalize();
            let spin = 10f64.powf(rng.next() * 2.0 - 0.5);
            let omega = DVec3::new(rng.normal(), rng.normal(), rng.normal()) * spin;
            let t = 2.0 * rng.next();
            (TorqueFree::new(inertia, DMat3::from_quat(q), omega), t)
        })
        .collect()
}

/// Largest differences from the reference over closed-form lanes: of the
/// attitude's entries, and of ω relative to |ω|; and the lanes compared.
fn errors<T: Real>(motions: &[(TorqueFree, f64)]) -> (f64, f64, usize) {
    let mut c = PoseLanes::<T>::new();
    let mut t = [T::ZERO; BLOCK];
    for (s, (m, ts)) in motions.iter().enumerate() {
        c.set(s, m);
        t[s] = T::from_f64(*ts);
    }
    let mut out = Poses::<T>::new();
    poses(&c, &t, &mut out);
    let (mut er, mut ew, mut n) = (0f64, 0f64, 0);
    for (s, (m, _)) in motions.iter().enumerate() {
        if !c.closed(s) {
            continue;
        }
        n += 1;
        let (want_r, want_w) = m.at(t[s].to_f64());
        let (got_r, got_w) = out.lane(s);
        let d = (got_r - want_r).to_cols_array();
        er = er.max(d.iter().fold(0.0, |a, x| a.max(x.abs())));
        ew = ew.max((got_w - want_w).length() / want_w.length());
    }
    (er, ew, n)
}

#[test]
fn lane_poses_match_the_reference_in_f64_and_f32() {
    let mut rng = Rng(0x2545_f491_4f6c_dd1d);
    let (mut worst64, mut worst32, mut lanes) = ((0f64, 0f64), (0f64, 0f64), 0);
    for _ in 0..40 {
        let motions = block(&mut rng);
        let (r, w, n) = errors::<f64>(&motions);
        worst64 = (worst64.0.max(r), worst64.1.max(w));
        let (r, w, _) = errors::<f32>(&motions);
        worst32 = (worst32.0.max(r), worst32.1.max(w));
        lanes += n;
    }
    println!("{lanes} lanes: f64 {worst64:?}, f32 {worst32:?}");
    assert!(lanes > 7000, "closed-form lanes {lanes}");
    assert!(worst64.0 < 1e-12 && worst64.1 < 1e-12, "f64 {worst64:?}");
    assert!(worst32.0 < 1e-4 && worst32.1 < 1e-4, "f32 {worst32:?}");
}

/// The time of impact in lanes against the reference's, flight by flight,
/// on the first flights of `drop_corner` (10⁴ samples): in f64 the same
/// outcome (an impact or none) and the same time to 1e-9 s; in f32 the
/// same outcome and the time to 1e-4 s for all but a counted few.
#[test]
fn lane_times_of_impact_match_the_reference() {
    use impactmc::config::{load_scene, Overrides, Placement};
    use impactmc::kernel::flight::{times_of_impact, FlightLanes, Times};
    use impactmc::physics::{time_of_impact, Rotation};
    let s = load_scene(
        &crate::support::repo("configs/drop_corner.toml"),
        &Overrides::default(),
    )
    .unwrap();
    let Placement::Drop(start) = s.placement() else {
        panic!("a drop scene")
    };
    let sampler = impactmc::sampler::Sampler::new(&s);
    let planes: Vec<_> = s.planes().iter().map(|p| p.plane).collect();
    let fx = s.effects();
    let gravity = DVec3::new(0.0, 0.0, -fx.gravity);
    let (tol, horizon) = (fx.toi_tolerance, fx.horizon);
    let (mut worst64, mut worst32, mut off32, mut compared) = (0f64, 0f64, 0usize, 0usize);
    for b in 0..(10_000 / BLOCK as u64 + 1) {
        let motions: Vec<_> = (0..BLOCK as u64)
            .map(|k| impactmc::engine::drop::start_of(start, &sampler, b * BLOCK as u64 + k))
            .collect();
        let mut f64s = FlightLanes::<f64, 3>::new(s.body(), &planes, gravity, tol, horizon);
        let mut f32s = FlightLanes::<f32, 3>::new(s.body(), &planes, gravity, tol, horizon);
        for (k, m) in motions.iter().enumerate() {
            f64s.set(k, s.body(), m);
            f32s.set(k, s.body(), m);
        }
        let (mut t64, mut t32) = (Times::<f64>::new(), Times::<f32>::new());
        times_of_impact(&f64s, 400, &mut Poses::new(), &mut t64);
        times_of_impact(&f32s, 400, &mut Poses::new(), &mut t32);
        for (k, m) in motions.iter().enumerate() {
            if !f64s.pose.closed(k) {
                continue;
            }
            let want = time_of_impact(
                s.body(),
                m,
                &planes,
                gravity,
                Rotation::Elliptic,
                tol,
                horizon,
            );
            assert!(
                t64.done[k] && t32.done[k] && !t64.stuck[k] && !t32.stuck[k],
                "lane {k} of block {b} still open: f64 {} at {}, f32 {} at {}; reference {:?}",
                t64.done[k],
                t64.time[k],
                t32.done[k],
                t32.time[k],
                want.as_ref().map(|w| (w.time, w.iterations))
            );
            assert_eq!(t64.hit[k], want.is_some(), "block {b} lane {k}");
            compared += 1;
            if let Some(w) = want {
                worst64 = worst64.max((t64.time[k] - w.time).abs());
                let d32 = (t32.time[k] as f64 - w.time).abs();
                if t32.hit[k] && d32 <= 1e-4 {
                    worst32 = worst32.max(d32);
                } else {
                    off32 += 1;
                }
            }
        }
    }
    println!("{compared} flights: f64 |Δt| ≤ {worst64:e} s, f32 {worst32:e} s, f32 off {off32}");
    assert!(compared > 9_000);
    assert!(worst64 <= 1e-9, "f64 {worst64:e}");
    assert!(off32 * 1000 <= compared, "f32: {off32} of {compared} off");
}

/// Grazing flights never step past a contact, in either precision: a
/// triaxial body thrown up under a ceiling whose apex passes it by
/// clearances from −1 mm to +1 mm (down to 1e-7 m), spinning slowly. The
/// reference, run at the lanes' own tolerance, is the judge: where it finds
/// a contact the lanes find one no later, and at the lanes' time of impact
/// (or, where they find none, at the reference's) the body is never more
/// than the tolerance inside the ceiling.
#[test]
fn grazing_flights_never_step_past_a_contact() {
    grazing::<f64>();
    grazing::<f32>();
}

fn grazing<T: Real>() {
    use impactmc::kernel::flight::{times_of_impact, FlightLanes, Times};
    use impactmc::physics::{time_of_impact, ContactGeometry, Ellipsoid, Motion, Plane, Rotation};
    let body = Ellipsoid::new([0.5, 0.3, 0.2], 50.0).unwrap();
    let g = DVec3::new(0.0, 0.0, -9.81);
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let (mut hits, mut compared) = (0, 0);
    for b in 0..8 {
        let mut motions = Vec::new();
        let mut planes_of = Vec::new();
        for k in 0..BLOCK {
            let q = DQuat::from_xyzw(rng.normal(), rng.normal(), rng.normal(), rng.normal())
                .normalize();
            let rotation = DMat3::from_quat(q);
            let omega = DVec3::new(rng.normal(), rng.normal(), rng.normal()) * 1e-3;
            let m = Motion {
                centre: DVec3::ZERO,
                rotation,
                velocity: DVec3::new(0.0, 0.0, 2.0 + rng.next()),
                omega,
            };
            // The support toward +z at the apex, nearly the start's (slow spin).
            let apex_t = m.velocity.z / 9.81;
            let apex = m.velocity.z * apex_t - 0.5 * 9.81 * apex_t * apex_t;
            let h = (body.semi_axes() * (rotation.transpose() * DVec3::Z)).length();
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            let clearance = sign * 10f64.powf(-7.0 + 4.0 * rng.next());
            let ceiling = Plane::new([0.0, 0.0, -1.0], apex + h + clearance, 0.5).unwrap();
            motions.push(m);
            planes_of.push(ceiling);
        }
        // One plane per lane: each block's lanes share planes, so run one
        // lane's plane per block of identical planes.
        for (k, m) in motions.iter().enumerate() {
            let planes = [planes_of[k]];
            let mut f = FlightLanes::<T, 1>::new(&body, &planes, g, 1e-9, 10.0);
            f.set(0, &body, m);
            let mut times = Times::<T>::new();
            times_of_impact(&f, 100_000, &mut Poses::new(), &mut times);
            if !f.pose.closed(0) {
                continue;
            }
            compared += 1;
            let tol = f.tolerance();
            let want = time_of_impact(&body, m, &planes, g, Rotation::Elliptic, tol, 10.0);
            let depth = |t: f64| {
                let (r, _) = TorqueFree::new(body.inertia(), m.rotation, m.omega).at(t);
                let c = m.centre + m.velocity * t + g * (0.5 * t * t);
                ContactGeometry::new(&body, r, c, &planes[0]).distance
            };
            assert!(
                times.done[0] && !times.stuck[0],
                "{} block {b} lane {k}",
                T::NAME
            );
            let t = times.time[0].to_f64();
            if times.hit[0] {
                hits += 1;
                assert!(
                    depth(t) >= -2.0 * tol,
                    "{} lane {k}: {} m at the lanes' impact",
                    T::NAME,
                    depth(t)
                );
            }
            if let Some(w) = want {
                // In f32 the time itself rounds (1.5e-8 s at 0.24 s, and a
                // grazing contact's time is ill-conditioned): the depth
                // above is the test there.
                let late = if T::NAME == "f64" {
                    1e-9
                } else {
                    f64::INFINITY
                };
                assert!(
                    times.hit[0] && t <= w.time + late,
                    "{} lane {k}: reference contact at {} s, lanes {} at {t} s",
                    T::NAME,
                    w.time,
                    times.hit[0]
                );
            } else if !times.hit[0] {
                // Neither: the apex passed the ceiling without touching.
                let apex_t = m.velocity.z / 9.81;
                assert!(
                    depth(apex_t) >= -2.0 * tol,
                    "{} lane {k}: missed a contact",
                    T::NAME
                );
            }
        }
    }
    assert!(
        compared > 1000 && hits > 300,
        "{}: {hits} hits of {compared}",
        T::NAME
    );
}
