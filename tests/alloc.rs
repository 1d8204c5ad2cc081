//! The reference's full single-contact search (every case tried, every
//! slide root searched: candidates, slides, Durand–Kerner) and the building
//! of an impact's contacts (`Contacts::new`, Delassus blocks included)
//! allocate nothing. Its own test binary, without the test harness's threads, so
//! that the counting allocator sees this search alone.

use std::alloc::System;

use glam::{DMat3, DVec3};
use impactmc::physics::friction::{single_contact_full, Case, Contacts};
use impactmc::physics::{Ellipsoid, MAX_DROP_PLANES};
use stats_alloc::{Region, StatsAlloc, INSTRUMENTED_SYSTEM};

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

/// A deterministic spread of inputs: Delassus blocks `AᵀA + εI`, velocities
/// and normals from a small linear congruential sequence, μ from 0.05 to 2.
fn inputs() -> Vec<(DVec3, f64, DMat3, DVec3, f64)> {
    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = move || {
        x = x
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (x >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    (0..2000)
        .map(|_| {
            let a = DMat3::from_cols_array(&std::array::from_fn(|_| next()));
            let w = a.transpose() * a + DMat3::IDENTITY * 0.05;
            let n = DVec3::new(next(), next(), next()).normalize_or(DVec3::Z);
            let c = DVec3::new(next(), next(), next()) - n * (1.5 + next().abs());
            let mu = 0.05 + 1.95 * next().abs();
            (c, 0.3 * next().abs(), w, n, mu)
        })
        .collect()
}

fn main() {
    let cases = inputs();
    // The counter sees an allocation (the check can fail).
    let control = Region::new(GLOBAL);
    let v: Vec<u64> = std::hint::black_box(vec![1, 2, 3]);
    assert!(
        control.change().allocations >= 1,
        "the counter missed a Vec"
    );
    drop(v);

    let (mut stick, mut slide) = (0, 0);
    let region = Region::new(GLOBAL);
    for &(c, b, w, n, mu) in &cases {
        let s = single_contact_full(c, b, &w, n, mu, 1.0 + c.length());
        match s.case {
            Case::Stick => stick += 1,
            Case::Slide => slide += 1,
            _ => {}
        }
        std::hint::black_box(s);
    }
    let stats = region.change();
    assert_eq!(
        (stats.allocations, stats.reallocations),
        (0, 0),
        "the single-contact search allocated: {stats:?}"
    );
    // Both branches of the search were exercised.
    assert!(stick > 100 && slide > 100, "stick {stick}, slide {slide}");
    println!(
        "alloc: {} single-contact searches ({stick} stick, {slide} slide), no allocation",
        cases.len()
    );

    // Contacts of one to MAX_DROP_PLANES planes, built in place.
    let body = Ellipsoid::new([0.3, 0.2, 0.1], 2.0).unwrap();
    let points: Vec<DVec3> = (0..MAX_DROP_PLANES)
        .map(|i| DVec3::new(0.1 * i as f64, -0.05, 0.02 * i as f64))
        .collect();
    let normals: Vec<DVec3> = (0..MAX_DROP_PLANES)
        .map(|i| DVec3::new(1.0, i as f64, 2.0).normalize())
        .collect();
    let mu: Vec<f64> = (0..MAX_DROP_PLANES).map(|i| 0.1 * i as f64).collect();
    let k = [0.5; MAX_DROP_PLANES];
    let rotation = DMat3::from_rotation_y(0.3);
    let region = Region::new(GLOBAL);
    let mut scale = 0.0;
    for n in 1..=MAX_DROP_PLANES {
        let ct = Contacts::new(
            &body,
            rotation,
            DVec3::new(0.1, 0.0, -1.0),
            DVec3::new(0.0, 2.0, 0.5),
            &points[..n],
            &normals[..n],
            &mu[..n],
            &k[..n],
        );
        assert_eq!(ct.len(), n);
        scale += std::hint::black_box(ct).w[n - 1][0].x_axis.x;
    }
    let stats = region.change();
    assert_eq!(
        (stats.allocations, stats.reallocations),
        (0, 0),
        "Contacts::new allocated: {stats:?}"
    );
    assert!(scale.is_finite());
    println!("alloc: Contacts::new for 1 to {MAX_DROP_PLANES} planes, no allocation");
}
