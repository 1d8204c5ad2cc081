//! `impactmc run` from the command line: scene errors (file, line, field,
//! value; exit 2), output folder rules, and the JSON summary's public keys.

use crate::support;

use support::{bin, json_file, repo, tmpdir};

use std::path::Path;

fn corner3_text() -> String {
    std::fs::read_to_string(repo("configs/corner3.toml")).unwrap()
}

/// Runs a scene file into `out` with flags; returns (exit code, stdout,
/// stderr).
fn run_scene(scene: &Path, out: &Path, flags: &[&str]) -> (i32, String, String) {
    let o = bin()
        .arg("run")
        .arg(scene)
        .arg("--out")
        .arg(out)
        .args(flags)
        .output()
        .unwrap();
    (
        o.status.code().unwrap(),
        String::from_utf8(o.stdout).unwrap(),
        String::from_utf8(o.stderr).unwrap(),
    )
}

/// Runs a scene text at 1000 samples; returns (exit code, stdout, stderr).
fn run_text(tag: &str, text: &str, extra: &[&str]) -> (i32, String, String) {
    let d = tmpdir(tag);
    let scene = d.join("scene.toml");
    std::fs::write(&scene, text).unwrap();
    run_scene(
        &scene,
        &d.join("out"),
        &[&["--samples", "1000"], extra].concat(),
    )
}

