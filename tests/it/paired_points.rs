//! Paired differences between sweep points under RQMC: every point runs
//! the same scrambled points, so replicate r of one point and replicate r
//! of the reference point see the same samples, and the interval of a
//! difference comes from the R paired replicate differences.

use arrow_array::cast::AsArray;
use arrow_array::types::{Float64Type, UInt32Type};

use crate::support::{assert_succeeded, bin, json_file, read_parquet, repo, tmpdir};

/// S1 under RQMC (16 replicates of 4096 points, f64), swept over the
/// floor's restitution: the paired interval of the mean energy ratio
/// agrees with the one computed from samples.parquet (per replicate, the
/// mean over impacting rows of each point, then Student's t over the 16
/// differences), and is narrower than the unpaired one.
#[test]
fn paired_sweep_differences_agree_with_the_rows() {
    let text = std::fs::read_to_string(repo("configs/floor.toml"))
        .unwrap()
        .replacen("seed = 42\n", "seed = 42\nsampling = \"rqmc\"\n", 1)
        + "\n[sweep]\n\"planes.floor.restitution\" = [0.5, 0.8]\n";
    let d = tmpdir("paired-points");
    std::fs::write(d.join("scene.toml"), text).unwrap();
    let out = d.join("out");
    let o = bin()
        .arg("run")
        .arg(d.join("scene.toml"))
        .args(["--samples", "65536", "--precision", "f64", "--per-sample"])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert_succeeded(&o);
    let summary = json_file(&out.join("summary.json"));
    let points = summary["points"].as_array().unwrap();
    assert!(points[0]["summary"].get("paired_points").is_none());
    let pp = &points[1]["summary"]["paired_points"];
    assert_eq!(pp["reference_point"], 0);
    let er = &pp["laws"]["newton"]["energy_ratio"];
    let rows = read_parquet(&out.join("samples.parquet"));
    let (mut sums, mut counts) = ([[0.0f64; 16]; 2], [[0u64; 16]; 2]);
    for b in &rows {
        let point = b
            .column_by_name("point")
            .unwrap()
            .as_primitive::<UInt32Type>();
        let rep = b
            .column_by_name("replicate")
            .unwrap()
            .as_primitive::<UInt32Type>();
        let ratio = b
            .column_by_name("energy_ratio_newton")
            .unwrap()
            .as_primitive::<Float64Type>();
        let hit = b.column_by_name("impacted_newton").unwrap().as_boolean();
        for i in 0..b.num_rows() {
            if hit.value(i) {
                let (p, r) = (point.value(i) as usize, rep.value(i) as usize);
                sums[p][r] += ratio.value(i);
                counts[p][r] += 1;
            }
        }
    }
    let d: Vec<f64> = (0..16)
        .map(|r| sums[1][r] / counts[1][r] as f64 - sums[0][r] / counts[0][r] as f64)
        .collect();
    let mean = d.iter().sum::<f64>() / 16.0;
    let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / 15.0;
    // Student's t, 15 degrees of freedom (scipy's t.ppf(0.975, 15)).
    let ci = 2.131449545559323 * (var / 16.0).sqrt();
    let got = er["ci95"].as_f64().unwrap();
    assert!(
        (got - ci).abs() < 1e-6 * ci,
        "paired ci95 {got} vs {ci} from the rows"
    );
    let diff = er["difference"].as_f64().unwrap();
    let all = |p: usize| {
        points[p]["summary"]["laws"]["newton"]["groups"]["all"]["stats"]["energy_ratio"]["mean"]
            .as_f64()
            .unwrap()
    };
    assert!((diff - (all(1) - all(0))).abs() < 1e-15);
    let unpaired = er["unpaired_ci95"].as_f64().unwrap();
    eprintln!("energy ratio difference {diff} ± {got} (unpaired ± {unpaired})");
    assert!(got < unpaired / 1.5, "paired {got}, unpaired {unpaired}");
    // Proportions too: the same samples impact at both points.
    let imp = &pp["laws"]["newton"]["impacting"];
    assert_eq!(imp["difference"].as_f64(), Some(0.0));
    assert_eq!(imp["ci95"].as_f64(), Some(0.0));
}

/// The floor scene swept over its restitution, `extra` added to the top
/// of the scene and `sweep` as its `[sweep]` table, written to `d`.
fn floor_sweep(d: &std::path::Path, extra: &str, sweep: &str) -> std::path::PathBuf {
    let text = std::fs::read_to_string(repo("configs/floor.toml"))
        .unwrap()
        .replacen("seed = 42\n", &format!("seed = 42\n{extra}"), 1)
        + "\n[sweep]\n"
        + sweep;
    let path = d.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn readers_available() -> bool {
    std::process::Command::new("python3")
        .args(["-c", "import pyarrow, polars"])
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false)
}

