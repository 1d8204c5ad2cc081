//! Value stability of seeded runs: S1, S2 and S3 in f32 and f64 under the
//! four laws, with a fixed seed, give exactly the counts and the bits of the
//! moments (n, mean, M2, min, max) in `tests/frozen/summaries.txt`; the
//! frictional floor (μ = 0.5) and S3 with μ = 0.3 on every wall under the
//! frictional laws, with their friction statistics, those in
//! `tests/frozen/friction-summaries.txt`; the drop scenes `drop_corner` and
//! `drop_dice` (rough) with their per-bounce, ending and sequence counts,
//! those in `tests/frozen/drop-summaries.txt`.
//!
//! A change that moves any seeded result fails here. Such a change needs a
//! version bump and a CHANGELOG entry; then regenerate the file with
//! `IMPACTMC_FREEZE=1 cargo test --release --test it frozen_summaries` and
//! review their diffs.

use crate::support;

use impactmc::config::{load_scene, Overrides, Scene};
use impactmc::engine::{run, RunOptions};
use impactmc::stats::accumulators::LawAcc;
use impactmc::stats::drops::DropAcc;
use impactmc::stats::Moments;
use support::{repo, rough_scene};

const FROZEN: &str = "tests/frozen/summaries.txt";
const FROZEN_FRICTION: &str = "tests/frozen/friction-summaries.txt";
const FROZEN_DROPS: &str = "tests/frozen/drop-summaries.txt";

fn moments(name: &str, m: &Moments) -> String {
    let (n, mean, m2, min, max) = m.state();
    format!(
        " {name}=n{n}:{:016x}:{:016x}:{:016x}:{:016x}",
        mean.to_bits(),
        m2.to_bits(),
        min.to_bits(),
        max.to_bits()
    )
}

/// One law's counts and moments, with its friction statistics if any.
fn law_line(key: &str, a: &LawAcc) -> String {
    let mut l = format!(
        "{key}: samples={} impacts={} energy_gain={} degenerate={} jammed={} unsolved={} recomputed={} penetrating={} active_sets={:?}",
        a.samples,
        a.impacts,
        a.energy_gain,
        a.degenerate,
        a.jammed,
        a.unsolved,
        a.recomputed,
        a.penetrating,
        a.active_sets
    );
    l += &moments("energy_ratio", &a.energy_ratio.moments);
    l += &moments("omega_after_norm", &a.omega_after_norm.moments);
    l += &moments("velocity_after_norm", &a.velocity_after_norm.moments);
    for (i, st) in a.impulse.iter().enumerate() {
        l += &moments(&format!("impulse{i}"), &st.moments);
    }
    for (i, st) in a.rebound.iter().enumerate() {
        l += &moments(&format!("rebound{i}"), &st.moments);
    }
    for (i, r) in a.restitution.iter().enumerate() {
        l += &moments(&format!("restitution{i}.resid"), &r.resid);
        l += &moments(&format!("restitution{i}.y"), &r.y);
        l += &moments(&format!("restitution{i}.sum"), &r.sum);
    }
    if let Some(f) = &a.friction {
        l += &format!(
            " ambiguous={} unconverged={} active={:?} sticking={:?}",
            f.ambiguous, f.unconverged, f.active, f.sticking
        );
        for (i, st) in f.tangential_impulse.iter().enumerate() {
            l += &moments(&format!("tangential{i}"), &st.moments);
        }
        for (i, st) in f.sliding_speed.iter().enumerate() {
            l += &moments(&format!("sliding{i}"), &st.moments);
        }
    }
    l
}

/// The non-zero cells of a count table, as `index:count` pairs.
fn sparse(counts: &[u64]) -> String {
    let cells: Vec<String> = counts
        .iter()
        .enumerate()
        .filter(|(_, &c)| c != 0)
        .map(|(i, c)| format!("{i}:{c}"))
        .collect();
    format!("[{}]", cells.join(","))
}

/// One law's drop statistics: counts by impacts, ending, final axis and
/// sequence, then per bounce its counts and moments.
fn drop_line(key: &str, d: &DropAcc) -> String {
    let mut l = format!(
        "{key} drops: samples={} reference={}/{} lane_search={}/{} impacts={:?} endings={:?} final_axis_up={:?} sequences={}",
        d.samples,
        d.reference_flights,
        d.reference_impacts,
        d.lane_flights,
        d.lane_poses,
        d.impacts,
        d.endings,
        d.final_axis_up(),
        sparse(&d.sequences)
    );
    for (k, b) in d.bounces.iter().enumerate() {
        l += &format!(
            " | bounce{k}: reached={} sets={:?} within={:?} energy_gain={} degenerate={}",
            b.reached, b.sets, b.within, b.energy_gain, b.degenerate
        );
        l += &moments("energy_ratio", &b.energy_ratio);
        l += &moments("interval", &b.interval);
        l += &moments("speed_before", &b.speed_before);
    }
    l
}

