//! Sharded runs and their merge: N shards merged give the single run's
//! outputs to the last bit (summary JSON, summary and histogram tables);
//! missing, duplicated and foreign shards are refused with the indices or
//! fields named; the Slurm job script works with SLURM_ARRAY_TASK_ID set by
//! a loop.

use crate::support;

use support::{bin, repo};

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use polars::prelude::*;

fn tmpdir(tag: &str) -> PathBuf {
    support::tmpdir(&format!("shards-{tag}"))
}

/// corner3 with two laws (so paired differences are merged too), small
/// batches so that 40 000 samples make 40 batches (39 full, one short).
fn scene(d: &Path, extra: &str) -> PathBuf {
    let text = std::fs::read_to_string(repo("configs/corner3.toml")).unwrap();
    let text = text.replacen(
        "samples = ",
        &format!("batch_size = 1024\n{extra}samples = "),
        1,
    );
    // Every histogram the engine can keep goes through the shard state,
    // not only the default's.
    let text = text
        + "\n[statistics]\nquantiles = [\"energy_ratio\", \"omega_after_norm\", \
           \"velocity_after_norm\", \"impulse\", \"rebound\"]\n";
    let p = d.join("scene.toml");
    std::fs::write(&p, text).unwrap();
    p
}

const SAMPLES: &str = "40000";

fn run(scene: &Path, out: &Path, extra: &[&str]) -> Output {
    bin()
        .arg("run")
        .arg(scene)
        .args(["--samples", SAMPLES, "--law", "newton", "--law", "paper"])
        .args(["--format", "json", "--out"])
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

fn merge(dirs: &[PathBuf], out: &Path, extra: &[&str]) -> Output {
    bin()
        .arg("merge")
        .args(dirs)
        .args(["--format", "json", "--out"])
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

/// The summary JSON without what legitimately differs (timings, threads).
fn summary_without_timing(stdout: &[u8]) -> serde_json::Value {
    support::without_timing(serde_json::from_slice(stdout).unwrap())
}

/// The first path at which two JSON values differ, for short messages.
fn first_difference(a: &serde_json::Value, b: &serde_json::Value, path: &str) -> Option<String> {
    match (a, b) {
        (serde_json::Value::Object(x), serde_json::Value::Object(y)) => {
            for (k, v) in x {
                match y.get(k) {
                    Some(w) => {
                        if let Some(d) = first_difference(v, w, &format!("{path}.{k}")) {
                            return Some(d);
                        }
                    }
                    None => return Some(format!("{path}.{k} missing on the right")),
                }
            }
            y.keys()
                .find(|k| !x.contains_key(*k))
                .map(|k| format!("{path}.{k} missing on the left"))
        }
        (serde_json::Value::Array(x), serde_json::Value::Array(y)) if x.len() == y.len() => x
            .iter()
            .zip(y)
            .enumerate()
            .find_map(|(i, (v, w))| first_difference(v, w, &format!("{path}[{i}]"))),
        _ => (a != b).then(|| format!("{path}: {a} vs {b}")),
    }
}

fn assert_same_summary(got: &serde_json::Value, want: &serde_json::Value, what: &str) {
    if let Some(d) = first_difference(got, want, "") {
        panic!("{what}: merged summary differs from the single run at {d}");
    }
}

fn frame(path: &Path) -> DataFrame {
    ParquetReader::new(std::fs::File::open(path).unwrap())
        .finish()
        .unwrap()
}

fn assert_same_tables(a: &Path, b: &Path) {
    // Histograms: every column, bit for bit.
    let (ha, hb) = (
        frame(&a.join("histograms.parquet")),
        frame(&b.join("histograms.parquet")),
    );
    assert!(ha.height() > 100, "histograms too small to mean much");
    assert!(ha.equals(&hb), "histograms differ:\n{ha}\n{hb}");
    // Summary table: every column except the timing ones.
    let (sa, sb) = (
        frame(&a.join("summary.parquet")),
        frame(&b.join("summary.parquet")),
    );
    let keep: Vec<String> = sa
        .get_column_names()
        .iter()
        .map(|c| c.to_string())
        .filter(|c| !c.contains("second") && c != "threads")
        .collect();
    assert!(keep.len() > 5);
    let (sa, sb) = (sa.select(keep.clone()).unwrap(), sb.select(keep).unwrap());
    assert!(sa.equals_missing(&sb), "summary tables differ:\n{sa}\n{sb}");
}

fn shards(scene: &Path, d: &Path, n: u64) -> Vec<PathBuf> {
    (0..n)
        .map(|i| {
            let out = d.join(format!("shard-{i}"));
            support::succeeded(run(scene, &out, &["--shard", &format!("{i}/{n}")]));
            out
        })
        .collect()
}

#[test]
fn eight_shards_merge_to_the_single_run_bit_for_bit() {
    let d = tmpdir("eight");
    let scene = scene(&d, "");
    let single = support::succeeded(run(&scene, &d.join("single"), &["--threads", "2"]));
    let parts = shards(&scene, &d, 8);
    // Any order on the command line.
    let mut given = parts.clone();
    given.reverse();
    let merged = support::succeeded(merge(&given, &d.join("merged"), &[]));
    let want = summary_without_timing(&single.stdout);
    let got = summary_without_timing(&merged.stdout);
    assert_eq!(want["samples"], 40000);
    assert_same_summary(&got, &want, "8 shards");
    assert_same_tables(&d.join("single"), &d.join("merged"));
    // The shards' own summaries cover their shares, which add up.
    let shard_samples: u64 = parts
        .iter()
        .map(|p| {
            let s: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(p.join("summary.json")).unwrap())
                    .unwrap();
            s["samples"].as_u64().unwrap()
        })
        .sum();
    assert_eq!(shard_samples, 40000);
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("merged/manifest.json")).unwrap())
            .unwrap();
    assert_eq!(manifest["merge"]["partial"], false);
    assert_eq!(
        manifest["merge"]["shards_merged"].as_array().unwrap().len(),
        8
    );
}