/// The paired interval of the energy ratio between two restitutions of
/// the floor, recomputed from samples.parquet in polars
/// (tests/python/check_paired.py): under MC from the per-sample
/// linearised differences (agreeing to 5 %, the noise of the clusters'
/// variance estimate), under RQMC from the replicates (to rounding). Both
/// are narrower than the unpaired interval.
#[test]
fn paired_intervals_agree_with_the_rows_in_polars() {
    if !crate::support::available_or_skip(
        readers_available(),
        "IMPACTMC_REQUIRE_READERS",
        "pyarrow and polars",
        "pip install -r .ci/requirements-readers.txt",
    ) {
        return;
    }
    for (sampling, samples) in [("", "1000000"), ("sampling = \"rqmc\"\n", "65536")] {
        let d = tmpdir("paired-polars");
        let scene = floor_sweep(&d, sampling, "\"planes.floor.restitution\" = [0.5, 0.8]\n");
        let out = d.join("out");
        assert_succeeded(
            &bin()
                .arg("run")
                .arg(&scene)
                .args(["--samples", samples, "--precision", "f64", "--per-sample"])
                .args([
                    "--columns",
                    "energy_ratio_newton,impacted_newton",
                    "--format",
                    "json",
                    "--out",
                ])
                .arg(&out)
                .output()
                .unwrap(),
        );
        let check = std::process::Command::new("python3")
            .arg(repo("tests/python/check_paired.py"))
            .arg(out.join("samples.parquet"))
            .arg(out.join("summary.json"))
            .args(["newton", "1"])
            .output()
            .unwrap();
        let report = String::from_utf8_lossy(&check.stdout);
        assert!(
            check.status.success(),
            "{sampling:?}: {report}{}",
            String::from_utf8_lossy(&check.stderr)
        );
        eprintln!("{report}");
        std::fs::remove_dir_all(&d).unwrap();
    }
}

/// An MC sweep's paired intervals come from cluster sums fixed by the
/// scene, so they are the same bit for bit on one thread and on two; a
/// run without a sweep has none. The reference point is the one
/// `sweep.reference` names, by its values or its index.
#[test]
fn mc_paired_points_are_thread_independent_against_the_named_reference() {
    let d = tmpdir("paired-mc");
    let run = |scene: &std::path::Path, threads: &str| -> serde_json::Value {
        let o = bin()
            .arg("run")
            .arg(scene)
            .args([
                "--samples",
                "200000",
                "--threads",
                threads,
                "--format",
                "json",
            ])
            .arg("--out")
            .arg(d.join(format!("out-{threads}")))
            .arg("--force")
            .output()
            .unwrap();
        assert_succeeded(&o);
        serde_json::from_slice(&o.stdout).unwrap()
    };
    let scene = floor_sweep(
        &d,
        "",
        "\"planes.floor.restitution\" = [0.5, 0.8, 0.9]\nreference = { \"planes.floor.restitution\" = 0.8 }\n",
    );
    let (one, two) = (run(&scene, "1"), run(&scene, "2"));
    let pairs = |v: &serde_json::Value| -> Vec<serde_json::Value> {
        v["points"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| p["summary"]["paired_points"].clone())
            .collect()
    };
    assert_eq!(pairs(&one), pairs(&two));
    let p = pairs(&one);
    assert!(p[1].is_null(), "the reference has no differences");
    let mean = |i: usize| {
        one["points"][i]["summary"]["laws"]["newton"]["groups"]["all"]["stats"]["energy_ratio"]
            ["mean"]
            .as_f64()
            .unwrap()
    };
    for i in [0, 2] {
        assert_eq!(p[i]["reference_point"], 1);
        assert_eq!(p[i]["method"], "clusters");
        // 200 000 samples: three batches of 65 536 in 342 blocks of 192,
        // and 3392 in 18, one cluster per block.
        assert_eq!(p[i]["degrees_of_freedom"], 3 * 342 + 18 - 1);
        let er = &p[i]["laws"]["newton"]["energy_ratio"];
        assert_eq!(er["difference"].as_f64(), Some(mean(i) - mean(1)));
        let (ci, unpaired) = (
            er["ci95"].as_f64().unwrap(),
            er["unpaired_ci95"].as_f64().unwrap(),
        );
        assert!(
            ci > 0.0 && ci < unpaired / 1.5,
            "paired {ci}, unpaired {unpaired}"
        );
    }
    // summary.parquet: the same, on each law's `all` row, null at the
    // reference.
    let table = read_parquet(&d.join("out-1/summary.parquet"));
    let ci = crate::support::column::<Float64Type>(&table, "paired_energy_ratio_ci95");
    let refs = table[0].column_by_name("paired_reference_point").unwrap();
    assert!(refs.is_null(1) && !refs.is_null(0) && !refs.is_null(2));
    for i in [0, 2] {
        assert_eq!(
            Some(ci[i]),
            p[i]["laws"]["newton"]["energy_ratio"]["ci95"].as_f64()
        );
        assert_eq!(refs.as_primitive::<UInt32Type>().value(i), 1);
    }
    // The text names the method.
    let o = bin()
        .arg("run")
        .arg(&scene)
        .args(["--samples", "20000", "--out"])
        .arg(d.join("text"))
        .output()
        .unwrap();
    assert_succeeded(&o);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains(
            "[newton] minus point 1, paired by clusters of samples (104 dof): energy_ratio"
        ),
        "{text}"
    );
    // By index, the same reference.
    let by_index = floor_sweep(
        &d,
        "",
        "\"planes.floor.restitution\" = [0.5, 0.8, 0.9]\nreference = 1\n",
    );
    assert_eq!(pairs(&run(&by_index, "2")), p);
    // Without a sweep, nothing to pair.
    let plain = bin()
        .arg("run")
        .arg(repo("configs/floor.toml"))
        .args(["--samples", "20000", "--format", "json", "--out"])
        .arg(d.join("plain"))
        .output()
        .unwrap();
    assert_succeeded(&plain);
    let plain: serde_json::Value = serde_json::from_slice(&plain.stdout).unwrap();
    assert!(plain.get("paired_points").is_none());
}