#[test]
fn scene_errors_name_file_line_field_and_value() {
    let base = corner3_text();
    let cases: &[(&str, &str, &str)] = &[
        ("mass = 500.0", "mass = -5.0", "scene.toml:10: body.mass: mass must be a finite number > 0, got -5"),
        ("mass = 500.0", "mass = nan", "body.mass: mass must be a finite number > 0, got NaN"),
        ("mass = 500.0", "mass = 500.0\ncolour = 1", "unknown field `colour`"),
        ("normal = [0.0, 1.0, 0.0]", "normal = [0.0, 0.0, 0.0]", ":20: planes[1].normal: normal must be a finite non-zero vector, got [0, 0, 0]"),
        ("restitution = 0.9", "restitution = 1.9", "planes[2].restitution: restitution must be in [0, 1], got 1.9"),
        ("laws = [\"newton\", \"paper\"]", "laws = [\"newton\", \"pgs0\"]", ":5: laws[1]: unknown law \"pgs0\""),
        (
            "normal = [0.0, 1.0, 0.0]",
            "normal = [1.0, 0.0, 0.0]",
            "placement.touching: impossible placement: the normals of [\"wall_x\", \"wall_y\", \"floor\"] are (nearly) dependent",
        ),
        ("touching = [\"wall_x\", \"wall_y\", \"floor\"]", "touching = [\"wall_x\", \"ceiling\"]", "placement.touching[1]: no plane is named \"ceiling\""),
        ("sd = [0.5, 0.5, 0.5]", "sd = [0.5, -0.5, 0.5]", "velocity.sd: must be ≥ 0, got [0.5, -0.5, 0.5]"),
        ("precision = \"f32\"", "precision = \"f16\"", "precision: must be \"f32\" or \"f64\", got \"f16\""),
        ("distribution = \"uniform\"", "distribution = \"isotropic\"", "unknown variant `isotropic`"),
        ("sd = [1.0, 1.0, 1.0]", "sd = [1.0, 1.0, 1.0]\n[output]\ncompression = \"gzip\"", ":46: output.compression: \"gzip\" is not one of \"lz4\", \"zstd\", \"none\""),
        ("sd = [1.0, 1.0, 1.0]", "sd = [1.0, 1.0, 1.0]\n[output]\ncompression = \"zstd\"\nlevel = 0", "output.level: zstd levels are 1..=22, got 0"),
        ("sd = [1.0, 1.0, 1.0]", "sd = [1.0, 1.0, 1.0]\n[output]\nlevel = 3", "output.level: a level applies to zstd only, got 3 with lz4"),
    ];
    for (from, to, want) in cases {
        let text = base.replacen(from, to, 1);
        assert_ne!(text, base, "{from} not found");
        let (code, out, err) = run_text("err", &text, &[]);
        assert_eq!(code, 2, "{to}: {err}");
        assert!(out.is_empty(), "{to}: stdout {out}");
        assert!(err.contains(want), "{to}: stderr {err:?} lacks {want:?}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

/// `--quantiles` replaces the scene's `[statistics] quantiles`: the named
/// statistics get p01, median and p99, the others only moments; a bad name
/// is a scene error naming the list entry.
#[test]
fn quantiles_option_chooses_the_histograms() {
    let text = corner3_text();
    let (code, out, err) = run_text(
        "q",
        &text,
        &[
            "--quantiles",
            "omega_after_norm,velocity_after_norm",
            "--format",
            "json",
        ],
    );
    assert_eq!(code, 0, "{err}");
    assert!(
        err.contains("statistics: quantiles of omega_after_norm, velocity_after_norm"),
        "{err}"
    );
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let stats = &v["laws"]["newton"]["groups"]["all"]["stats"];
    for (stat, kept) in [
        ("energy_ratio", false),
        ("omega_after_norm", true),
        ("velocity_after_norm", true),
    ] {
        assert!(stats[stat]["mean"].is_number(), "{stat}");
        for f in ["p01", "median", "p99"] {
            assert_eq!(stats[stat][f].is_number(), kept, "{stat}.{f}");
        }
    }
    // The empty list: moments only, as `quantiles = []`.
    let (code, out, err) = run_text("qnone", &text, &["--quantiles", "", "--format", "json"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("statistics: no quantiles"), "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let er = &v["laws"]["newton"]["groups"]["all"]["stats"]["energy_ratio"];
    assert!(er["mean"].is_number() && er.get("median").is_none(), "{er}");
    let (code, out, err) = run_text("qbad", &text, &["--quantiles", "energy_ratio,spin"]);
    assert_eq!(code, 2, "{err}");
    assert!(out.is_empty(), "{out}");
    assert!(
        err.contains("scene.toml: --quantiles[1]: unknown statistic \"spin\""),
        "{err}"
    );
}

#[test]
fn output_folder_rules_and_json_summary() {
    let d = tmpdir("out");
    let out_dir = d.join("res");
    let args = |extra: &[&str]| {
        let mut c = bin();
        c.args([
            "run",
            concat!(env!("CARGO_MANIFEST_DIR"), "/configs/corner3.toml"),
            "--samples",
            "20000",
            "--format",
            "json",
            "--out",
        ])
        .arg(&out_dir)
        .args(extra);
        c.output().unwrap()
    };
    let first = args(&[]);
    support::assert_succeeded(&first);
    let v: serde_json::Value = serde_json::from_slice(&first.stdout).unwrap();
    for key in ["scene", "samples", "seed", "throughput", "laws"] {
        assert!(v.get(key).is_some(), "missing key {key}");
    }
    let all = &v["laws"]["newton"]["groups"]["all"];
    for key in ["samples", "impacts", "stats", "fractions", "active_sets"] {
        assert!(all.get(key).is_some(), "missing all.{key}");
    }
    // The default: quantiles of the energy ratio; moments of all.
    for stat in ["energy_ratio", "omega_after_norm", "velocity_after_norm"] {
        for f in ["mean", "ci95", "sd", "min", "max"] {
            assert!(all["stats"][stat][f].is_number(), "{stat}.{f}");
        }
        for f in ["p01", "median", "p99"] {
            let kept = stat == "energy_ratio";
            assert_eq!(all["stats"][stat][f].is_number(), kept, "{stat}.{f}");
        }
    }
    assert!(all["active_sets"]["wall_x+wall_y+floor"].as_f64().unwrap() > 0.5);
    for f in ["summary.parquet", "summary.json", "manifest.json"] {
        assert!(out_dir.join(f).is_file(), "{f} missing");
    }
    // No temporary files are left behind.
    let leftovers: Vec<_> = std::fs::read_dir(&out_dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .filter(|n| n.contains("partial"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
    // A second run refuses, --force overwrites.
    let again = args(&[]);
    assert_eq!(again.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&again.stderr).contains("already holds a run; pass --force"));
    assert!(args(&["--force"]).status.success());
    // An unwritable output directory: a path under a regular file.
    let blocked = d.join("file");
    std::fs::write(&blocked, "x").unwrap();
    let out = bin()
        .args([
            "run",
            concat!(env!("CARGO_MANIFEST_DIR"), "/configs/corner3.toml"),
            "--samples",
            "1000",
            "--out",
        ])
        .arg(blocked.join("sub"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("output folder") && err.contains("file/sub"),
        "{err}"
    );
}

#[test]
fn a_killed_run_leaves_no_file_that_looks_complete() {
    let d = tmpdir("killed");
    let out_dir = d.join("res");
    let mut child = bin()
        .args([
            "run",
            concat!(env!("CARGO_MANIFEST_DIR"), "/configs/corner3.toml"),
            "--samples",
            "500000000",
            "--per-sample",
            "--out",
        ])
        .arg(&out_dir)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Wait until the run is writing (its temporary samples file exists).
    let started = std::time::Instant::now();
    let names = |dir: &Path| -> Vec<String> {
        std::fs::read_dir(dir)
            .map(|r| {
                r.flatten()
                    .map(|e| e.file_name().to_string_lossy().to_string())
                    .collect()
            })
            .unwrap_or_default()
    };
    while !names(&out_dir).iter().any(|n| n.contains(".partial-")) {
        assert!(
            started.elapsed().as_secs() < 60,
            "the run never started writing"
        );
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    std::thread::sleep(std::time::Duration::from_millis(300));
    child.kill().unwrap();
    child.wait().unwrap();
    let left = names(&out_dir);
    for complete in [
        "summary.parquet",
        "histograms.parquet",
        "samples.parquet",
        "summary.json",
        "manifest.json",
    ] {
        assert!(
            !left.contains(&complete.to_string()),
            "{complete} exists after a kill: {left:?}"
        );
    }
    assert!(
        left.iter()
            .all(|n| n.starts_with('.') && n.contains(".partial-")),
        "{left:?}"
    );
    // The next run into the folder is not refused (nothing completed) and
    // clears the dead run's temporary files.
    let ok = bin()
        .args([
            "run",
            concat!(env!("CARGO_MANIFEST_DIR"), "/configs/corner3.toml"),
            "--samples",
            "1000",
            "--out",
        ])
        .arg(&out_dir)
        .output()
        .unwrap();
    support::assert_succeeded(&ok);
    assert!(
        names(&out_dir).iter().all(|n| !n.contains(".partial-")),
        "{:?}",
        names(&out_dir)
    );
    std::fs::remove_dir_all(&d).unwrap();
}

/// `samples.parquet` is the same file byte for byte for one and two threads
/// (row groups are encoded in parallel and written in order): a contact
/// scene over several row groups, and a drop scene, whose batches hold
/// varying numbers of rows.
#[test]
fn samples_file_is_the_same_for_any_thread_count() {
    let d = tmpdir("threads-file");
    for (scene, samples) in [("corner3", "600000"), ("drop_corner", "3000")] {
        let file = |threads: &str| {
            let out_dir = d.join(format!("{scene}-{threads}"));
            let out = bin()
                .arg("run")
                .arg(repo(&format!("configs/{scene}.toml")))
                .args([
                    "--samples",
                    samples,
                    "--per-sample",
                    "--threads",
                    threads,
                    "--out",
                ])
                .arg(&out_dir)
                .output()
                .unwrap();
            support::assert_succeeded(&out);
            std::fs::read(out_dir.join("samples.parquet")).unwrap()
        };
        let (one, two) = (file("1"), file("2"));
        assert!(one.len() > 1000, "{scene}: {} bytes", one.len());
        assert!(one == two, "{scene}: the files differ for 1 and 2 threads");
    }
    std::fs::remove_dir_all(d).unwrap();
}

/// `--force` leaves one run in the folder: what the earlier run listed in
/// its manifest and this one does not write is gone (its per-sample rows,
/// bounce tables and figures), and a file of the user's own stays.
#[test]
fn force_leaves_no_file_of_the_earlier_run() {
    let dir = support::scratch("force-stale");
    let _ = std::fs::remove_dir_all(&dir);
    let run = |scene: &str, extra: &[&str]| {
        let out = support::bin()
            .args(["run", "--samples", "300", "--force", "--out"])
            .arg(&dir)
            .args(extra)
            .arg(support::repo(scene))
            .output()
            .unwrap();
        support::assert_succeeded(&out);
    };
    run("configs/drop_corner.toml", &["--per-sample"]);
    for f in ["samples.parquet", "bounces.parquet", "plots/sequences.svg"] {
        assert!(dir.join(f).exists(), "{f}");
    }
    std::fs::write(dir.join("notes.txt"), "mine").unwrap();
    run("configs/floor.toml", &[]);
    for f in ["samples.parquet", "bounces.parquet", "plots/sequences.svg"] {
        assert!(
            !dir.join(f).exists(),
            "{f} of the earlier run is still there"
        );
    }
    let manifest = support::json_file(&dir.join("manifest.json"));
    for f in manifest["files"].as_array().unwrap() {
        assert!(dir.join(f.as_str().unwrap()).exists(), "{f}");
    }
    assert!(dir.join("summary.parquet").exists());
    assert_eq!(
        std::fs::read_to_string(dir.join("notes.txt")).unwrap(),
        "mine"
    );
}

/// Runs a shipped scene with flags; returns (exit code, stdout, stderr).
fn run_flags(tag: &str, scene: &str, flags: &[&str]) -> (i32, String, String) {
    run_scene(&repo(scene), &tmpdir(tag).join("out"), flags)
}

/// `--samples` takes a count as people write it, and refuses a fraction
/// with a message that says what a count looks like.
#[test]
fn samples_take_exponents_and_underscores() {
    for (given, want) in [("2e4", 20_000), ("20_000", 20_000), ("20000", 20_000)] {
        let (code, out, err) = run_flags(
            "samples-forms",
            "configs/floor.toml",
            &["--samples", given, "--format", "json"],
        );
        assert_eq!(code, 0, "{given}: {err}");
        let v: serde_json::Value = serde_json::from_str(&out).unwrap();
        assert_eq!(v["samples"], want, "{given}");
    }
    let (code, _, err) = run_flags("samples-bad", "configs/floor.toml", &["--samples", "1.5e3"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("\"1.5e3\" is not a count"), "{err}");
}

/// Every u64 seed works: above i64::MAX it cannot be a TOML integer, and
/// the flag does not go through one.
#[test]
fn seeds_above_i64_max_run() {
    let seed = "9223372036854775808";
    let (code, out, err) = run_flags(
        "seed-u64",
        "configs/floor.toml",
        &["--samples", "2000", "--seed", seed, "--format", "json"],
    );
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["seed"].as_u64(), Some(1u64 << 63));
}

/// A law the scene cannot use, given on the command line, is blamed on
/// the flag, not on the scene file's `laws` line; and the refusal of
/// `poisson` with friction offers only laws the scene takes.
#[test]
fn override_errors_name_the_flag() {
    let (code, _, err) = run_flags("law-flag", "configs/corner3.toml", &["--law", "stronge"]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("corner3.toml: --law[0]: law stronge takes one touching plane"),
        "{err}"
    );
    let (code, _, err) = run_flags(
        "poisson-friction",
        "configs/corner3_friction.toml",
        &["--law", "poisson"],
    );
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("use newton, paper or pgsN"), "{err}");
    assert!(!err.contains("stronge"), "{err}");
}

#[test]
fn run_help_lists_every_law() {
    let out = bin().args(["run", "--help"]).output().unwrap();
    let help = String::from_utf8(out.stdout).unwrap();
    let law = help
        .lines()
        .skip_while(|l| !l.contains("--law"))
        .take(3)
        .collect::<String>();
    for name in ["paper", "newton", "poisson", "pgsN", "stronge"] {
        assert!(law.contains(name), "{name} missing from: {law}");
    }
}

/// Without a scene, `run` takes corner3 from the binary, so it runs from a
/// folder that has no `configs/` (and gives the file's results).
#[test]
fn the_default_scene_is_built_in() {
    let d = tmpdir("default-scene");
    let out = bin()
        .current_dir(&d)
        .args(["run", "--samples", "1000", "--format", "json"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!d.join("configs").exists());
    assert!(d.join("results/corner3/manifest.json").exists());
    let built_in: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let (code, file, _) = run_text("default-scene-file", &corner3_text(), &["--format", "json"]);
    assert_eq!(code, 0);
    let file: serde_json::Value = serde_json::from_str(&file).unwrap();
    assert_eq!(built_in["laws"], file["laws"]);
    assert_eq!(built_in["scene"], "corner3");
}

/// The manifest names the statistics whose quantiles a run kept, as the
/// scene's `[statistics] quantiles` does (it was five unlabelled booleans).
#[test]
fn the_manifest_names_the_quantiles_kept() {
    let d = tmpdir("manifest-quantiles");
    let (code, _, err) = run_scene(
        &repo("configs/floor.toml"),
        &d.join("out"),
        &["--samples", "1000", "--quantiles", "impulse,energy_ratio"],
    );
    assert_eq!(code, 0, "{err}");
    let m = json_file(&d.join("out/manifest.json"));
    assert_eq!(
        m["effects"]["statistics"]["quantiles"],
        serde_json::json!(["energy_ratio", "impulse"])
    );
}