#[test]
fn more_shards_than_batches_and_a_sweep_merge_exactly() {
    let d = tmpdir("sweep");
    // 3 grid points; 40 batches over 3 shards (uneven) and over 64 shards
    // (most of them empty).
    let scene = scene(&d, "");
    let text = std::fs::read_to_string(&scene).unwrap()
        + "\n[sweep]\n\"planes.floor.restitution\" = [0.3, 0.6, 0.9]\n";
    std::fs::write(&scene, text).unwrap();
    let single = support::succeeded(run(&scene, &d.join("single"), &[]));
    let want = summary_without_timing(&single.stdout);
    assert_eq!(want["points"].as_array().unwrap().len(), 3);
    // The MC sweep's paired differences are merged too (from the shards'
    // cluster sums).
    let paired = &want["points"][1]["summary"]["paired_points"];
    assert!(
        paired["laws"]["newton"]["energy_ratio"]["ci95"].as_f64() > Some(0.0),
        "{paired}"
    );
    for n in [3u64, 64] {
        let sd = d.join(format!("n{n}"));
        std::fs::create_dir_all(&sd).unwrap();
        let parts = shards(&scene, &sd, n);
        let merged = support::succeeded(merge(&parts, &sd.join("merged"), &[]));
        assert_same_summary(
            &summary_without_timing(&merged.stdout),
            &want,
            &format!("{n} shards"),
        );
        assert_same_tables(&d.join("single"), &sd.join("merged"));
        watched_merge_counts_shards_and_stops(&parts, &sd);
    }
}

/// The library's merge with a watch: the watch counts every shard read,
/// and a merge asked to stop stops before reading one, with nothing
/// written.
fn watched_merge_counts_shards_and_stops(parts: &[PathBuf], d: &Path) {
    use impactmc::engine::{RunError, Watch};
    use impactmc::study::{merge_study, StudyError};
    let watch = Watch::new();
    let out = d.join("watched");
    let mut study = merge_study(parts, false, &out, Some(&watch)).unwrap();
    study.write().unwrap();
    assert_eq!(
        (watch.done(), watch.total()),
        (parts.len() as u64, parts.len() as u64)
    );
    let stopped = Watch::new();
    stopped.cancel();
    let out = d.join("stopped");
    match merge_study(parts, false, &out, Some(&stopped)) {
        Err(StudyError::Run(RunError::Cancelled)) => {}
        Err(e) => panic!("a cancelled merge failed otherwise: {e}"),
        Ok(_) => panic!("a cancelled merge finished"),
    }
    assert_eq!(stopped.done(), 0);
    assert!(!out.exists(), "a stopped merge wrote {}", out.display());
}

