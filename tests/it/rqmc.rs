//! Randomized quasi-Monte Carlo (`sampling = "rqmc"`), against things the
//! code did not produce: scipy's unscrambled Sobol points, the net property
//! counted in elementary intervals, long independent MC runs (unbiased, and
//! the reported intervals' coverage over many seeds), and the same answers
//! for any thread or shard count.

use impactmc::config::{load_scene, Overrides, Scene};
use impactmc::engine::{run, RunOptions};
use impactmc::output::summary::{StatSummary, Summary};
use impactmc::sampler::sobol::{unscrambled, Sobol};

use crate::support::{self, repo, succeeded};

fn scene(name: &str, o: Overrides) -> Scene {
    load_scene(&repo(&format!("configs/{name}.toml")), &o).expect("scene")
}

fn rqmc(samples: u64, replicates: u64, seed: u64, precision: &str) -> Overrides {
    Overrides {
        samples: Some(samples),
        seed: Some(seed),
        sampling: Some("rqmc".into()),
        replicates: Some(replicates),
        laws: Some(vec!["newton".into()]),
        precision: Some(precision.parse().unwrap()),
        ..Default::default()
    }
}

fn summary(scene: &Scene, threads: usize) -> Summary {
    let r = run(
        scene,
        &RunOptions {
            threads,
            ..Default::default()
        },
    )
    .expect("run");
    Summary::new(scene, &r)
}

fn stat<'a>(s: &'a Summary, name: &str) -> &'a StatSummary {
    &s.all_group("newton").expect("newton").stats[name]
}

/// The unscrambled points are scipy's (`qmc.Sobol(d=12, scramble=False,
/// bits=32)`, the first 2^10 points, in `tests/data/sobol`).
#[test]
fn unscrambled_points_are_scipys() {
    let data = support::data_file("sobol/scipy_unscrambled_1024x12.txt");
    let rows: Vec<Vec<u32>> = data
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| {
            l.split_whitespace()
                .map(|x| u32::from_str_radix(x, 16).unwrap())
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), 1024);
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(row.len(), 12);
        for (d, &want) in row.iter().enumerate() {
            assert_eq!(unscrambled(i as u64, d), want, "point {i} dimension {d}");
        }
    }
}

/// Whether the points (32-bit fractions) of two dimensions are a (t, m,
/// 2)-net in base 2: every elementary box 2^-a × 2^-b with a + b = m − t
/// holds exactly 2^t of the 2^m points.
fn is_net(xs: &[u32], ys: &[u32], m: u32, t: u32) -> bool {
    let k = m - t;
    (0..=k).all(|a| {
        let b = k - a;
        let mut counts = vec![0u32; 1 << k];
        for (&x, &y) in xs.iter().zip(ys) {
            let cx = if a == 0 { 0 } else { (x >> (32 - a)) as usize };
            let cy = if b == 0 { 0 } else { (y >> (32 - b)) as usize };
            counts[(cx << b) | cy] += 1;
        }
        counts.iter().all(|&c| c == 1 << t)
    })
}

/// Every scrambled replicate keeps the net property of the unscrambled
/// points, for every pair of the twelve dimensions and every power-of-two
/// prefix up to 2^10: each pair's quality t is that of scipy's points,
/// and each dimension alone is a (0, m, 1)-net.
#[test]
fn scrambled_replicates_are_nets() {
    let data = support::data_file("sobol/scipy_unscrambled_1024x12.txt");
    let plain: Vec<Vec<u32>> = (0..12)
        .map(|d| {
            data.lines()
                .filter(|l| !l.starts_with('#'))
                .map(|l| u32::from_str_radix(l.split_whitespace().nth(d).unwrap(), 16).unwrap())
                .collect()
        })
        .collect();
    let sobol = Sobol::new(2024, 10);
    for r in [0u64, 1, 7] {
        let pts: Vec<Vec<u32>> = (0..12)
            .map(|d| {
                (0..1024u64)
                    .map(|i| sobol.point((r << 10) + i, d))
                    .collect()
            })
            .collect();
        // Scrambled: no point is left where it was.
        assert_ne!(pts[0], plain[0]);
        for m in [4u32, 7, 10] {
            let n = 1 << m;
            for d in 0..12 {
                let mut cells: Vec<u32> = pts[d][..n].iter().map(|x| x >> (32 - m)).collect();
                cells.sort_unstable();
                assert!(
                    cells.iter().enumerate().all(|(k, &c)| c == k as u32),
                    "replicate {r}: dimension {d}, 2^{m} points"
                );
                for e in d + 1..12 {
                    let t = (0..=m)
                        .find(|&t| is_net(&plain[d][..n], &plain[e][..n], m, t))
                        .expect("t = m always holds");
                    assert!(
                        is_net(&pts[d][..n], &pts[e][..n], m, t),
                        "replicate {r}: dimensions {d}, {e}, 2^{m} points, t = {t}"
                    );
                }
            }
        }
    }
}

