//! Effects compiled out: every specialised kernel (no rotational
//! coupling, no LCP, neither) gives the answers of the kernel that computes
//! every effect, sample by sample and in the run statistics; statistics
//! that were not requested are not reported; a constant |ω⁺| is counted
//! exactly.

use crate::support;

use support::{repo, scratch};

use impactmc::config::Keep;
use impactmc::config::{load_scene, Overrides, Scene};
use impactmc::engine::{evaluate_samples, evaluate_samples_with, run, RunOptions, SampleOutcome};
use impactmc::kernel::KernelVariant;
use impactmc::output::summary::Summary;
use impactmc::physics::Law;
use impactmc::sampler::{Inputs, Sampler};

fn shipped(name: &str, precision: &str, samples: u64) -> Scene {
    shipped_with(name, precision, samples, None)
}

/// [`shipped`] with `--quantiles`'s override.
fn shipped_with(
    name: &str,
    precision: &str,
    samples: u64,
    quantiles: Option<Vec<String>>,
) -> Scene {
    load_scene(
        &repo(&format!("configs/{name}.toml")),
        &Overrides {
            precision: Some(precision.parse().expect("f32 or f64")),
            samples: Some(samples),
            laws: Some(vec!["newton".into(), "paper".into()]),
            quantiles,
            ..Overrides::default()
        },
    )
    .unwrap()
}

/// A shipped scene's text with replacements, loaded from a temporary file.
fn edited(name: &str, edits: &[(&str, &str)], precision: &str, tag: &str) -> Scene {
    let mut text = std::fs::read_to_string(repo(&format!("configs/{name}.toml"))).unwrap();
    for (a, b) in edits {
        assert!(text.contains(a), "{name}: no {a:?}");
        text = text.replacen(a, b, 1);
    }
    let d = scratch(&format!("effects-{tag}"));
    std::fs::create_dir_all(&d).unwrap();
    let p = d.join("scene.toml");
    std::fs::write(&p, text).unwrap();
    load_scene(
        &p,
        &Overrides {
            precision: Some(precision.parse().expect("f32 or f64")),
            samples: Some(100_000),
            laws: Some(vec!["newton".into(), "paper".into()]),
            ..Overrides::default()
        },
    )
    .unwrap()
}

const SPHERE: (&str, &str) = ("semi_axes = [1.0, 1.0, 2.0]", "semi_axes = [1.0, 1.0, 1.0]");

/// Scenes covering the four kernel variants, with the variant each derives.
fn scenes(precision: &str) -> Vec<(String, Scene, &'static str)> {
    vec![
        (
            "floor".into(),
            shipped("floor", precision, 100_000),
            "rotation",
        ),
        (
            "floor_sphere".into(),
            shipped("floor_sphere", precision, 100_000),
            "closed-form",
        ),
        (
            "corner3".into(),
            shipped("corner3", precision, 100_000),
            "rotation+lcp",
        ),
        (
            "corner3 sphere".into(),
            edited("corner3", &[SPHERE], precision, "c3s"),
            "closed-form",
        ),
        (
            // A sphere in a 60° wedge: G is not diagonal, so the LCP stays.
            "wedge sphere".into(),
            edited(
                "corner2_paper",
                &[
                    SPHERE,
                    (
                        "normal = [0.0, 1.0, 0.0]",
                        "normal = [0.5, 0.8660254037844386, 0.0]",
                    ),
                ],
                precision,
                "wedge",
            ),
            "lcp",
        ),
    ]
}

#[test]
fn each_scene_gets_the_variant_its_geometry_needs() {
    for (name, s, want) in scenes("f64") {
        assert_eq!(KernelVariant::of(&s, Keep::NONE).name(), want, "{name}");
        assert_eq!(
            KernelVariant::of(&s, Keep::ALL).name(),
            "rotation+lcp",
            "{name}"
        );
    }
}

/// The largest difference between two kernels' outcomes of the same
/// samples: post-impact v and ω (m/s, rad/s) and impulses over the mass;
/// the draws must be the same and every energy finite.
fn worst_difference(s: &Scene, name: &str, a: &[SampleOutcome], b: &[SampleOutcome]) -> f64 {
    let mut worst = 0f64;
    for (a, b) in a.iter().zip(b) {
        assert_eq!(a.index, b.index);
        assert_eq!(a.velocity, b.velocity, "{name}: the draws differ");
        for k in 0..3 {
            worst = worst
                .max((a.velocity_after[k] - b.velocity_after[k]).abs())
                .max((a.omega_after[k] - b.omega_after[k]).abs());
        }
        for (x, y) in a.impulses.iter().zip(&b.impulses) {
            worst = worst.max((x - y).abs() / s.body().mass());
        }
        assert!(
            a.energy_after.is_finite() && b.energy_after.is_finite(),
            "{name}"
        );
    }
    worst
}

