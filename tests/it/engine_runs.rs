//! `impactmc run` as a whole: determinism across thread counts, the sampler's
//! uniformity on SO(3), and agreement with the independent reference
//! statistics of the floor scene (tests/data/golden/floor_stats.json).

use crate::support;

use support::{repo, scratch};

use glam::{DMat3, DVec3};
use impactmc::config::{load_scene, Overrides, Scene};
use impactmc::engine::{run, RunOptions};
use impactmc::output::summary::{StatSummary, Summary};

fn scene(name: &str, o: Overrides) -> Scene {
    load_scene(&repo(&format!("configs/{name}.toml")), &o).unwrap()
}

fn summary(s: &Scene, threads: usize) -> Summary {
    let r = run(
        s,
        &RunOptions {
            threads,
            progress: false,
            ..Default::default()
        },
    )
    .unwrap();
    Summary::new(s, &r)
}

/// The summary without its timing, for comparisons.
fn without_timing(s: &Summary) -> serde_json::Value {
    support::without_timing(serde_json::to_value(s).unwrap())
}

#[test]
fn same_seed_same_summary_for_1_and_2_threads() {
    // Every histogram the engine can keep, not only the default's.
    let all = Some(impactmc::config::STATISTIC_NAMES.map(String::from).to_vec());
    for precision in ["f32", "f64"] {
        let s = scene(
            "corner3",
            Overrides {
                samples: Some(300_001),
                precision: Some(precision.parse().expect("f32 or f64")),
                laws: Some(vec!["newton".into(), "paper".into(), "pgs4".into()]),
                quantiles: all.clone(),
                ..Overrides::default()
            },
        );
        let one = summary(&s, 1);
        let two = summary(&s, 2);
        let three = summary(&s, 3);
        let g = one.all_group("pgs4").unwrap();
        for stat in ["omega_after_norm", "impulse_floor", "rebound_wall_x"] {
            assert!(g.stats[stat].median.is_some(), "{stat}");
        }
        // serde_json prints f64 round-trip exactly, so equal values mean
        // bit-identical statistics.
        assert_eq!(without_timing(&one), without_timing(&two), "{precision}");
        assert_eq!(without_timing(&one), without_timing(&three), "{precision}");
        // And a different seed gives a different answer (the check can fail).
        let other = scene(
            "corner3",
            Overrides {
                samples: Some(300_001),
                seed: Some(43),
                precision: Some(precision.parse().expect("f32 or f64")),
                laws: Some(vec!["newton".into(), "paper".into(), "pgs4".into()]),
                quantiles: all.clone(),
                ..Overrides::default()
            },
        );
        assert_ne!(without_timing(&one), without_timing(&summary(&other, 2)));
    }
}

/// Kolmogorov–Smirnov statistic of samples against U(0, 1).
fn ks_uniform(mut xs: Vec<f64>) -> f64 {
    xs.sort_by(f64::total_cmp);
    let n = xs.len() as f64;
    xs.iter()
        .enumerate()
        .map(|(i, &x)| (x - i as f64 / n).abs().max(((i + 1) as f64 / n - x).abs()))
        .fold(0.0, f64::max)
}

/// Body-frame images u = Aᵀn of a fixed world normal under the sampler's
/// orientations: (u_z + 1)/2 and the azimuth/2π are U(0, 1) exactly when
/// u is uniform on the sphere (Archimedes).
fn sphere_coordinates(s: &Scene, n: usize) -> (Vec<f64>, Vec<f64>) {
    let normal = DVec3::new(0.3, -0.5, 0.8).normalize();
    let mut z = Vec::with_capacity(n);
    let mut phi = Vec::with_capacity(n);
    for o in impactmc::engine::evaluate_samples(s, impactmc::physics::Law::Paper, 0, n) {
        let a = DMat3::from_cols_array(&o.rotation).transpose();
        let u = a.transpose() * normal;
        z.push((u.z + 1.0) / 2.0);
        phi.push(u.y.atan2(u.x) / std::f64::consts::TAU + 0.5);
    }
    (z, phi)
}