/// The mean over many replicates agrees with a long MC run within 4σ
/// (σ from both runs' intervals): S1, S3 and the first impact of a drop.
#[test]
fn rqmc_is_unbiased() {
    for (name, rq, mc, precision) in [
        ("floor", (64, 1 << 12), 20_000_000, "f64"),
        ("corner3", (64, 1 << 12), 20_000_000, "f32"),
        ("drop_corner", (32, 1 << 8), 100_000, "f64"),
    ] {
        let r = summary(&scene(name, rqmc(rq.0 * rq.1, rq.0, 7, precision)), 0);
        let m = summary(
            &scene(
                name,
                Overrides {
                    samples: Some(mc),
                    seed: Some(8),
                    laws: Some(vec!["newton".into()]),
                    precision: Some(precision.parse().unwrap()),
                    ..Default::default()
                },
            ),
            0,
        );
        assert_eq!(r.samples, rq.0 * rq.1);
        for st in ["energy_ratio", "velocity_after_norm"] {
            let (a, b) = (stat(&r, st), stat(&m, st));
            assert!(a.gain.is_some() && b.gain.is_none());
            let sigma = ((a.ci95 / 2.0).powi(2) + (b.ci95 / 1.96).powi(2)).sqrt();
            assert!(
                (a.mean - b.mean).abs() < 4.0 * sigma,
                "{name} {st}: rqmc {} ± {}, mc {} ± {}",
                a.mean,
                a.ci95,
                b.mean,
                b.ci95
            );
        }
    }
}

/// Over 400 seeds, the reported ci95 of S1's mean energy ratio and mean
/// speed after covers the long-run value 95 % of the time, within 3.5
/// binomial standard deviations (365 to 395 of 400); the long run's own
/// error is far below the intervals.
#[test]
fn rqmc_intervals_cover() {
    let long = summary(
        &scene(
            "floor",
            Overrides {
                samples: Some(40_000_000),
                seed: Some(1),
                precision: Some("f64".parse().unwrap()),
                ..Default::default()
            },
        ),
        0,
    );
    let seeds = 400u64;
    for st in ["energy_ratio", "velocity_after_norm"] {
        let truth = stat(&long, st);
        let mut covered = 0;
        let mut widest_ratio = f64::INFINITY;
        for seed in 0..seeds {
            let s = summary(&scene("floor", rqmc(16 << 10, 16, 1000 + seed, "f64")), 1);
            let e = stat(&s, st);
            covered += ((e.mean - truth.mean).abs() <= e.ci95) as u32;
            widest_ratio = widest_ratio.min(e.ci95 / truth.ci95);
        }
        assert!(
            widest_ratio > 5.0,
            "{st}: the long run is not precise enough ({widest_ratio})"
        );
        eprintln!("{st}: the ci95 covered the long-run value in {covered} of {seeds} seeds");
        assert!(
            (365..=395).contains(&covered),
            "{st}: covered {covered} of {seeds}"
        );
    }
}