/// `[[sweep.zip]]` fields vary together: a zip of two fields by two
/// values, beside a plain axis of three, is a grid of 2 × 3 points, not
/// 2 × 2 × 3; the axes (plain fields in path order, then each zip group's
/// in path order) say which dimension each field is on.
#[test]
fn zipped_fields_vary_together() {
    let d = tmpdir("sweep-zip");
    let scene = floor_sweep(
        &d,
        "",
        "\"body.mass\" = [1.0, 2.0, 3.0]\n[[sweep.zip]]\n\"planes.floor.restitution\" = [0.5, 0.8]\n\"body.semi_axes[2]\" = [0.2, 0.4]\n",
    );
    let o = bin()
        .arg("run")
        .arg(&scene)
        .args(["--samples", "2000", "--format", "json", "--out"])
        .arg(d.join("out"))
        .output()
        .unwrap();
    assert_succeeded(&o);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let points = v["points"].as_array().unwrap();
    assert_eq!(points.len(), 6);
    let axes = v["sweep"]["axes"].as_array().unwrap();
    let dims: Vec<(String, u64)> = axes
        .iter()
        .map(|a| {
            (
                a["path"].as_str().unwrap().to_string(),
                a["dimension"].as_u64().unwrap(),
            )
        })
        .collect();
    assert_eq!(
        dims,
        [
            ("body.mass".to_string(), 0),
            ("body.semi_axes[2]".to_string(), 1),
            ("planes.floor.restitution".to_string(), 1),
        ]
    );
    // Each point's values: the zipped pair always together.
    for p in points {
        let values = p["values"].as_object().unwrap();
        let e = values["planes.floor.restitution"].as_f64().unwrap();
        let c = values["body.semi_axes[2]"].as_f64().unwrap();
        assert!((e, c) == (0.5, 0.2) || (e, c) == (0.8, 0.4), "{values:?}");
    }
}

