//! Value stability of seeded runs: S1, S2 and S3 in f32 and f64 under the
//! four laws, with a fixed seed, give exactly the counts and the bits of the
//! moments (n, mean, M2, min, max) in `tests/frozen/summaries.txt`.
//!
//! A change that moves any seeded result fails here. Such a change needs a
//! version bump and a CHANGELOG entry; then regenerate the file with
//! `IMPACTMC_FREEZE=1 cargo test --release --test frozen_summaries` and
//! review its diff.

mod support;

use impactmc::config::{load_scene, Overrides};
use impactmc::engine::{run, RunOptions};
use impactmc::stats::Moments;
use support::repo;

const FROZEN: &str = "tests/frozen/summaries.txt";

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
            let r = run(
                &s,
                &RunOptions {
                    threads: 2,
                    ..Default::default()
                },
            )
            .expect("run");
            for (law, a) in s.laws().iter().zip(&r.acc.laws) {
                let mut l = format!(
                    "{scene} {precision} {}: samples={} impacts={} energy_gain={} degenerate={} jammed={} unsolved={} recomputed={} penetrating={} active_sets={:?}",
                    law.name(),
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
                lines.push(l);
            }
        }
    }
    lines
}

#[test]
fn seeded_summaries_are_frozen() {
    let got = fingerprint();
    assert_eq!(got.len(), 3 * 2 * 4);
    let path = repo(FROZEN);
    if std::env::var_os("IMPACTMC_FREEZE").is_some() {
        std::fs::write(&path, got.join("\n") + "\n").expect("write the frozen file");
        return;
    }
    let text = std::fs::read_to_string(&path).expect("tests/frozen/summaries.txt");
    let want: Vec<&str> = text.lines().collect();
    assert_eq!(want.len(), got.len(), "{FROZEN}: line count");
    for (g, w) in got.iter().zip(&want) {
        assert_eq!(g, w, "a seeded result moved (see this file's header)");
    }
}