#[test]
fn uniform_orientations_make_the_body_frame_normal_uniform() {
    let n = 200_000;
    // KS critical value at α = 0.001: 1.95/√n.
    let critical = 1.95 / (n as f64).sqrt();
    for precision in ["f32", "f64"] {
        let s = scene(
            "floor",
            Overrides {
                precision: Some(precision.parse().expect("f32 or f64")),
                ..Overrides::default()
            },
        );
        let (z, phi) = sphere_coordinates(&s, n);
        let (dz, dphi) = (ks_uniform(z), ks_uniform(phi));
        assert!(
            dz < critical && dphi < critical,
            "{precision}: KS {dz:.2e}, {dphi:.2e} vs {critical:.2e}"
        );
    }
    // The test has power: uniform Bryan angles are not uniform on SO(3).
    let dir = scratch("bryan");
    std::fs::create_dir_all(&dir).unwrap();
    let text = std::fs::read_to_string(repo("configs/floor.toml"))
        .unwrap()
        .replace(
            "distribution = \"uniform\"\n\n[velocity]",
            "distribution = \"bryan_uniform\"\npsi_deg = [-180.0, 180.0]\ntheta_deg = [-90.0, 90.0]\nphi_deg = [-180.0, 180.0]\n\n[velocity]",
        );
    let path = dir.join("bryan.toml");
    std::fs::write(&path, text).unwrap();
    let s = load_scene(&path, &Overrides::default()).unwrap();
    let (z, phi) = sphere_coordinates(&s, n);
    assert!(
        ks_uniform(z).max(ks_uniform(phi)) > critical,
        "KS failed to reject uniform Bryan angles"
    );
    std::fs::remove_dir_all(dir).unwrap();
}

#[derive(serde::Deserialize)]
struct RefRow {
    law: String,
    statistic: String,
    value: f64,
    ci95_halfwidth: f64,
}

#[derive(serde::Deserialize)]
struct RefFile {
    rows: Vec<RefRow>,
}

#[test]
fn floor_scene_agrees_with_independent_reference_statistics() {
    let reference: RefFile =
        serde_json::from_str(&support::data_file("golden/floor_stats.json")).unwrap();
    for precision in ["f32", "f64"] {
        let s = scene(
            "floor",
            Overrides {
                samples: Some(4_000_000),
                seed: Some(2026),
                precision: Some(precision.parse().expect("f32 or f64")),
                laws: Some(vec!["paper".into(), "newton".into(), "poisson".into()]),
                ..Overrides::default()
            },
        );
        let sum = summary(&s, 0);
        let mut checked = 0;
        for row in &reference.rows {
            let law = if row.law == "any" {
                "newton"
            } else {
                row.law.as_str()
            };
            let all = sum.all_group(law).unwrap();
            let stat = |name: &str| -> &StatSummary { &all.stats[name] };
            let (ours, ci) = match row.statistic.as_str() {
                "frac_impacting" => (
                    all.fractions["impacting"],
                    all.fractions_ci95["impacting"].half_width(),
                ),
                "energy_gain_frac" => (
                    all.fractions["energy_gain"],
                    all.fractions_ci95["energy_gain"].half_width(),
                ),
                "energy_ratio_mean" => (stat("energy_ratio").mean, stat("energy_ratio").ci95),
                // se of an sd ≈ sd/√(2n) for near-normal data; take the
                // reference's own half-width, which has the same n.
                "energy_ratio_sd" => (stat("energy_ratio").sd, row.ci95_halfwidth),
                "omega_post_norm_mean" => {
                    (stat("omega_after_norm").mean, stat("omega_after_norm").ci95)
                }
                "v_post_norm_mean" => (
                    stat("velocity_after_norm").mean,
                    stat("velocity_after_norm").ci95,
                ),
                "impulse_mean_plane0" => (stat("impulse_floor").mean, stat("impulse_floor").ci95),
                other => panic!("unknown reference statistic {other}"),
            };
            let se = ((ci / 1.96).powi(2) + (row.ci95_halfwidth / 1.96).powi(2)).sqrt();
            let bound = 4.0 * se;
            // energy_gain is exactly 0 for one contact: both sides must be 0.
            let ok = if row.value == 0.0 {
                ours == 0.0
            } else {
                (ours - row.value).abs() < bound
            };
            assert!(
                ok,
                "{precision} {} {}: ours {ours} vs ref {} (bound {bound:e})",
                row.law, row.statistic, row.value
            );
            checked += 1;
        }
        assert_eq!(checked, reference.rows.len());
    }
}