/// A scene run on two threads: one [`law_line`] per law, keyed `KEY LAW`,
/// and for a drop scene one [`drop_line`] after it.
fn run_lines(key: &str, s: &Scene) -> Vec<String> {
    let r = run(
        s,
        &RunOptions {
            threads: 2,
            ..Default::default()
        },
    )
    .expect("run");
    let mut lines = Vec::new();
    for (i, (law, a)) in s.laws().iter().zip(&r.acc.laws).enumerate() {
        let key = format!("{key} {}", law.name());
        lines.push(law_line(&key, a));
        if let Some(d) = r.acc.drops.get(i) {
            lines.push(drop_line(&key, d));
        }
    }
    lines
}

/// Compares `got` with a frozen file, or rewrites it under
/// `IMPACTMC_FREEZE`.
fn check_frozen(file: &str, got: &[String]) {
    let path = repo(file);
    if std::env::var_os("IMPACTMC_FREEZE").is_some() {
        std::fs::write(&path, got.join("\n") + "\n").expect("write the frozen file");
        return;
    }
    let text = std::fs::read_to_string(&path).expect(file);
    let want: Vec<&str> = text.lines().collect();
    assert_eq!(want.len(), got.len(), "{file}: line count");
    for (g, w) in got.iter().zip(&want) {
        assert_eq!(g, w, "a seeded result moved (see this file's header)");
    }
}

/// One line per (scene, precision, law).
fn fingerprint() -> Vec<String> {
    let mut lines = Vec::new();
    for scene in ["floor", "corner2_paper", "corner3"] {
        for precision in ["f32", "f64"] {
            let s = load_scene(
                &repo(&format!("configs/{scene}.toml")),
                &Overrides {
                    samples: Some(150_000),
                    seed: Some(2026),
                    precision: Some(precision.parse().expect("f32 or f64")),
                    laws: Some(
                        ["newton", "paper", "poisson", "pgs20"]
                            .map(String::from)
                            .into(),
                    ),
                    ..Default::default()
                },
            )
            .expect("shipped scene");
            // Three batches, so the merge tree is exercised too.
            lines.extend(run_lines(&format!("{scene} {precision}"), &s));
        }
    }
    lines
}

#[test]
fn seeded_summaries_are_frozen() {
    let got = fingerprint();
    assert_eq!(got.len(), 3 * 2 * 4);
    check_frozen(FROZEN, &got);
}

/// A shipped scene with friction μ on every plane that has none, seeded.
fn rough(name: &str, mu: f64, precision: &str, samples: u64, laws: &[&str]) -> Scene {
    rough_scene(
        name,
        mu,
        &format!("frozen-friction-{name}-{precision}"),
        &Overrides {
            samples: Some(samples),
            seed: Some(2026),
            precision: Some(precision.parse().expect("f32 or f64")),
            laws: Some(laws.iter().map(|l| l.to_string()).collect()),
            ..Default::default()
        },
    )
}

#[test]
fn seeded_friction_summaries_are_frozen() {
    let mut got = Vec::new();
    for precision in ["f32", "f64"] {
        for (name, samples, laws) in [
            (
                "floor_friction",
                100_000,
                &["newton", "paper", "pgs8", "stronge"][..],
            ),
            ("corner3", 5_000, &["newton", "paper", "pgs8"][..]),
        ] {
            // Stronge runs on the reference in either precision: once.
            let laws: Vec<&str> = laws
                .iter()
                .copied()
                .filter(|&l| l != "stronge" || precision == "f64")
                .collect();
            let s = rough(name, 0.3, precision, samples, &laws);
            got.extend(run_lines(&format!("{name} {precision}"), &s));
        }
    }
    assert_eq!(got.len(), 2 * (3 + 3) + 1);
    check_frozen(FROZEN_FRICTION, &got);
}

/// The drop scenes, seeded: the triaxial corner rattle under `newton` and
/// `paper`, and the rough die under `newton` and `stronge` (whose impacts
/// on several planes at once fall back to `newton`), in the lanes of each
/// precision.
#[test]
fn seeded_drop_summaries_are_frozen() {
    let mut got = Vec::new();
    for precision in ["f64", "f32"] {
        for (name, laws) in [
            ("drop_corner", &["newton", "paper"][..]),
            ("drop_dice", &["newton", "stronge"][..]),
        ] {
            let s = load_scene(
                &repo(&format!("configs/{name}.toml")),
                &Overrides {
                    samples: Some(10_000),
                    seed: Some(2026),
                    precision: Some(precision.parse().expect("f32 or f64")),
                    laws: Some(laws.iter().map(|l| l.to_string()).collect()),
                    ..Default::default()
                },
            )
            .expect("shipped scene");
            // 4096-sample batches: three of them, so the merge tree is exercised.
            got.extend(run_lines(&format!("{name} {precision}"), &s));
        }
    }
    assert_eq!(got.len(), 2 * 2 * 2 * 2);
    check_frozen(FROZEN_DROPS, &got);
}
