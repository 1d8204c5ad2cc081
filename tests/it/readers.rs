//! Every output file read by the tools analysts use (pyarrow, DuckDB and
//! polars for Python; pinned in .ci/requirements-readers.txt and installed by
//! .ci/run): schemas, row counts, and the Newton energy-ratio mean equal to
//! what the run printed.
//!
//! Without the Python readers the test says so and passes, unless
//! `IMPACTMC_REQUIRE_READERS=1` (set by .ci/run), where it fails.

use crate::support;

use std::process::Command;

use support::{bin, repo, scratch};

fn readers_available() -> bool {
    Command::new("python3")
        .args(["-c", "import pyarrow, duckdb, polars"])
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false)
}

#[test]
fn python_readers_agree_with_the_run() {
    if !support::available_or_skip(
        readers_available(),
        "IMPACTMC_REQUIRE_READERS",
        "pyarrow, duckdb and polars",
        "pip install -r .ci/requirements-readers.txt",
    ) {
        return;
    }
    let dir = scratch("readers");
    let _ = std::fs::remove_dir_all(&dir);
    let samples = 50_000u64;
    let out = bin()
        .args([
            "run",
            concat!(env!("CARGO_MANIFEST_DIR"), "/configs/corner3.toml"),
            "--samples",
            &samples.to_string(),
            "--law",
            "newton",
            "--law",
            "paper",
            "--per-sample",
            // Histograms of three statistics (the default keeps one).
            "--quantiles",
            "energy_ratio,omega_after_norm,velocity_after_norm",
            "--format",
            "json",
            "--out",
        ])
        .arg(&dir)
        .output()
        .unwrap();
    support::assert_succeeded(&out);
    let printed: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let mean = printed["laws"]["newton"]["groups"]["all"]["stats"]["energy_ratio"]["mean"].clone();
    // Rows: one per (law, group present) in the summary; one per sample.
    let groups = |law: &str| printed["laws"][law]["groups"].as_object().unwrap().len();
    let summary_rows = groups("newton") + groups("paper");
    let expected = serde_json::json!({
        "files": {
            "summary.parquet": {"rows": summary_rows, "columns": [
                "point", "law", "contact_set", "samples", "impacts",
                "energy_ratio_mean", "energy_ratio_ci95", "energy_ratio_sd", "energy_ratio_min",
                "energy_ratio_p01", "energy_ratio_median", "energy_ratio_p99", "energy_ratio_max",
                "omega_after_norm_mean", "velocity_after_norm_mean", "fraction_energy_gain"]},
            "histograms.parquet": {"rows": null, "columns": [
                "point", "law", "contact_set", "statistic", "bin_lo", "bin_hi", "count"]},
            "samples.parquet": {"rows": samples, "columns": [
                "sample", "q_w", "q_x", "q_y", "q_z", "v_x", "v_y", "v_z", "omega_x", "omega_y", "omega_z",
                "energy_before", "energy_ratio_newton", "impulse_newton_wall_x", "flags_paper"]},
        },
        "value": {"file": "summary.parquet", "column": "energy_ratio_mean",
                  "where": {"law": "newton", "contact_set": "all"}, "equals": mean},
    });
    let exp_path = dir.join("expected.json");
    std::fs::write(&exp_path, expected.to_string()).unwrap();
    let script = repo("tests/python/check_outputs.py");
    let check = Command::new("python3")
        .arg(&script)
        .arg(&dir)
        .arg(&exp_path)
        .output()
        .unwrap();
    let report = String::from_utf8_lossy(&check.stdout);
    assert!(
        check.status.success(),
        "{report}{}",
        String::from_utf8_lossy(&check.stderr)
    );
    // histograms.parquet: its counts must add up, per law and statistic, to
    // the impacting samples the run printed.
    let hist = Command::new("python3")
        .args([
            "-c",
            "import sys, duckdb; print(duckdb.connect().execute(\"SELECT law, statistic, sum(count) FROM read_parquet('\" + sys.argv[1] + \"') WHERE contact_set = 'all' GROUP BY ALL ORDER BY ALL\").fetchall())",
        ])
        .arg(dir.join("histograms.parquet"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&hist.stdout);
    for law in ["newton", "paper"] {
        let impacts = printed["laws"][law]["groups"]["all"]["impacts"]
            .as_u64()
            .unwrap();
        for stat in ["energy_ratio", "omega_after_norm", "velocity_after_norm"] {
            let needle = format!("('{law}', '{stat}', {impacts})");
            assert!(
                text.contains(&needle),
                "histogram counts: {text} lacks {needle}"
            );
        }
    }
    // Per contact set, the energy-ratio histogram counts add up to the set's
    // impacting samples.
    let per_set = Command::new("python3")
        .args([
            "-c",
            "import sys, duckdb; print(dict(duckdb.connect().execute(\"SELECT contact_set, sum(count)::BIGINT FROM read_parquet('\" + sys.argv[1] + \"') WHERE law = 'newton' AND statistic = 'energy_ratio' AND contact_set <> 'all' GROUP BY ALL\").fetchall()))",
        ])
        .arg(dir.join("histograms.parquet"))
        .output()
        .unwrap();
    let per_set = String::from_utf8_lossy(&per_set.stdout);
    for (set, g) in printed["laws"]["newton"]["groups"].as_object().unwrap() {
        let impacts = g["impacts"].as_u64().unwrap();
        if set == "all" || impacts == 0 {
            continue;
        }
        let needle = format!("'{set}': {impacts}");
        assert!(
            per_set.contains(&needle),
            "per-set histogram counts {per_set} lack {needle}"
        );
    }
    // The manifest and summary.json are JSON a script can read.
    for f in ["manifest.json", "summary.json"] {
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join(f)).unwrap()).unwrap();
        assert!(v.is_object(), "{f}");
    }
    eprintln!("{report}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A drop scene's per-impact rows and tables in the three readers, and
/// DuckDB rebuilding the run's per-bounce counts and the frequencies of the
/// sequences of planes hit from the rows alone.
#[test]
fn python_readers_rebuild_drop_sequences_from_per_impact_rows() {
    if !support::available_or_skip(
        readers_available(),
        "IMPACTMC_REQUIRE_READERS",
        "pyarrow, duckdb and polars",
        "pip install -r .ci/requirements-readers.txt",
    ) {
        return;
    }
    let dir = scratch("readers-drop");
    let _ = std::fs::remove_dir_all(&dir);
    let out = bin()
        .args([
            "run",
            concat!(env!("CARGO_MANIFEST_DIR"), "/configs/drop_corner.toml"),
            "--samples",
            "4000",
            "--per-sample",
            "--format",
            "json",
            "--out",
        ])
        .arg(&dir)
        .output()
        .unwrap();
    support::assert_succeeded(&out);
    let printed: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let drop = &printed["drops"]["newton"];
    let bounces = drop["bounces"].as_array().unwrap();
    let reached: Vec<u64> = bounces
        .iter()
        .map(|b| b["reached"].as_u64().unwrap())
        .collect();
    let expected = serde_json::json!({
        "files": {
            "samples.parquet": {"rows": reached.iter().sum::<u64>(), "columns": [
                "sample", "law", "time", "interval", "centre_z", "q_w", "v_x", "omega_z",
                "energy_before", "energy_after", "energy_ratio", "v_after_x", "omega_after_z",
                "distance_floor", "vn_before_wall_x", "vn_after_wall_y", "impulse_floor",
                "bounce", "planes", "flags"]},
            "bounces.parquet": {"rows": bounces.len(), "columns": [
                "point", "law", "bounce", "reached", "energy_ratio_mean", "interval_seconds_mean"]},
            "sequences.parquet": {"rows": drop["sequences"].as_array().unwrap().len(),
                "columns": ["point", "law", "sequence", "count", "fraction"]},
            "summary.parquet": {"rows": null, "columns": ["law", "contact_set", "bounce", "samples"]},
        },
        "value": {"file": "bounces.parquet", "column": "energy_ratio_mean",
                  "where": {"law": "newton", "bounce": 2},
                  "equals": bounces[1]["energy_ratio"]["mean"]},
    });
    let exp_path = dir.join("expected.json");
    std::fs::write(&exp_path, expected.to_string()).unwrap();
    let check = Command::new("python3")
        .arg(repo("tests/python/check_outputs.py"))
        .arg(&dir)
        .arg(&exp_path)
        .output()
        .unwrap();
    let report = String::from_utf8_lossy(&check.stdout);
    assert!(
        check.status.success(),
        "{report}{}",
        String::from_utf8_lossy(&check.stderr)
    );
    // Per bounce, the rows are the samples that reached it.
    let query = |sql: &str| {
        let o = Command::new("python3")
            .args([
                "-c",
                "import sys, duckdb; print(duckdb.connect().execute(sys.argv[1].replace('ROWS', \"read_parquet('\" + sys.argv[2] + \"')\")).fetchall())",
            ])
            .arg(sql)
            .arg(dir.join("samples.parquet"))
            .output()
            .unwrap();
        support::assert_succeeded(&o);
        String::from_utf8_lossy(&o.stdout).trim().to_string()
    };
    let per_bounce = query("SELECT count(*) FROM ROWS GROUP BY bounce ORDER BY bounce");
    let want: Vec<String> = reached.iter().map(|r| format!("({r},)")).collect();
    assert_eq!(per_bounce, format!("[{}]", want.join(", ")));
    // The sequences of the first three impacts, rebuilt per sample.
    let seqs = query(
        "SELECT count(*) AS n FROM (SELECT sample, list(planes ORDER BY bounce) AS seq \
         FROM ROWS WHERE bounce <= 3 GROUP BY sample) GROUP BY seq ORDER BY n DESC",
    );
    let mut counts: Vec<u64> = drop["sequences"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["count"].as_u64().unwrap())
        .collect();
    counts.sort_unstable_by(|a, b| b.cmp(a));
    let want: Vec<String> = counts.iter().map(|c| format!("({c},)")).collect();
    assert_eq!(seqs, format!("[{}]", want.join(", ")));
    eprintln!("{report}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Every per-sample column of an f32 run, read back by pyarrow, DuckDB and
/// polars, holds exactly what the kernel computed for that sample
/// (`evaluate_samples`, which does not go through the writer), in its
/// native type (f32 floats, u8 active sets, u16 flags, u64 samples), under
/// each codec; the quaternion matches the kernel's rotation matrix.
#[test]
fn python_readers_read_back_exactly_what_the_run_computed() {
    use impactmc::config::{load_scene, Overrides};
    use impactmc::engine::evaluate_samples;
    use serde_json::{json, Map, Value};
    if !support::available_or_skip(
        readers_available(),
        "IMPACTMC_REQUIRE_READERS",
        "pyarrow, duckdb and polars",
        "pip install -r .ci/requirements-readers.txt",
    ) {
        return;
    }
    let samples = 3000usize;
    let scene_path = repo("configs/corner3.toml");
    let scene = load_scene(
        &scene_path,
        &Overrides {
            samples: Some(samples as u64),
            precision: Some("f32".parse().unwrap()),
            ..Default::default()
        },
    )
    .unwrap();
    let planes: Vec<String> = scene
        .touching()
        .iter()
        .map(|&i| scene.planes()[i].name.clone())
        .collect();
    let mut cols = Map::new();
    let mut put = |name: String, ty: &str, values: Vec<Value>| {
        cols.insert(name, json!({"type": ty, "values": values}));
    };
    let f = |x: f64| json!(x);
    put(
        "sample".into(),
        "uint64",
        (0..samples as u64).map(|i| json!(i)).collect(),
    );
    let mut rotation = Vec::new();
    for (l, &law) in scene.laws().iter().enumerate() {
        let name = law.name();
        let outs = evaluate_samples(&scene, law, 0, samples);
        if l == 0 {
            for (k, c) in ["x", "y", "z"].iter().enumerate() {
                put(
                    format!("v_{c}"),
                    "float32",
                    outs.iter().map(|o| f(o.velocity[k])).collect(),
                );
                put(
                    format!("omega_{c}"),
                    "float32",
                    outs.iter().map(|o| f(o.omega[k])).collect(),
                );
            }
            put(
                "energy_before".into(),
                "float32",
                outs.iter().map(|o| f(o.energy_before)).collect(),
            );
            for (i, p) in planes.iter().enumerate() {
                put(
                    format!("vn_before_{p}"),
                    "float32",
                    outs.iter().map(|o| f(o.vn_before[i])).collect(),
                );
            }
            rotation = outs.iter().map(|o| json!(o.rotation)).collect();
        }
        put(
            format!("energy_after_{name}"),
            "float32",
            outs.iter().map(|o| f(o.energy_after)).collect(),
        );
        // The f32 quotient of the two f32 energies.
        put(
            format!("energy_ratio_{name}"),
            "float32",
            outs.iter()
                .map(|o| f((o.energy_after as f32 / o.energy_before as f32) as f64))
                .collect(),
        );
        for (k, c) in ["x", "y", "z"].iter().enumerate() {
            put(
                format!("v_after_{c}_{name}"),
                "float32",
                outs.iter().map(|o| f(o.velocity_after[k])).collect(),
            );
            put(
                format!("omega_after_{c}_{name}"),
                "float32",
                outs.iter().map(|o| f(o.omega_after[k])).collect(),
            );
        }
        for (i, p) in planes.iter().enumerate() {
            put(
                format!("impulse_{name}_{p}"),
                "float32",
                outs.iter().map(|o| f(o.impulses[i])).collect(),
            );
            put(
                format!("vn_after_{name}_{p}"),
                "float32",
                outs.iter().map(|o| f(o.vn_after[i])).collect(),
            );
        }
        // Approaching on some plane (bits 0–2), not penetrating (bit 13).
        put(
            format!("impacted_{name}"),
            "bool",
            outs.iter()
                .map(|o| json!(o.status.bits() & 7 != 0 && o.status.bits() & (1 << 13) == 0))
                .collect(),
        );
        put(
            format!("active_{name}"),
            "uint8",
            outs.iter()
                .map(|o| json!((o.status.bits() >> 4) & 7))
                .collect(),
        );
        put(
            format!("flags_{name}"),
            "uint16",
            outs.iter().map(|o| json!(o.status.bits())).collect(),
        );
    }
    let expected = json!({"columns": cols, "rotation": rotation, "tolerance": 1e-6});
    // Every codec with all columns, and a subset (the engine then computes
    // only those: their values must not change).
    let subset = [
        "energy_ratio_paper",
        "impulse_newton_floor",
        "v_after_x_newton",
        "flags_paper",
    ];
    let some = json!({"columns": subset
        .iter()
        .chain(&["sample"])
        .map(|c| (c.to_string(), expected["columns"][c].clone()))
        .collect::<Map<String, Value>>()});
    for (codec, columns, expected) in [
        ("zstd", None, &expected),
        ("lz4", None, &expected),
        ("none", None, &expected),
        ("lz4", Some(subset.join(",")), &some),
    ] {
        let dir = scratch(&format!("values-{codec}-{}", columns.is_some()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let text = std::fs::read_to_string(&scene_path).unwrap()
            + &format!("\n[output]\nper_sample = true\ncompression = \"{codec}\"\n");
        let path = dir.join("scene.toml");
        std::fs::write(&path, text).unwrap();
        let mut cmd = bin();
        cmd.arg("run")
            .arg(&path)
            .args([
                "--samples",
                &samples.to_string(),
                "--precision",
                "f32",
                "--out",
            ])
            .arg(dir.join("run"));
        if let Some(c) = &columns {
            cmd.args(["--columns", c]);
        }
        let out = cmd.output().unwrap();
        support::assert_succeeded(&out);
        let manifest: Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("run/manifest.json")).unwrap())
                .unwrap();
        assert_eq!(manifest["per_sample"]["floats"], "f32");
        assert_eq!(manifest["per_sample"]["compression"], codec);
        assert_eq!(manifest["per_sample"]["rows"], samples);
        let exp_path = dir.join("expected.json");
        std::fs::write(&exp_path, expected.to_string()).unwrap();
        let check = Command::new("python3")
            .arg(repo("tests/python/check_values.py"))
            .arg(dir.join("run/samples.parquet"))
            .arg(&exp_path)
            .output()
            .unwrap();
        let report = String::from_utf8_lossy(&check.stdout);
        assert!(
            check.status.success(),
            "{codec} {columns:?}: {report}{}",
            String::from_utf8_lossy(&check.stderr)
        );
        eprintln!("{codec} {columns:?}: {report}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