/// Sample by sample: the specialised kernel against the kernel with every
/// effect, on the same draws, under every law.
#[test]
fn specialised_kernels_match_the_all_effects_kernel_per_sample() {
    let all = KernelVariant::ALL_FRICTIONLESS;
    for precision in ["f64", "f32"] {
        // f64: rounding only (closed form against LCP enumeration);
        // f32: the kernel's documented velocity bound.
        let tol = if precision == "f64" { 1e-12 } else { 1e-5 };
        for (name, s, _) in scenes(precision) {
            let scale = 10.0; // |v|, L|ω| are O(1) here; impulses are divided by the mass
            for law in [
                Law::Newton,
                Law::Paper,
                Law::Poisson,
                Law::Pgs { sweeps: 8 },
            ] {
                let fast = evaluate_samples(&s, law, 1000, 1500);
                let full = evaluate_samples_with(&s, law, 1000, 1500, all);
                let worst = worst_difference(&s, &name, &fast, &full);
                assert!(
                    worst < tol * scale,
                    "{name} {precision} {}: specialised and all-effects kernels differ by {worst:e}",
                    law.name()
                );
            }
        }
    }
}

/// `--keep friction`: the frictional kernel on frictionless scenes gives
/// the frictionless answers (rounding; with several contacts `newton` is
/// Gauss–Seidel to its stopping rule, 1e-13 of `m(|v| + L|ω|)` in f64 and
/// 2e-6 in f32), and is the kernel that runs.
#[test]
fn kept_friction_gives_the_frictionless_answers() {
    let keep: Keep = "friction".parse().unwrap();
    let kept = |s: &Scene| KernelVariant::of(s, keep);
    for precision in ["f64", "f32"] {
        let tol = if precision == "f64" { 1e-10 } else { 1e-4 };
        for (name, s, _) in scenes(precision) {
            assert_eq!(kept(&s).name(), "friction", "{name}");
            let scale = 10.0;
            for law in [Law::Newton, Law::Paper, Law::Pgs { sweeps: 8 }] {
                let fast = evaluate_samples(&s, law, 0, 1500);
                let rough = evaluate_samples_with(&s, law, 0, 1500, kept(&s));
                let worst = worst_difference(&s, &name, &fast, &rough);
                let rubbed = rough.iter().flat_map(|o| &o.tangential).any(|&f| f != 0.0);
                assert!(!rubbed, "{name}: a tangential impulse without friction");
                assert!(
                    worst < tol * scale,
                    "{name} {precision} {}: kept friction differs by {worst:e}",
                    law.name()
                );
            }
        }
    }
}

/// A vector drawn alone takes only its own Box–Muller pairs: the inputs
/// must still be the reference sampler's.
#[test]
fn vectors_drawn_alone_match_the_reference_sampler() {
    for (name, s, _) in scenes("f64") {
        let sampler = Sampler::new(&s);
        for got in evaluate_samples(&s, Law::Newton, 77, 300) {
            let (_, v, w) = sampler.reference(got.index);
            for k in 0..3 {
                assert!((got.velocity[k] - v[k]).abs() < 1e-13, "{name}");
                assert!((got.omega[k] - w[k]).abs() < 1e-13, "{name}");
            }
        }
    }
}

/// The run path of a sphere skips the orientation draws: that leaves the
/// identity and does not shift the velocity draws.
#[test]
fn skipping_orientations_shifts_no_other_draw() {
    let s = shipped("corner3", "f32", 1000);
    let full = Sampler::new(&s);
    let skip = full.with_orientation(false);
    let (mut a, mut b) = (Inputs::<f32>::new(), Inputs::<f32>::new());
    full.fill(4096, &mut a);
    skip.fill(4096, &mut b);
    assert_eq!(a.v, b.v);
    assert_eq!(a.w, b.w);
    assert_ne!(a.a, b.a, "the full sampler draws orientations");
    for (k, row) in b.a.iter().enumerate() {
        let want = if k % 4 == 0 { 1.0 } else { 0.0 };
        assert!(
            row.iter().all(|&x| x == want),
            "entry {k} is not the identity's"
        );
    }
}

fn summary(s: &Scene, all_effects: bool) -> Summary {
    let opts = RunOptions {
        threads: 2,
        keep: if all_effects { Keep::ALL } else { Keep::NONE },
        ..RunOptions::default()
    };
    Summary::new(s, &run(s, &opts).unwrap())
}

/// End to end: the same counts and, to rounding, the same moments, whether
/// the effects a scene does not need are compiled out or not (the run path
/// draws no orientations for a sphere).
#[test]
fn run_statistics_do_not_depend_on_the_specialisation() {
    for (name, s, _) in scenes("f64") {
        let (a, b) = (summary(&s, false), summary(&s, true));
        for law in ["newton", "paper"] {
            let (ga, gb) = (a.all_group(law).unwrap(), b.all_group(law).unwrap());
            assert_eq!(ga.impacts, gb.impacts, "{name} {law}");
            assert_eq!(ga.active_sets, gb.active_sets, "{name} {law}");
            for stat in ["energy_ratio", "omega_after_norm", "velocity_after_norm"] {
                let (x, y) = (&ga.stats[stat], &gb.stats[stat]);
                for (key, x, y) in [
                    ("mean", x.mean, y.mean),
                    ("sd", x.sd, y.sd),
                    ("min", x.min, y.min),
                    ("max", x.max, y.max),
                ] {
                    assert!(
                        (x - y).abs() <= 1e-12 * x.abs().max(1.0),
                        "{name} {law} {stat}.{key}: {x} vs {y}"
                    );
                }
            }
        }
    }
}