/// The same answers for one or two threads, and for three shards merged.
#[test]
fn rqmc_is_deterministic_across_threads_and_shards() {
    let s = scene("corner3", rqmc(1 << 20, 8, 5, "f32"));
    let untimed =
        |threads| support::without_timing(serde_json::to_value(summary(&s, threads)).unwrap());
    assert_eq!(untimed(1), untimed(2));

    let dir = support::tmpdir("rqmc-shards");
    let args = |extra: &[&str]| {
        let mut v: Vec<String> = [
            "run",
            repo("configs/corner3.toml").to_str().unwrap(),
            "--samples",
            "1048576",
            "--seed",
            "5",
            "--sampling",
            "rqmc",
            "--replicates",
            "8",
            "--law",
            "newton",
            "--format",
            "json",
        ]
        .iter()
        .map(|x| x.to_string())
        .collect();
        v.extend(extra.iter().map(|x| x.to_string()));
        v
    };
    let whole = dir.join("whole");
    let out = succeeded(
        support::bin()
            .args(args(&["--out", whole.to_str().unwrap()]))
            .output()
            .unwrap(),
    );
    let whole_json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let mut shards = Vec::new();
    for i in 0..3 {
        let d = dir.join(format!("shard{i}"));
        succeeded(
            support::bin()
                .args(args(&[
                    "--shard",
                    &format!("{i}/3"),
                    "--out",
                    d.to_str().unwrap(),
                ]))
                .output()
                .unwrap(),
        );
        shards.push(d);
    }
    let merged = dir.join("merged");
    let mut cmd = support::bin();
    cmd.arg("merge")
        .arg("--out")
        .arg(&merged)
        .arg("--format")
        .arg("json");
    for d in &shards {
        cmd.arg(d);
    }
    let out = succeeded(cmd.output().unwrap());
    let merged_json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let strip = support::without_timing;
    let (w, m) = (strip(whole_json), strip(merged_json));
    assert_eq!(w["sampling"]["replicates"], 8);
    assert!(w["laws"]["newton"]["groups"]["all"]["stats"]["energy_ratio"]["gain"].is_number());
    assert_eq!(w, m);
}

/// The default `mc` runs as before: no `sampling` block, no gains.
#[test]
fn mc_summaries_have_no_replicate_fields() {
    let s = summary(
        &scene(
            "corner3",
            Overrides {
                samples: Some(100_000),
                ..Default::default()
            },
        ),
        0,
    );
    let json = serde_json::to_value(&s).unwrap();
    assert!(json.get("sampling").is_none());
    let all = &json["laws"]["newton"]["groups"]["all"];
    assert!(all["stats"]["energy_ratio"].get("gain").is_none());
    assert!(all.get("active_sets_gain").is_none());
    assert!(all.get("fractions_gain").is_none());
}

/// Requested samples become whole replicates of a power of two of points,
/// at least as many as asked for; per-sample rows carry the replicate.
#[test]
fn samples_map_to_whole_replicates() {
    let s = scene("corner3", rqmc(1_000_000, 16, 1, "f32"));
    assert_eq!(s.samples(), 16 << 16);
    let s = scene("corner3", rqmc(100, 3, 1, "f32"));
    assert_eq!(s.samples(), 3 * 64);
    assert_eq!(s.batch_size(), 64);
    let s = summary(&s, 0);
    assert_eq!(s.samples, 192);
    let sampling = s.sampling.as_ref().unwrap();
    assert_eq!(
        (sampling.replicates, sampling.samples_per_replicate),
        (3, 64)
    );

    let dir = support::tmpdir("rqmc-rows");
    succeeded(
        support::bin()
            .args([
                "run",
                repo("configs/corner3.toml").to_str().unwrap(),
                "--samples",
                "1000",
                "--sampling",
                "rqmc",
                "--replicates",
                "4",
                "--per-sample",
                "--columns",
                "energy_ratio_newton",
                "--out",
            ])
            .arg(&dir)
            .output()
            .unwrap(),
    );
    let batches = support::read_parquet(&dir.join("samples.parquet"));
    let rep = support::column::<arrow_array::types::UInt32Type>(&batches, "replicate");
    let sample = support::column::<arrow_array::types::UInt64Type>(&batches, "sample");
    assert_eq!(sample.len(), 4 * 256);
    for (r, i) in rep.iter().zip(&sample) {
        assert_eq!(*r as u64, i / 256);
    }
    // summary.parquet: the gains beside the intervals, as in the JSON.
    let json = support::json_file(&dir.join("summary.json"));
    let table = support::read_parquet(&dir.join("summary.parquet"));
    let gain = support::column::<arrow_array::types::Float64Type>(&table, "energy_ratio_gain");
    let ci = support::column::<arrow_array::types::Float64Type>(&table, "energy_ratio_ci95");
    let all = &json["laws"]["newton"]["groups"]["all"]["stats"]["energy_ratio"];
    assert_eq!(gain[0], all["gain"].as_f64().unwrap());
    assert_eq!(ci[0], all["ci95"].as_f64().unwrap());
    support::column::<arrow_array::types::Float64Type>(&table, "fraction_impacting_gain");
}

