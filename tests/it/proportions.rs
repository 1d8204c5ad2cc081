//! Intervals on proportions: Wilson's score interval for every share a
//! summary reports, its coverage on a proportion whose value is known, a
//! positive upper bound for a count of none, and the replicates' interval
//! under RQMC.

use impactmc::config::{Overrides, Scene};
use impactmc::engine::{run, RunOptions};
use impactmc::output::summary::{Interval, Summary};

use crate::support::edited_scene;

/// The standard normal's distribution function at −2 (scipy's
/// `norm.cdf(-2)`).
const PHI_MINUS_2: f64 = 0.022750131948179195;

/// S1 with a sphere and no spin whose centre moves at v_z ~ N(`mean_z`,
/// 0.5): the contact point moves with the centre, so a sample impacts
/// exactly when v_z < 0.
fn sphere(mean_z: &str, o: Overrides) -> Scene {
    edited_scene(
        "floor_sphere",
        &[(
            "mean = [0.0, 0.0, -1.0]",
            &format!("mean = [0.0, 0.0, {mean_z}]"),
        )],
        &format!("proportions-{mean_z}"),
        &o,
    )
    .expect("scene")
}

fn summary(scene: &Scene) -> Summary {
    let r = run(
        scene,
        &RunOptions {
            threads: 1,
            ..Default::default()
        },
    )
    .expect("run");
    Summary::new(scene, &r)
}

/// With v_z ~ N(1, 0.5), a sample impacts with probability Φ(−2) ≈ 0.023:
/// over 400 seeds of 1000 samples (about 23 impacts each) Wilson's
/// interval of `impacting` covers it 95 % of the time, within 3.5
/// binomial standard deviations (365 to 395 of 400). Its exact coverage
/// there is 0.944 (the binomial sum over statsmodels' Wilson intervals;
/// the normal interval's is 0.929).
#[test]
fn wilson_intervals_cover_a_known_proportion() {
    let seeds = 400u64;
    let mut covered = 0;
    for seed in 0..seeds {
        let s = summary(&sphere(
            "1.0",
            Overrides {
                samples: Some(1000),
                seed: Some(7000 + seed),
                ..Default::default()
            },
        ));
        let all = s.all_group("newton").expect("newton");
        let p = all.fractions["impacting"];
        let ci = all.fractions_ci95["impacting"];
        assert!(ci.low() <= p && p <= ci.high(), "{ci:?} excludes {p}");
        // The same interval for the active set "floor".
        assert_eq!(all.active_sets_ci95["floor"], ci);
        covered += (ci.low() <= PHI_MINUS_2 && PHI_MINUS_2 <= ci.high()) as u32;
    }
    eprintln!("Wilson's interval covered Φ(−2) in {covered} of {seeds} seeds");
    assert!((365..=395).contains(&covered), "covered {covered}");
}

/// A count of none has the interval [0, z²/(n + z²)], not a width of 0: in
/// JSON, in the text and in summary.parquet.
#[test]
fn a_count_of_none_has_a_positive_upper_bound() {
    let n = 100_000u64;
    // Every sample approaches (v_z ~ N(−5, 0.5) is positive with
    // probability Φ(−10), 8e-24); a sphere without spin never gains energy.
    let s = summary(&sphere(
        "-5.0",
        Overrides {
            samples: Some(n),
            ..Default::default()
        },
    ));
    let all = s.all_group("newton").expect("newton");
    assert_eq!(all.fractions["energy_gain"], 0.0);
    let ci = all.fractions_ci95["energy_gain"];
    let z2 = 1.959963984540054f64.powi(2);
    assert_eq!(ci.low(), 0.0);
    assert!((ci.high() - z2 / (n as f64 + z2)).abs() < 1e-15, "{ci:?}");
    assert_eq!(all.fractions["impacting"], 1.0);
    assert_eq!(all.fractions_ci95["impacting"].high(), 1.0);
    assert!(all.fractions_ci95["impacting"].low() < 1.0);
    let json = serde_json::to_value(&s).unwrap();
    let pair = &json["laws"]["newton"]["groups"]["all"]["fractions_ci95"]["energy_gain"];
    assert_eq!(pair[0], 0.0);
    assert!(pair[1].as_f64().unwrap() > 3e-5, "{pair}");
    let back: Summary = serde_json::from_value(json).unwrap();
    assert_eq!(
        back.all_group("newton").unwrap().fractions_ci95["energy_gain"],
        ci
    );
    let text = s.to_text();
    assert!(text.contains("energy_gain 0 (≤ 3.8e-5)"), "{text}");
}

/// Under RQMC the interval of a proportion comes from the replicates'
/// spread: it is centred on the share and narrower than Wilson's of the
/// same count, and a count of none keeps Wilson's upper bound.
#[test]
fn rqmc_proportion_intervals_come_from_the_replicates() {
    let s = summary(&sphere(
        "1.0",
        Overrides {
            samples: Some(16 << 12),
            sampling: Some("rqmc".into()),
            replicates: Some(16),
            ..Default::default()
        },
    ));
    let all = s.all_group("newton").expect("newton");
    let (p, ci) = (all.fractions["impacting"], all.fractions_ci95["impacting"]);
    let k = (p * all.samples as f64).round() as u64;
    let pooled = Interval::wilson(k, all.samples);
    assert!((p - PHI_MINUS_2).abs() < pooled.half_width());
    assert!(
        ((ci.low() + ci.high()) / 2.0 - p).abs() < 1e-15,
        "{ci:?} about {p}"
    );
    assert!(
        ci.half_width() < pooled.half_width(),
        "replicates {ci:?}, Wilson {pooled:?}"
    );
    assert!(all.fractions_gain["impacting"] > 1.0);
    assert_eq!(
        all.fractions_ci95["energy_gain"],
        Interval::wilson(0, all.samples)
    );
}
