//! The sampler's draws: value stability, the transforms' distributions,
//! and RQMC points.

use super::*;

fn sampler(seed: u64) -> Sampler {
    Sampler {
        rng: CounterRng::new(seed, WORDS),
        boxes: rng::drop_start_rng(seed),
        points: Points::Mc,
        orientation_needed: true,
        matrix_rows: ALL_ROWS,
        orientation: OrientationDist::Uniform,
        velocity: VectorDist::Fixed(DVec3::ZERO),
        angular_velocity: VectorDist::Fixed(DVec3::ZERO),
    }
}

/// Value stability of the draws: the 52-bit integers k of the f64
/// uniforms (k + ½)·2⁻⁵², computed once from the module notes' word
/// layout by an independent Python implementation of SplitMix64.
/// Changing them changes every seeded result: a deliberate decision and
/// a version bump.
#[test]
fn draws_are_frozen() {
    let s = sampler(42);
    let want: [(u64, [u64; 9]); 2] = [
        (
            0,
            [
                2029098098584163,
                1201813910028967,
                2473972865410187,
                3352543597182741,
                4066727417352526,
                583196261555283,
                4140893753844133,
                56444775705590,
                4415853579443453,
            ],
        ),
        (
            1_000_000_007,
            [
                146971034081284,
                261147499335548,
                3839864956428190,
                1801187253391987,
                834816944512625,
                1545269381926959,
                4503127835676428,
                4095400509254592,
                572114929692372,
            ],
        ),
    ];
    for (i, ks) in want {
        for (j, k) in ks.into_iter().enumerate() {
            let u = (k as f64 + 0.5) / 4_503_599_627_370_496.0;
            assert_eq!(s.u::<f64>(i, j as u32), u, "sample {i} draw {j}");
            // The f32 draw is the f64 draw's top 23 bits.
            let u32_ = ((k >> 29) as f64 + 0.5) / 8_388_608.0;
            assert_eq!(s.u::<f32>(i, j as u32) as f64, u32_, "sample {i} draw {j}");
        }
    }
}

/// Every draw of a sample uses bits no other draw of it uses.
#[test]
fn draws_of_a_sample_are_distinct() {
    let s = sampler(7);
    for i in 0..1000u64 {
        let mut us: Vec<f64> = (0..DRAWS_PER_SAMPLE).map(|j| s.u::<f64>(i, j)).collect();
        us.sort_by(f64::total_cmp);
        us.dedup();
        assert_eq!(us.len(), DRAWS_PER_SAMPLE as usize);
    }
}

const DRAWS_PER_SAMPLE: u32 = 9;

/// A fill of some rows of a Haar orientation writes exactly what the
/// whole fill writes in those rows, and `orientation_of` gives the
/// whole fill's matrix bit for bit, in both lane types (a lane the
/// reference recomputes is completed with it).
fn partial_rows_are_the_whole_fill<T: Real>() {
    for points in [Points::Mc, Points::Rqmc(Sobol::new(5, 11))] {
        partial_rows_are_the_whole_fill_with::<T>(points);
    }
}

fn partial_rows_are_the_whole_fill_with<T: Real>(points: Points) {
    let mut s = sampler(5);
    s.points = points;
    s.velocity = VectorDist::Normal {
        mean: DVec3::new(0.0, 0.0, -1.0),
        sd: DVec3::splat(0.5),
    };
    s.angular_velocity = s.velocity;
    // RQMC: across the lookup table's runs, in one replicate.
    let first = 5 * BLOCK as u64;
    let mut whole = Inputs::<T>::new();
    // `orientation_of` is every distribution's fill, lane by lane (the
    // Haar one last: `whole` keeps it for the partial fills below).
    for orientation in [
        OrientationDist::Fixed(DMat3::from_rotation_y(0.7)),
        OrientationDist::BryanUniform {
            low: DVec3::new(-0.5, 0.1, -3.0),
            high: DVec3::new(0.5, 1.2, 3.0),
        },
        s.orientation,
    ] {
        let other = Sampler { orientation, ..s };
        other.fill(first, &mut whole);
        for l in 0..BLOCK {
            let a = other.orientation_of::<T>(first + l as u64);
            for k in 0..9 {
                assert_eq!(
                    a[k].to_f64().to_bits(),
                    whole.a[k][l].to_f64().to_bits(),
                    "{orientation:?} lane {l} entry {k}"
                );
            }
        }
    }
    assert!(matches!(s.orientation, OrientationDist::Uniform));
    for rows in 1..ALL_ROWS {
        let part = s.with_matrix_rows(rows);
        assert!(part.partial_rows());
        let mut x = Inputs::<T>::new();
        part.fill(first, &mut x);
        for k in 0..9 {
            if rows & (1 << (k / 3)) != 0 {
                assert!(x.a[k] == whole.a[k], "rows {rows:#b}: entry {k}");
            }
        }
        assert!(
            x.v == whole.v && x.w == whole.w,
            "rows {rows:#b}: velocities"
        );
    }
    assert!(!s.partial_rows());
}