/// Each bad sampling input is one error naming the field and the value.
#[test]
fn bad_sampling_input_names_the_field() {
    for (o, want) in [
        (
            Overrides {
                sampling: Some("sobol".into()),
                ..Default::default()
            },
            "sampling: must be \"mc\" or \"rqmc\", got \"sobol\"",
        ),
        (
            Overrides {
                sampling: Some("rqmc".into()),
                replicates: Some(1),
                ..Default::default()
            },
            "replicates: must be in 2..=2^20",
        ),
        (
            Overrides {
                replicates: Some(8),
                ..Default::default()
            },
            "replicates: is for sampling = \"rqmc\" only (sampling is \"mc\"), got 8",
        ),
        (
            Overrides {
                sampling: Some("rqmc".into()),
                replicates: Some(16),
                samples: Some(10),
                ..Default::default()
            },
            "samples: must be at least replicates (16) with sampling = \"rqmc\", got 10",
        ),
    ] {
        let e = load_scene(&repo("configs/corner3.toml"), &o)
            .err()
            .unwrap_or_else(|| panic!("accepted {o:?}"))
            .to_string();
        assert!(e.contains(want), "{e}");
    }
    // A replicate count that is not an integer, in the scene file.
    let e = support::edited_scene(
        "corner3",
        &[(
            "precision = \"f32\"",
            "precision = \"f32\"\nsampling = \"rqmc\"\nreplicates = 2.5",
        )],
        "rqmc-float",
        &Overrides::default(),
    )
    .unwrap_err();
    assert!(
        e.contains(":8: replicates: invalid type: floating point `2.5`"),
        "{e}"
    );
}

/// The default S3 run with RQMC (10⁷ requested: 16 × 2²⁰) gives a mean
/// energy ratio interval at least 5× narrower than MC's at the same sample
/// count, and the rough floor's RQMC run (friction lanes) agrees with MC.
#[test]
fn rqmc_narrows_the_default_s3_interval_fivefold() {
    let r = summary(
        &scene(
            "corner3",
            Overrides {
                sampling: Some("rqmc".into()),
                ..Default::default()
            },
        ),
        0,
    );
    let m = summary(
        &scene(
            "corner3",
            Overrides {
                samples: Some(r.samples),
                ..Default::default()
            },
        ),
        0,
    );
    assert_eq!(r.samples, 16 << 20);
    let (a, b) = (stat(&r, "energy_ratio"), stat(&m, "energy_ratio"));
    assert!(
        b.ci95 > 5.0 * a.ci95,
        "rqmc {} against mc {}",
        a.ci95,
        b.ci95
    );

    let rough = |o: Overrides| summary(&scene("floor_friction", o), 0);
    let r = rough(rqmc(16 << 14, 16, 3, "f32"));
    let m = rough(Overrides {
        samples: Some(4_000_000),
        seed: Some(4),
        laws: Some(vec!["newton".into()]),
        ..Default::default()
    });
    let (a, b) = (stat(&r, "energy_ratio"), stat(&m, "energy_ratio"));
    let sigma = ((a.ci95 / 2.0).powi(2) + (b.ci95 / 1.96).powi(2)).sqrt();
    assert!((a.mean - b.mean).abs() < 4.0 * sigma, "{a:?} {b:?}");
    assert!(a.gain.is_some_and(|g| g > 1.0), "{a:?}");
}
