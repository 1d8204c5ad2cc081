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