#[test]
fn planes_outside_the_placement_are_checked_per_sample() {
    // S1 with a ceiling at Z = 3: the body (c = 2) sits with its centre at
    // h ∈ [1, 2] above the floor and reaches 2h, so tall poses penetrate the
    // ceiling. They are counted as `penetrating` and left out of the impact
    // statistics, at the analytic rate.
    let dir = scratch("ceiling");
    std::fs::create_dir_all(&dir).unwrap();
    let text = std::fs::read_to_string(repo("configs/floor.toml"))
        .unwrap()
        .replace(
            "[placement]",
            "[[planes]]\nname = \"ceiling\"\nnormal = [0.0, 0.0, -1.0]\noffset = 3.0\nrestitution = 0.5\n\n[placement]",
        );
    let path = dir.join("ceiling.toml");
    std::fs::write(&path, text).unwrap();
    for precision in ["f32", "f64"] {
        let s = load_scene(
            &path,
            &Overrides {
                samples: Some(20_000),
                precision: Some(precision.parse().expect("f32 or f64")),
                ..Overrides::default()
            },
        )
        .unwrap();
        let r = run(
            &s,
            &RunOptions {
                threads: 2,
                progress: false,
                ..Default::default()
            },
        )
        .unwrap();
        let newton = &r.acc.laws[0];
        // A pose penetrates when its height 2h exceeds 3, i.e. h > 1.5:
        // h² = 1 + 3u_z² for u uniform on the sphere, so P = P(|u_z| > √(5/12)).
        let expected = 1.0 - (5.0f64 / 12.0).sqrt();
        let got = newton.penetrating as f64 / newton.samples as f64;
        assert!(
            (got - expected).abs() < 0.02,
            "{precision}: penetrating fraction {got} vs {expected}"
        );
        assert!(newton.energy_ratio.moments.mean().is_finite());
        assert_eq!(
            newton.active_sets.iter().sum::<u64>() + newton.penetrating,
            newton.samples
        );
    }
    std::fs::remove_dir_all(dir).unwrap();
}

/// Summary-only runs merge inside a parallel recursion; runs that also
/// stream per-sample rows merge batch by batch in sample order. Both follow
/// the one merge tree, so their statistics are bit-identical.
#[test]
fn summary_only_and_per_sample_runs_merge_alike() {
    use impactmc::engine::run_with_samples;
    use impactmc::output::samples::SampleRows;
    let s = scene(
        "corner3",
        Overrides {
            samples: Some(2_000_003),
            laws: Some(vec!["newton".into(), "paper".into()]),
            ..Overrides::default()
        },
    );
    let plain = summary(&s, 2);
    let mut rows = 0usize;
    let mut sink = |r: SampleRows| -> Result<(), impactmc::engine::SinkError> {
        rows += r.len();
        Ok(())
    };
    let streamed = run_with_samples(
        &s,
        &RunOptions {
            threads: 2,
            ..Default::default()
        },
        Some(&mut sink),
    )
    .unwrap();
    assert_eq!(rows, 2_000_003);
    assert_eq!(
        without_timing(&plain),
        without_timing(&Summary::new(&s, &streamed))
    );
}