/// A malformed zip or reference is one error naming the field.
#[test]
fn bad_zips_and_references_name_the_field() {
    let d = tmpdir("sweep-bad");
    for (sweep, field, says) in [
        (
            "[[sweep.zip]]\n\"planes.floor.restitution\" = [0.5, 0.8]\n\"body.mass\" = [1.0]\n",
            "sweep.zip[0].\"planes.floor.restitution\"",
            "lists of one length",
        ),
        (
            "\"planes.floor.restitution\" = [0.5, 0.8]\nreference = 2\n",
            "sweep.reference",
            "the grid has points 0 to 1",
        ),
        (
            "\"planes.floor.restitution\" = [0.5, 0.8]\nreference = { \"planes.floor.restitution\" = 0.7 }\n",
            "sweep.reference",
            "no grid point has",
        ),
        (
            "\"planes.floor.restitution\" = [0.5, 0.8]\n\"body.mass\" = [1.0, 2.0]\nreference = { \"body.mass\" = 1.0 }\n",
            "sweep.reference",
            "2 grid points have",
        ),
        (
            "\"planes.floor.restitution\" = [0.5, 0.8]\nreference = { \"body.mass\" = 1.0 }\n",
            "sweep.reference.\"body.mass\"",
            "not a swept field",
        ),
        (
            "\"body.mass\" = [1.0]\n[[sweep.zip]]\n\"body.mass\" = [2.0]\n",
            "sweep",
            "\"body.mass\" is swept twice",
        ),
        ("zip = 3\n", "sweep.zip", "[[sweep.zip]]"),
    ] {
        let scene = floor_sweep(&d, "", sweep);
        let o = bin()
            .arg("run")
            .arg(&scene)
            .args(["--samples", "1000", "--out"])
            .arg(d.join("out"))
            .output()
            .unwrap();
        assert!(!o.status.success(), "{sweep}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(field) && err.contains(says), "{sweep}: {err}");
        assert_eq!(err.lines().filter(|l| l.starts_with("error")).count(), 1, "{err}");
    }
}

/// A drop sweep pairs its points' first impacts by clusters of one block
/// each, the same on one thread and on two.
#[test]
fn drop_sweeps_pair_by_blocks() {
    let d = tmpdir("paired-drop");
    let text = std::fs::read_to_string(repo("configs/drop_corner.toml")).unwrap()
        + "\n[sweep]\n\"planes.floor.restitution\" = [0.5, 0.8]\n";
    let scene = d.join("scene.toml");
    std::fs::write(&scene, text).unwrap();
    let run = |threads: &str| -> serde_json::Value {
        let o = bin()
            .arg("run")
            .arg(&scene)
            .args([
                "--samples",
                "8192",
                "--threads",
                threads,
                "--format",
                "json",
            ])
            .arg("--out")
            .arg(d.join(format!("out-{threads}")))
            .output()
            .unwrap();
        assert_succeeded(&o);
        serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap()["points"][1]["summary"]
            ["paired_points"]
            .clone()
    };
    let (one, two) = (run("1"), run("2"));
    assert_eq!(one, two);
    assert_eq!(one["method"], "clusters");
    // Two batches of 4096 samples, 22 blocks of 192 each.
    assert_eq!(one["degrees_of_freedom"], 2 * 22 - 1);
    let er = &one["laws"]["newton"]["energy_ratio"];
    assert!(er["ci95"].as_f64().unwrap() < er["unpaired_ci95"].as_f64().unwrap());
}

/// The clusters partition the samples: summed over clusters, every
/// estimate's two sums are the run's own (counts exactly, sums to
/// rounding), for a contact scene with friction and for a drop.
#[test]
fn cluster_sums_add_up_to_the_run() {
    use impactmc::engine::{run, RunOptions};
    use impactmc::stats::clusters::{walk_law, Key};
    for (name, samples) in [("corner3_friction", 30_000u64), ("drop_corner", 5000)] {
        let scene = impactmc::config::load_scene(
            &repo(&format!("configs/{name}.toml")),
            &impactmc::config::Overrides {
                samples: Some(samples),
                ..Default::default()
            },
        )
        .unwrap();
        let r = run(
            &scene,
            &RunOptions {
                threads: 2,
                clusters: true,
                ..Default::default()
            },
        )
        .unwrap();
        let c = r.clusters.as_ref().expect("clusters recorded");
        assert!(c.clusters() > 20, "{name}: {} clusters", c.clusters());
        for (l, law) in r.acc.laws.iter().enumerate() {
            let mut whole = Vec::new();
            walk_law(law, &mut |k, a, b| whole.push((k, a, b)));
            assert_eq!(whole.len(), c.keys.len());
            for (k, a, b) in whole {
                let col = c.column(l, k).unwrap();
                let (sa, sb) = col
                    .iter()
                    .fold((0.0, 0.0), |(x, y), &(a, b)| (x + a, y + b));
                // B is a count, except a restitution's Σ|v_n⁻|.
                if matches!(k, Key::PlaneStat("restitution", _)) {
                    assert!((sb - b).abs() <= 1e-12 * b, "{name} {k:?}: B {sb} vs {b}");
                } else {
                    assert_eq!(sb, b, "{name} {k:?}: B");
                }
                assert!(
                    (sa - a).abs() <= 1e-9 * a.abs().max(b),
                    "{name} {k:?}: A {sa} vs {a}"
                );
            }
        }
    }
}