/// `floor_sphere` has no spin: |ω⁺| is counted as exact zeros, not
/// computed, and agrees with the kernel that computes it per sample.
#[test]
fn constant_spin_is_counted_exactly() {
    // With |ω⁺|'s quantiles, which the default does not keep.
    let q = ["energy_ratio", "omega_after_norm"]
        .map(String::from)
        .to_vec();
    let s = shipped_with("floor_sphere", "f32", 50_000, Some(q));
    assert_eq!(s.effects().constant_spin, Some(0.0));
    assert!(s.effects().line().contains("|ω⁺| = 0 in every sample"));
    let (a, b) = (summary(&s, false), summary(&s, true));
    let (ga, gb) = (
        a.all_group("newton").unwrap(),
        b.all_group("newton").unwrap(),
    );
    let fields = |w: &impactmc::output::summary::StatSummary| {
        [
            Some(w.mean),
            Some(w.sd),
            Some(w.min),
            Some(w.max),
            w.median,
            w.p01,
            w.p99,
        ]
    };
    let w = &ga.stats["omega_after_norm"];
    assert_eq!(w.n, ga.impacts);
    assert_eq!(fields(w), [Some(0.0); 7]);
    assert_eq!(fields(&gb.stats["omega_after_norm"]), [Some(0.0); 7]);
    // Paired differences of a constant are exact zeros too.
    let p = &a.paired["paper-newton"].omega_after_norm;
    assert_eq!((p.mean, p.sd), (0.0, 0.0));
}

#[test]
fn only_requested_statistics_are_reported() {
    // Default: quantiles of the energy ratio, moments of
    // everything else, no per-set groups.
    let s = edited("corner3", &[], "f32", "stats0");
    assert!(s
        .effects()
        .line()
        .ends_with("statistics: quantiles of energy_ratio"));
    let a = summary(&s, false);
    let law = &a.laws["newton"].groups;
    assert_eq!(law.keys().collect::<Vec<_>>(), ["all"]);
    let g = a.all_group("newton").unwrap();
    assert!(g.stats["energy_ratio"].median.is_some());
    for stat in ["omega_after_norm", "velocity_after_norm", "impulse_floor"] {
        assert!(g.stats[stat].median.is_none(), "{stat}");
        assert!(g.stats[stat].p99.is_none(), "{stat}");
        assert!(g.stats[stat].mean.is_finite(), "{stat}");
    }

    // Requested: impulse quantiles and per-set groups; no energy quantiles.
    let s = edited(
        "corner3",
        &[(
            "[body]",
            "[statistics]\nquantiles = [\"impulse\"]\nby_active_set = true\n\n[body]",
        )],
        "f32",
        "stats",
    );
    assert!(s
        .effects()
        .line()
        .contains("statistics: quantiles of impulse; moments per active set"));
    let b = summary(&s, false);
    let g = b.all_group("newton").unwrap();
    assert!(g.stats["energy_ratio"].median.is_none());
    assert!(g.stats["energy_ratio"].mean.is_finite());
    assert!(g.stats["impulse_floor"].median.is_some());
    let law = &b.laws["newton"].groups;
    assert!(
        law.contains_key("wall_x+wall_y+floor"),
        "{:?}",
        law.keys().collect::<Vec<_>>()
    );
    // The moments do not depend on what else is kept.
    assert_eq!(
        a.all_group("newton").unwrap().stats["energy_ratio"].mean,
        g.stats["energy_ratio"].mean
    );
}

#[test]
fn bad_statistics_are_named() {
    for (quantiles, want) in [
        (
            "[\"energy\"]",
            "statistics.quantiles[0]: unknown statistic \"energy\"",
        ),
        (
            "[\"rebound\", \"rebound\"]",
            "statistics.quantiles[1]: \"rebound\" is listed twice",
        ),
    ] {
        let text = std::fs::read_to_string(repo("configs/floor.toml"))
            .unwrap()
            .replacen(
                "[body]",
                &format!("[statistics]\nquantiles = {quantiles}\n\n[body]"),
                1,
            );
        let d = scratch("effects-bad");
        std::fs::create_dir_all(&d).unwrap();
        let p = d.join("scene.toml");
        std::fs::write(&p, text).unwrap();
        let err = load_scene(&p, &Overrides::default())
            .unwrap_err()
            .to_string();
        assert!(err.contains(want), "{err}");
    }
}