#[test]
fn missing_duplicate_and_foreign_shards_are_refused() {
    let d = tmpdir("refuse");
    let scene = scene(&d, "");
    let parts = shards(&scene, &d, 4);
    let stderr = |o: &Output| String::from_utf8_lossy(&o.stderr).to_string();

    // Missing shard 2: an error naming it, and no run folder.
    let some = vec![parts[0].clone(), parts[1].clone(), parts[3].clone()];
    let o = merge(&some, &d.join("m1"), &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("missing shard indices [2] of 4"),
        "{}",
        stderr(&o)
    );
    assert!(!d.join("m1/manifest.json").exists());

    // Duplicate shard 1.
    let dup = vec![
        parts[0].clone(),
        parts[1].clone(),
        parts[1].clone(),
        parts[2].clone(),
        parts[3].clone(),
    ];
    let o = merge(&dup, &d.join("m2"), &[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("duplicate shard index 1 of 4"),
        "{}",
        stderr(&o)
    );

    // --allow-partial: merged, marked partial, statistics over 3 shards.
    let o = support::succeeded(merge(&some, &d.join("m3"), &["--allow-partial"]));
    let s: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let shard2: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(parts[2].join("summary.json")).unwrap())
            .unwrap();
    assert_eq!(
        s["samples"].as_u64().unwrap() + shard2["samples"].as_u64().unwrap(),
        40000
    );
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("m3/manifest.json")).unwrap())
            .unwrap();
    assert_eq!(m["merge"]["partial"], true);
    assert_eq!(m["merge"]["missing_shards"], serde_json::json!([2]));

    // A shard of another seed, and of another scene.
    let other = d.join("other-seed");
    support::succeeded(run(&scene, &other, &["--shard", "2/4", "--seed", "7"]));
    let mix = vec![parts[0].clone(), parts[1].clone(), other, parts[3].clone()];
    let o = merge(&mix, &d.join("m4"), &[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("seed is \"7\""), "{}", stderr(&o));
    let other = d.join("other-precision");
    support::succeeded(run(
        &scene,
        &other,
        &["--shard", "2/4", "--precision", "f64"],
    ));
    let mix = vec![parts[0].clone(), parts[1].clone(), other, parts[3].clone()];
    let o = merge(&mix, &d.join("m5"), &[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("scene.toml"), "{}", stderr(&o));
    // Not a shard folder at all.
    let o = merge(std::slice::from_ref(&d), &d.join("m6"), &[]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("not a shard folder"), "{}", stderr(&o));
    // Bad --shard values.
    for bad in ["4/4", "1", "a/b", "0/0"] {
        let o = run(&scene, &d.join("bad"), &["--shard", bad]);
        assert_eq!(o.status.code(), Some(2), "--shard {bad}");
        assert!(stderr(&o).contains("--shard"), "{}", stderr(&o));
    }
}

#[test]
fn slurm_array_script_run_by_a_loop_then_merged() {
    let d = tmpdir("slurm");
    let scene = scene(&d, "");
    // The scene's own sample count (10^7) is too many for a test: pass it
    // through EXTRA_ARGS like a user would.
    let extra = format!("--samples {SAMPLES} --law newton --law paper");
    let task = |i: usize| {
        Command::new("bash")
            .arg(repo("deploy/slurm/impactmc-shard.sbatch"))
            .env("SLURM_ARRAY_TASK_ID", i.to_string())
            .env("SHARDS", "4")
            .env("SCENE", &scene)
            .env("OUT", d.join("shards"))
            .env("IMPACTMC", env!("CARGO_BIN_EXE_impactmc"))
            .env("EXTRA_ARGS", &extra)
            .output()
            .unwrap()
    };
    for i in 0..4 {
        support::succeeded(task(i));
    }
    // A failed task re-run: same index, same output (it overwrites).
    support::succeeded(task(1));
    let merged = support::succeeded(
        Command::new("bash")
            .arg(repo("deploy/slurm/impactmc-merge.sbatch"))
            .env("OUT", d.join("shards"))
            .env("MERGED", d.join("merged"))
            .env("IMPACTMC", env!("CARGO_BIN_EXE_impactmc"))
            .env("MERGE_ARGS", "--format json")
            .output()
            .unwrap(),
    );
    let single = support::succeeded(run(&scene, &d.join("single"), &[]));
    assert_same_summary(
        &summary_without_timing(&merged.stdout),
        &summary_without_timing(&single.stdout),
        "slurm loop",
    );
    assert_same_tables(&d.join("single"), &d.join("merged"));
    // Without SLURM_ARRAY_TASK_ID the script says what is missing.
    let o = Command::new("bash")
        .arg(repo("deploy/slurm/impactmc-shard.sbatch"))
        .env_remove("SLURM_ARRAY_TASK_ID")
        .env("SHARDS", "4")
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("SLURM_ARRAY_TASK_ID"));
}
