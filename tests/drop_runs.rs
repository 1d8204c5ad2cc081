//! Drop studies and effect sets: the derived effect sets of the
//! shipped scenes (a snapshot written by hand from the scenes' geometry);
//! a bouncing sphere against its closed form (energy ratio k² per bounce,
//! flight times 2k^(n−1)·u/g); the same answer on 1 and 2 threads; and the
//! errors for impossible drop scenes.

mod support;

use support::{bin, repo, scratch};

use impactmc::config::{load_scene, Overrides, Scene};
use impactmc::drop::run_drop;

fn scene_text(text: &str, tag: &str) -> Result<Scene, String> {
    let d = scratch(&format!("drop-{tag}"));
    std::fs::create_dir_all(&d).unwrap();
    let p = d.join("scene.toml");
    std::fs::write(&p, text).unwrap();
    load_scene(&p, &Overrides::default()).map_err(|e| e.to_string())
}

#[test]
fn derived_effect_sets_of_the_shipped_scenes() {
    // (scene, rotational coupling, coupled contacts, flight, rotation in
    // flight, bounces, kernel variant, constant |ω⁺|)
    #[rustfmt::skip]
    let want = [
        ("floor", true, false, false, "none", 1, "rotation", None),
        ("floor_sphere", false, false, false, "none", 1, "closed-form", Some(0.0)),
        ("corner2_paper", true, true, false, "none", 1, "rotation+lcp", None),
        ("corner3", true, true, false, "none", 1, "rotation+lcp", None),
        ("corner3_sphere", false, false, false, "none", 1, "closed-form", None),
        ("sweep_aspect_ratio", true, false, false, "none", 1, "rotation", None),
        ("accuracy_corner3", true, true, false, "none", 1, "rotation+lcp", None),
        ("drop_corner", true, true, true, "rk4", 5, "rotation+lcp", None),
        ("drop_dice", true, false, true, "rk4", 20, "rotation", None),
    ];
    let mut shipped: Vec<String> = std::fs::read_dir(repo("configs"))
        .unwrap()
        .filter_map(|e| {
            let p = e.unwrap().path();
            (p.extension()? == "toml").then(|| p.file_stem().unwrap().to_string_lossy().to_string())
        })
        .collect();
    shipped.sort();
    let mut listed: Vec<String> = want.iter().map(|w| w.0.to_string()).collect();
    listed.sort();
    assert_eq!(shipped, listed, "a shipped scene has no effect snapshot");
    for (name, rot, coupled, flight, rotation, bounces, kernel, spin) in want {
        let s = load_scene(
            &repo(&format!("configs/{name}.toml")),
            &Overrides::default(),
        )
        .unwrap();
        let e = s.effects();
        assert_eq!(
            (
                e.rotational_coupling,
                e.coupled_contacts,
                e.flight,
                e.flight_rotation,
                e.bounces,
                impactmc::kernel::KernelVariant::of(&s, impactmc::config::Keep::NONE).name(),
                e.constant_spin,
            ),
            (rot, coupled, flight, rotation, bounces, kernel, spin),
            "{name}: {}",
            e.line()
        );
        // No shipped scene asks for more than the default statistics.
        assert_eq!(
            e.statistics.describe(),
            "quantiles of energy_ratio",
            "{name}"
        );
    }
}

fn sphere_drop(k: f64, h: f64, vx: f64, bounces: u32) -> String {
    format!(
        r#"
name = "sphere_drop"
samples = 64
seed = 1
laws = ["newton"]
precision = "f64"
contact_tolerance = 1e-12
[body]
semi_axes = [0.1, 0.1, 0.1]
mass = 1.0
[[planes]]
name = "floor"
normal = [0.0, 0.0, 1.0]
offset = 0.0
restitution = {k}
[placement]
drop = {{ min = [0.0, 0.0, {z}], max = [0.0, 0.0, {z}] }}
[effects]
bounces = {bounces}
energy_floor = 0.0
toi_tolerance = 1e-13
[orientation]
distribution = "uniform"
[velocity]
distribution = "fixed"
value = [{vx}, 0.0, 0.0]
[angular_velocity]
distribution = "fixed"
value = [0.0, 0.0, 0.0]
"#,
        z = 0.1 + h
    )
}

