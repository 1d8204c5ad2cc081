//! A target precision: `--target-ci STAT=EPS` grows the sample count in
//! rounds until the half-width is reached, and the result is the
//! fixed-count run of the last round's count.

use serde_json::Value;

use crate::support::{bin, repo, tmpdir, without_timing};

/// `impactmc run configs/corner3.toml --format json` with `flags`; the
/// summary, or the error's text.
fn run(tag: &str, flags: &[&str]) -> Result<Value, String> {
    let o = bin()
        .arg("run")
        .arg(repo("configs/corner3.toml"))
        .arg("--out")
        .arg(tmpdir(tag).join("out"))
        .args(["--format", "json"])
        .args(flags)
        .output()
        .unwrap();
    if o.status.success() {
        Ok(serde_json::from_slice(&o.stdout).unwrap())
    } else {
        Err(String::from_utf8(o.stderr).unwrap())
    }
}

/// The widest 95 % half-width of the mean energy ratio over the laws.
fn energy_ratio_ci95(v: &Value) -> f64 {
    v["laws"]
        .as_object()
        .unwrap()
        .values()
        .map(|l| {
            l["groups"]["all"]["stats"]["energy_ratio"]["ci95"]
                .as_f64()
                .unwrap()
        })
        .fold(0.0, f64::max)
}

/// From 10⁶ samples, `energy_ratio=1e-4` on S3 stops at the first count of
/// its rounds whose ci95 is at most 1e-4; `--samples` with that count gives
/// the same summary, and the round before did not reach it.
#[test]
fn a_target_stops_at_the_first_count_that_reaches_it() {
    let target = run(
        "target",
        &["--samples", "1e6", "--target-ci", "energy_ratio=1e-4"],
    )
    .unwrap();
    let t = &target["target"];
    assert_eq!(t["reached"], true, "{t}");
    let rounds: Vec<u64> = t["rounds"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r.as_u64().unwrap())
        .collect();
    let last = *rounds.last().unwrap();
    assert!(rounds.len() >= 2 && rounds[0] == 1_000_000, "{rounds:?}");
    assert_eq!(target["samples"].as_u64(), Some(last));
    let ci = energy_ratio_ci95(&target);
    assert!(ci <= 1e-4, "{ci}");
    assert_eq!(t["statistics"][0]["statistic"], "energy_ratio");
    assert_eq!(t["statistics"][0]["achieved"].as_f64(), Some(ci));
    let fixed = run("target-fixed", &["--samples", &last.to_string()]).unwrap();
    let mut strip = without_timing(target.clone());
    strip.as_object_mut().unwrap().remove("target");
    assert_eq!(strip, without_timing(fixed));
    let before = rounds[rounds.len() - 2];
    let earlier = run("target-before", &["--samples", &before.to_string()]).unwrap();
    assert!(energy_ratio_ci95(&earlier) > 1e-4, "{before} samples");
}

/// A budget too small: the run stops at `--max-samples`, says the target
/// was not reached, and the text says so in one line.
#[test]
fn a_budget_that_is_too_small_is_reported() {
    let v = run(
        "target-budget",
        &[
            "--samples",
            "100000",
            "--target-ci",
            "energy_ratio=1e-5",
            "--target-ci",
            "impacting=1e-3",
            "--max-samples",
            "300_000",
        ],
    )
    .unwrap();
    let t = &v["target"];
    assert_eq!(t["reached"], false);
    assert_eq!(v["samples"].as_u64(), Some(300_000));
    // In name order; the fraction's half-width is reached, the mean's not.
    assert_eq!(t["statistics"][0]["statistic"], "energy_ratio");
    assert_eq!(t["statistics"][0]["reached"], false);
    assert_eq!(t["statistics"][1]["statistic"], "impacting");
    assert_eq!(t["statistics"][1]["reached"], true);
    let o = bin()
        .arg("run")
        .arg(repo("configs/corner3.toml"))
        .arg("--out")
        .arg(tmpdir("target-text").join("out"))
        .args(["--samples", "1000", "--target-ci", "energy_ratio=1e-9"])
        .args(["--max-samples", "2000"])
        .output()
        .unwrap();
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(
        text.contains("NOT reached within max_samples 2000 (at 2000 samples)"),
        "{text}"
    );
}

/// Bad targets fail before any work, naming the flag and the value.
#[test]
fn bad_targets_name_the_flag() {
    let e = run("target-bad", &["--target-ci", "energy_rati=1e-4"]).unwrap_err();
    assert!(
        e.contains("--target-ci") && e.contains("\"energy_rati\""),
        "{e}"
    );
    let e = run("target-zero", &["--target-ci", "energy_ratio=0"]).unwrap_err();
    assert!(e.contains("--target-ci") && e.contains("got 0"), "{e}");
    let e = run("target-form", &["--target-ci", "energy_ratio"]).unwrap_err();
    assert!(e.contains("STAT=EPS"), "{e}");
    let e = run(
        "target-max",
        &["--target-ci", "energy_ratio=1e-4", "--max-samples", "10"],
    )
    .unwrap_err();
    assert!(e.contains("--max-samples") && e.contains("got 10"), "{e}");
    let e = run(
        "target-shard",
        &["--target-ci", "energy_ratio=1e-4", "--shard", "0/2"],
    )
    .unwrap_err();
    assert!(e.contains("cannot be sharded"), "{e}");
}

/// The same target in the scene file, `[target]`.
#[test]
fn a_target_in_the_scene_file() {
    let text = std::fs::read_to_string(repo("configs/corner3.toml")).unwrap()
        + "\n[target]\nci95 = { energy_ratio = 3e-4 }\nmax_samples = 50_000_000\n";
    let d = tmpdir("target-scene");
    std::fs::write(d.join("scene.toml"), text).unwrap();
    let o = bin()
        .arg("run")
        .arg(d.join("scene.toml"))
        .arg("--out")
        .arg(d.join("out"))
        .args(["--samples", "100000", "--format", "json"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["target"]["reached"], true);
    assert_eq!(v["target"]["max_samples"].as_u64(), Some(50_000_000));
    assert!(energy_ratio_ci95(&v) <= 3e-4);
}

/// Under RQMC the rounds are whole powers of two per replicate, and the
/// result is again the fixed-count run of the last round.
#[test]
fn an_rqmc_target_is_a_fixed_count_run() {
    let flags = ["--sampling", "rqmc", "--samples", "16384"];
    let v = run(
        "target-rqmc",
        &[&flags[..], &["--target-ci", "energy_ratio=1e-4"]].concat(),
    )
    .unwrap();
    let t = &v["target"];
    assert_eq!(t["reached"], true, "{t}");
    let last = v["samples"].as_u64().unwrap();
    assert!(last.is_power_of_two() && last > 16384, "{last}");
    assert!(energy_ratio_ci95(&v) <= 1e-4);
    let fixed = run(
        "target-rqmc-fixed",
        &["--sampling", "rqmc", "--samples", &last.to_string()],
    )
    .unwrap();
    let mut strip = without_timing(v.clone());
    strip.as_object_mut().unwrap().remove("target");
    assert_eq!(strip, without_timing(fixed));
}
