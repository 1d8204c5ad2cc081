//! The Slurm job files on a real cluster: `deploy/slurm/submit.sh` submits a
//! sharded study (a job array and a merge job behind `afterok`), and the
//! merged summary equals a single run's bit for bit. Then one task fails on
//! purpose: the merge job must not start; the task is re-run alone, the
//! merge is run, and the summary is exact again. A drop scene's shards
//! merge exactly through the same job files.
//!
//! Needs a reachable Slurm (`sinfo`); `deploy/slurm/local-cluster.sh start`
//! makes one on this machine. Without one the test is skipped, unless
//! `IMPACTMC_REQUIRE_SLURM=1` (set by `.ci/run`), when it fails.

use crate::support;

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use support::{bin, repo, tmpdir};

const SHARDS: u32 = 8;
const SAMPLES: &str = "1000000";

fn slurm_reachable() -> bool {
    Command::new("sinfo")
        .arg("-h")
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false)
}

/// The summary without what depends on the run's timing and threads.
fn summary(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("summary.json"))
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let m = v.as_object_mut().unwrap();
    m.remove("throughput");
    m.remove("threads");
    v
}

/// A job's state while the controller knows it (`None` once it is gone),
/// with the reason of a pending job.
fn state(job: &str) -> Option<(String, String)> {
    let o = Command::new("squeue")
        .args(["-h", "-j", job, "-o", "%T %r"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    let line = text.lines().next()?;
    let (s, r) = line.split_once(' ').unwrap_or((line, ""));
    Some((s.to_string(), r.to_string()))
}

/// Waits until `done` holds, for at most two minutes.
fn wait_for(what: &str, mut done: impl FnMut() -> bool) {
    let t0 = Instant::now();
    while !done() {
        assert!(
            t0.elapsed() < Duration::from_secs(120),
            "timed out waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(250));
    }
}

/// Submits the corner3 study with `submit.sh`; returns the (array, merge)
/// job ids.
fn submit(work: &Path, out: &Path, fail: Option<u32>) -> (String, String) {
    submit_scene(work, out, fail, "configs/corner3.toml", SAMPLES)
}

fn submit_scene(
    work: &Path,
    out: &Path,
    fail: Option<u32>,
    scene: &str,
    samples: &str,
) -> (String, String) {
    let mut c = Command::new("bash");
    c.arg(repo("deploy/slurm/submit.sh"))
        .current_dir(work)
        .env("SCENE", repo(scene))
        .env("SHARDS", SHARDS.to_string())
        .env("OUT", out)
        .env("CPUS_PER_TASK", "1")
        .env("TIME_LIMIT", "00:10:00")
        .env("IMPACTMC", env!("CARGO_BIN_EXE_impactmc"))
        .env("EXTRA_ARGS", format!("--samples {samples}"));
    match fail {
        Some(i) => c.env("IMPACTMC_FAIL_SHARD", i.to_string()),
        None => c.env_remove("IMPACTMC_FAIL_SHARD"),
    };
    let o = c.output().unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "submit.sh: {}{}",
        stdout,
        String::from_utf8_lossy(&o.stderr)
    );
    let last = stdout.lines().last().unwrap();
    let ids: Vec<&str> = last
        .split(' ')
        .map(|kv| kv.split_once('=').unwrap().1)
        .collect();
    assert!(last.starts_with("array=") && ids.len() == 2, "{stdout}");
    (ids[0].to_string(), ids[1].to_string())
}

#[test]
fn sharded_study_on_a_real_slurm_cluster() {
    if !support::available_or_skip(
        slurm_reachable(),
        "IMPACTMC_REQUIRE_SLURM",
        "a Slurm cluster (sinfo failed)",
        "bash deploy/slurm/local-cluster.sh start makes one",
    ) {
        return;
    }
    let d = tmpdir("slurm-cluster");
    let single = d.join("single");
    let o = bin()
        .args(["run", repo("configs/corner3.toml").to_str().unwrap()])
        .args(["--samples", SAMPLES, "--out", single.to_str().unwrap()])
        .output()
        .unwrap();
    support::assert_succeeded(&o);
    let want = summary(&single);

    // Every task succeeds: the merge job runs after them.
    let ok = d.join("ok");
    let (_, merge) = submit(&d, &ok, None);
    wait_for("the merge job", || state(&merge).is_none());
    assert_eq!(
        summary(&ok.join("merged")),
        want,
        "merged Slurm study against the single run"
    );

    // Task 3 fails: the array ends, and the merge job is held by afterok.
    let bad = d.join("failed");
    let (array, merge) = submit(&d, &bad, Some(3));
    wait_for("the array", || state(&array).is_none());
    // The controller marks the dependency failed when it next evaluates
    // the queue; until then the job is pending on `Dependency`.
    wait_for("the merge job's dependency to fail", || {
        let (s, reason) = state(&merge).expect("the merge job is still queued");
        assert_eq!(s, "PENDING", "merge job after a failed shard");
        assert!(reason.starts_with("Dependency"), "{reason}");
        reason == "DependencyNeverSatisfied"
    });
    assert!(
        !bad.join("merged").exists(),
        "the merge ran after a failed shard"
    );
    assert!(!bad.join("shard-3").join("manifest.json").exists());
    Command::new("scancel").arg(&merge).status().unwrap();

    // Re-run task 3 alone, then the merge: the exact summary again.
    let rerun = |script: &str, extra: &[&str]| -> String {
        let o = Command::new("sbatch")
            .arg("--parsable")
            .args(extra)
            .arg("--export=ALL")
            .arg(repo(&format!("deploy/slurm/{script}")))
            .current_dir(&d)
            .env("SCENE", repo("configs/corner3.toml"))
            .env("SHARDS", SHARDS.to_string())
            .env("OUT", &bad)
            .env("IMPACTMC", env!("CARGO_BIN_EXE_impactmc"))
            .env("EXTRA_ARGS", format!("--samples {SAMPLES}"))
            .env_remove("IMPACTMC_FAIL_SHARD")
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "sbatch {script}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let id = String::from_utf8_lossy(&o.stdout).trim().to_string();
        id.split(';').next().unwrap().to_string()
    };
    let task = rerun("impactmc-shard.sbatch", &["--array=3", "--cpus-per-task=1"]);
    wait_for("the re-run task", || state(&task).is_none());
    let merge = rerun("impactmc-merge.sbatch", &[]);
    wait_for("the merge job", || state(&merge).is_none());
    assert_eq!(
        summary(&bad.join("merged")),
        want,
        "merged after a re-run shard"
    );
}

/// A drop scene through the same job files: 8 shards of drop_corner
/// (10 batches of 4,096 samples) merged by the merge job equal a single
/// run, bounces and sequences included.
#[test]
fn sharded_drop_study_on_a_real_slurm_cluster() {
    if !support::available_or_skip(
        slurm_reachable(),
        "IMPACTMC_REQUIRE_SLURM",
        "a Slurm cluster (sinfo failed)",
        "bash deploy/slurm/local-cluster.sh start makes one",
    ) {
        return;
    }
    let samples = "40000";
    let d = tmpdir("slurm-drop");
    let single = d.join("single");
    let o = bin()
        .args(["run", repo("configs/drop_corner.toml").to_str().unwrap()])
        .args(["--samples", samples, "--out", single.to_str().unwrap()])
        .output()
        .unwrap();
    support::assert_succeeded(&o);
    let want = summary(&single);
    assert_eq!(want["drops"]["newton"]["samples"], 40000);
    let ok = d.join("ok");
    let (_, merge) = submit_scene(&d, &ok, None, "configs/drop_corner.toml", samples);
    wait_for("the drop merge job", || state(&merge).is_none());
    assert_eq!(
        summary(&ok.join("merged")),
        want,
        "merged Slurm drop study against the single run"
    );
}