#[test]
fn bouncing_sphere_matches_the_closed_form() {
    let (k, h, vx, g): (f64, f64, f64, f64) = (0.8, 1.0, 0.3, 9.81);
    let s = scene_text(&sphere_drop(k, h, vx, 4), "sphere").unwrap();
    assert!(!s.effects().rotational_coupling && !s.effects().coupled_contacts);
    assert_eq!(s.effects().flight_rotation, "precession");
    let run = run_drop(&s, 2).unwrap();
    let (_, a) = &run.laws[0];
    let u0 = (2.0 * g * h).sqrt();
    let mut u = u0; // vertical speed just before the bounce
    for (n, b) in a.bounces.iter().enumerate() {
        assert_eq!(b.reached, 64);
        // T+/T- = (vx² + k²u²)/(vx² + u²), the same for every sample.
        let want = (vx * vx + k * k * u * u) / (vx * vx + u * u);
        assert!(
            (b.energy_ratio.mean() - want).abs() < 1e-9,
            "bounce {}: {} vs {want}",
            n + 1,
            b.energy_ratio.mean()
        );
        let want_t = if n == 0 { u0 / g } else { 2.0 * u / g };
        assert!(
            (b.interval.mean() - want_t).abs() < 1e-9,
            "bounce {} interval {} vs {want_t}",
            n + 1,
            b.interval.mean()
        );
        u *= k;
    }
    assert_eq!(a.impacts[4], 64);
}

#[test]
fn drop_results_do_not_depend_on_threads() {
    let s = load_scene(
        &repo("configs/drop_corner.toml"),
        &Overrides {
            samples: Some(3000),
            ..Default::default()
        },
    )
    .unwrap();
    let strip = |mut v: serde_json::Value| {
        v.as_object_mut().unwrap().remove("throughput");
        v.as_object_mut().unwrap().remove("threads");
        v
    };
    let one = strip(run_drop(&s, 1).unwrap().summary_json(&s));
    let two = strip(run_drop(&s, 2).unwrap().summary_json(&s));
    assert_eq!(one, two);
    assert_eq!(one["laws"]["newton"]["bounces"][0]["reached"], 3000);
}

#[test]
fn impossible_drop_scenes_are_refused_by_field() {
    let ok = sphere_drop(0.8, 1.0, 0.0, 2);
    let cases = [
        (
            ok.replace("[0.0, 0.0, 1.1], max = [0.0, 0.0, 1.1]", "[0.0, 0.0, 0.05], max = [0.0, 0.0, 1.1]"),
            "placement.drop: impossible placement: the drop box comes within 0.05 m of plane \"floor\"",
        ),
        (
            ok.replace("max = [0.0, 0.0, 1.1]", "max = [0.0, 0.0, 1.0]"),
            "placement.drop: min must be ≤ max",
        ),
        (ok.replace("bounces = 2", "bounces = 0"), "effects.bounces: must be in 1..=10000, got 0"),
        (
            ok.replace("[placement]\n", "[placement]\ntouching = [\"floor\"]\n"),
            "placement: give either touching or drop",
        ),
        (
            ok.replace("energy_floor = 0.0", "energy_floor = 1.5"),
            "effects.energy_floor: must be in [0, 1), got 1.5",
        ),
    ];
    for (text, want) in cases {
        let err = scene_text(&text, "bad").unwrap_err();
        assert!(err.contains(want), "{err}\nwanted: {want}");
    }
    // Flight without a drop placement.
    let corner = std::fs::read_to_string(repo("configs/corner3.toml")).unwrap()
        + "\n[effects]\nflight = true\n";
    let err = scene_text(&corner, "flight").unwrap_err();
    assert!(
        err.contains("effects.flight: flight = true needs placement.drop"),
        "{err}"
    );
}

#[test]
fn drop_corner_from_the_command_line() {
    let d = scratch("drop-cli");
    let _ = std::fs::remove_dir_all(&d);
    let out = bin()
        .args([
            "run",
            "configs/drop_corner.toml",
            "--samples",
            "2000",
            "--format",
            "json",
            "--out",
        ])
        .arg(&d)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("effects: on [rotational coupling, coupled contacts (LCP), flight]"),
        "{stderr}"
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["effects"]["bounces"], 5);
    let b = &v["laws"]["newton"]["bounces"];
    assert_eq!(b.as_array().unwrap().len(), 5);
    // Exact simultaneity has probability zero: no first impact has a second
    // plane within 1e-9 m, yet a wide tolerance makes many simultaneous.
    let sim = &b[0]["simultaneous_within_tolerance"];
    assert_eq!(sim["1e-9"].as_f64(), Some(0.0), "{sim}");
    assert!(sim["1e-1"].as_f64().unwrap() > 0.05, "{sim}");
    for f in [
        "bounces.parquet",
        "planes_hit.parquet",
        "simultaneity.parquet",
        "summary.json",
        "manifest.json",
    ] {
        assert!(d.join(f).exists(), "{f}");
    }
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(m["effects"]["flight"], true);
    // `inspect` reads a drop folder too.
    let out = bin().arg("inspect").arg(&d).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("\"bounces\""));
}