#[test]
fn partial_rows_are_the_whole_fill_f32() {
    partial_rows_are_the_whole_fill::<f32>();
}

#[test]
fn partial_rows_are_the_whole_fill_f64() {
    partial_rows_are_the_whole_fill::<f64>();
}

/// Every combination of the distributions and both sampling methods
/// (each pass of `fill` reads
/// its draws from the rows the uniform pass wrote, before the
/// orientation overwrites them): the lanes give the reference sampler's
/// inputs, in f64 to rounding, with orientations skipped or not.
#[test]
fn every_combination_of_distributions_matches_the_reference() {
    let orientations = [
        OrientationDist::Uniform,
        OrientationDist::Fixed(DMat3::from_rotation_x(0.3) * DMat3::from_rotation_z(1.1)),
        OrientationDist::BryanUniform {
            low: DVec3::new(-0.5, 0.1, -3.0),
            high: DVec3::new(0.5, 1.2, 3.0),
        },
    ];
    let vectors = [
        VectorDist::Normal {
            mean: DVec3::new(-1.0, 0.5, -2.0),
            sd: DVec3::new(0.5, 1.5, 0.25),
        },
        VectorDist::Uniform {
            low: DVec3::new(-1.0, 0.0, -4.0),
            high: DVec3::new(1.0, 0.5, -2.0),
        },
        VectorDist::Fixed(DVec3::new(0.25, -0.5, 2.0)),
    ];
    // RQMC: samples 960..1152 of replicate 0 of 2^11, across the
    // lookup table's runs.
    let first = 5 * BLOCK as u64;
    let mut x = Inputs::<f64>::new();
    for orientation in orientations {
        for velocity in vectors {
            for angular_velocity in vectors {
                for (orientation_needed, points) in [
                    (true, Points::Mc),
                    (false, Points::Mc),
                    (true, Points::Rqmc(Sobol::new(3, 11))),
                    (false, Points::Rqmc(Sobol::new(3, 11))),
                ] {
                    let s = Sampler {
                        rng: CounterRng::new(11, WORDS),
                        boxes: rng::drop_start_rng(11),
                        points,
                        orientation_needed,
                        matrix_rows: ALL_ROWS,
                        orientation,
                        velocity,
                        angular_velocity,
                    };
                    s.fill(first, &mut x);
                    let case = format!("{orientation:?} {velocity:?} {angular_velocity:?} {orientation_needed} {points:?}");
                    for l in 0..BLOCK {
                        let (a, v, w) = s.reference(first + l as u64);
                        let a = if orientation_needed {
                            a
                        } else {
                            DMat3::IDENTITY
                        };
                        let got_a =
                            DMat3::from_cols_array(&std::array::from_fn(|k| x.a[k][l])).transpose();
                        let err = (got_a - a)
                            .to_cols_array()
                            .iter()
                            .chain(
                                (DVec3::from_array(std::array::from_fn(|k| x.v[k][l])) - v)
                                    .as_ref(),
                            )
                            .chain(
                                (DVec3::from_array(std::array::from_fn(|k| x.w[k][l])) - w)
                                    .as_ref(),
                            )
                            .fold(0f64, |m, e| m.max(e.abs()));
                        assert!(err < 1e-13, "{case}, lane {l}: {err:e}");
                    }
                }
            }
        }
    }
}
