//! Friction in scenes: planes with μ = 0 leave today's kernel and results
//! untouched bit for bit; a frictional floor gives the energy ratios
//! friction.md's independent oracle reports, the friction statistics, and
//! the same bits for any thread count; a sweep can turn friction on; laws
//! a scene's friction rules out are refused, naming the law and the plane.

use crate::support;

use impactmc::config::{Overrides, Scene};
use impactmc::engine::{run, RunOptions};
use impactmc::output::summary::Summary;

/// A shipped scene with text edits, loaded with `samples` and `laws`.
fn edited(
    name: &str,
    edits: &[(&str, &str)],
    samples: u64,
    laws: &[&str],
) -> Result<Scene, String> {
    support::edited_scene(
        name,
        edits,
        &format!("friction-scene-{name}-{}", edits.len()),
        &Overrides {
            samples: Some(samples),
            laws: Some(laws.iter().map(|l| l.to_string()).collect()),
            ..Overrides::default()
        },
    )
}

fn summary(s: &Scene, threads: usize) -> Summary {
    let opts = RunOptions {
        threads,
        ..RunOptions::default()
    };
    Summary::new(s, &run(s, &opts).unwrap())
}

/// Of a `newton`/`stronge` summary: each law's fraction of samples with
/// `energy_gain`, and the pair's one-sided fractions (newton only, stronge
/// only).
fn energy_gains(r: &Summary) -> ([f64; 2], [f64; 2]) {
    let gain = |law: &str| r.all_group(law).unwrap().fractions["energy_gain"];
    let only = r.paired["stronge-newton"]
        .energy_gain_only
        .as_ref()
        .expect("the pair counts energy_gain");
    (
        [gain("newton"), gain("stronge")],
        [only["newton"], only["stronge"]],
    )
}

const FLOOR_K: &str = "restitution = 0.8\n";

#[test]
fn zero_friction_is_todays_kernel_bit_for_bit() {
    for precision in ["f32", "f64"] {
        let p = format!("precision = \"{precision}\"");
        let plain = edited(
            "floor",
            &[("precision = \"f32\"", &p)],
            200_000,
            &["newton", "paper"],
        )
        .unwrap();
        let zero = edited(
            "floor",
            &[
                ("precision = \"f32\"", &p),
                (FLOOR_K, "restitution = 0.8\nfriction = 0.0\n"),
            ],
            200_000,
            &["newton", "paper"],
        )
        .unwrap();
        assert!(!zero.effects().friction, "μ = 0 is no friction");
        let (a, b) = (summary(&plain, 2), summary(&zero, 2));
        assert_eq!(
            serde_json::to_value(&a.laws).unwrap(),
            serde_json::to_value(&b.laws).unwrap(),
            "{precision}: μ = 0 changed the results"
        );
    }
}

/// friction.md ("Measured by the independent oracle"): on the frictional
/// floor (S1 with μ = 0.5) the energy ratio is about 0.69 under `newton`
/// and 0.63 under `stronge`, and neither gains energy.
#[test]
fn frictional_floor_matches_the_oracle_and_is_thread_independent() {
    let s = edited("floor_friction", &[], 40_000, &["newton", "stronge"]).unwrap();
    assert!(s.effects().friction);
    let two = summary(&s, 2);
    for (law, want) in [("newton", 0.69), ("stronge", 0.63)] {
        let all = two.all_group(law).unwrap();
        let mean = all.stats["energy_ratio"].mean;
        assert!(
            (mean - want).abs() < 0.01,
            "{law}: energy ratio {mean} vs about {want}"
        );
        assert_eq!(all.fractions["energy_gain"], 0.0, "{law}");
        for key in ["tangential_impulse_floor", "sliding_speed_floor"] {
            let n = all.stats[key].n;
            assert!(n > 30_000, "{law} {key}: n = {n}");
        }
        let stuck = all.fractions["sticking_floor"];
        assert!(stuck > 0.0 && stuck < 1.0, "{law}: sticking {stuck}");
        assert!(all.fractions.contains_key("ambiguous"));
        assert!(all.fractions.contains_key("unconverged"));
    }
    // As in the oracle's figures, stronge dissipates more than newton here.
    let e = |law: &str| two.all_group(law).unwrap().stats["energy_ratio"].mean;
    assert!(e("stronge") < e("newton"));
    let one = summary(&s, 1);
    assert_eq!(
        serde_json::to_value(&one.laws).unwrap(),
        serde_json::to_value(&two.laws).unwrap(),
        "1 and 2 threads differ"
    );
}

/// The rough corner, where the lanes take the certificate's shortcut and
/// accelerate Gauss–Seidel (each jump decided by the lane's own data):
/// the same summary on 1 and 2 threads, in both precisions, with nearly
/// every lane solved in lanes.
#[test]
fn rough_corner_is_thread_independent() {
    for precision in ["f32", "f64"] {
        let s = support::edited_scene(
            "corner3_friction",
            &[],
            &format!("friction-scene-corner3-threads-{precision}"),
            &Overrides {
                samples: Some(3 * 4096),
                precision: Some(precision.parse().unwrap()),
                ..Overrides::default()
            },
        )
        .unwrap();
        let (one, two) = (summary(&s, 1), summary(&s, 2));
        assert_eq!(
            serde_json::to_value(&one.laws).unwrap(),
            serde_json::to_value(&two.laws).unwrap(),
            "{precision}: 1 and 2 threads differ"
        );
        let recomputed = two.all_group("newton").unwrap().fractions["recomputed_f64"];
        assert!(recomputed < 0.1, "{precision}: recomputed {recomputed}");
    }
}

#[test]
fn laws_that_friction_rules_out_are_refused() {
    let rough = ("restitution = 0.8\n", "restitution = 0.8\nfriction = 0.3\n");
    // The laws come from the overrides, so the error names the flag.
    let err = edited("floor", &[rough], 1000, &["poisson"]).unwrap_err();
    assert!(
        err.contains("poisson") && err.contains("floor") && err.contains("--law[0]"),
        "{err}"
    );
    // Poisson is fine when no touching plane has friction.
    edited("floor", &[], 1000, &["poisson"]).unwrap();
    let err = edited("corner3", &[], 1000, &["stronge"]).unwrap_err();
    assert!(err.contains("stronge") && err.contains("wall_x"), "{err}");
    let err = edited(
        "floor",
        &[(
            "restitution = 0.8\n",
            "restitution = 0.8\nfriction = -0.1\n",
        )],
        1000,
        &["newton"],
    )
    .unwrap_err();
    assert!(
        err.contains("planes") && err.contains("friction") && err.contains("-0.1"),
        "{err}"
    );
    // Stronge on one touching plane without friction is newton.
    let s = edited("floor", &[], 20_000, &["newton", "stronge"]).unwrap();
    let r = summary(&s, 2);
    let e = |law: &str| r.all_group(law).unwrap().stats["energy_ratio"].mean;
    assert_eq!(e("newton"), e("stronge"));
}

/// Drops with friction: the first impact's friction statistics are in the
/// summary, and `stronge` in flight solves an impact that meets several
/// planes at once with `newton`, counted as `coupled_fallback`
/// (friction.md). A sphere thrown without gravity at the edge of a wall and
/// the floor meets both at once, in every sample.
#[test]
fn drops_with_friction_report_it_and_stronge_falls_back_on_several_planes() {
    let rough = [
        ("restitution = 0.5\n", "restitution = 0.5\nfriction = 0.3\n"),
        ("restitution = 0.7\n", "restitution = 0.7\nfriction = 0.3\n"),
        ("restitution = 0.9\n", "restitution = 0.9\nfriction = 0.3\n"),
    ];
    let s = edited("drop_corner", &rough, 2000, &["newton", "stronge"]).unwrap();
    let r = summary(&s, 2);
    for law in ["newton", "stronge"] {
        let all = r.all_group(law).unwrap();
        for plane in ["wall_x", "wall_y", "floor"] {
            let stuck = all.fractions[&format!("sticking_{plane}")];
            assert!((0.0..=1.0).contains(&stuck), "{law} {plane}: {stuck}");
            assert!(all
                .stats
                .contains_key(&format!("tangential_impulse_{plane}")));
        }
        let fallback = all.fractions["coupled_fallback"];
        if law == "newton" {
            assert_eq!(fallback, 0.0);
        }
    }

    let mut edge = rough.to_vec();
    edge.extend([
        ("semi_axes = [0.5, 0.3, 0.2]", "semi_axes = [0.5, 0.5, 0.5]"),
        (
            "drop = { min = [0.6, 0.6, 1.0], max = [1.2, 1.2, 2.0] }",
            "drop = { min = [1.0, 3.0, 1.0], max = [1.0, 3.0, 1.0] }",
        ),
        ("gravity = 9.81", "gravity = 0.0"),
        ("bounces = 5", "bounces = 1"),
        (
            "mean = [-1.5, -1.5, 0.0]\nsd = [0.5, 0.5, 0.5]",
            "mean = [-1.0, 0.0, -1.0]\nsd = [0.0, 0.0, 0.0]",
        ),
        ("sd = [2.0, 2.0, 2.0]", "sd = [0.0, 0.0, 0.0]"),
    ]);
    let s = edited("drop_corner", &edge, 200, &["newton", "stronge"]).unwrap();
    let r = summary(&s, 2);
    let all = |law: &str| r.all_group(law).unwrap();
    assert_eq!(all("stronge").fractions["coupled_fallback"], 1.0);
    assert_eq!(all("newton").fractions["coupled_fallback"], 0.0);
    // Solved by newton, the impact is newton's.
    assert_eq!(
        all("stronge").stats["energy_ratio"].mean,
        all("newton").stats["energy_ratio"].mean
    );
    // Every sample's first impact meets the wall and the floor together.
    assert_eq!(all("newton").active_sets["wall_x+floor"], 1.0);
}

/// Kane's paradox in the summary: a thin rod (k = 1, μ = 1) on the rough
/// floor gains energy under `newton` in a large share of samples and never
/// under `stronge`; the paired summary counts the samples where exactly one
/// of the two raised `energy_gain`, which here are all of newton's.
#[test]
fn paired_summary_counts_where_newton_gains_energy_and_stronge_does_not() {
    let s = edited(
        "floor_friction",
        &[
            ("restitution = 0.8", "restitution = 1.0"),
            ("friction = 0.5", "friction = 1.0"),
            ("semi_axes = [1.0, 1.0, 2.0]", "semi_axes = [0.2, 0.2, 2.0]"),
        ],
        20_000,
        &["newton", "stronge"],
    )
    .unwrap();
    let r = summary(&s, 2);
    let ([newton, stronge], [newton_only, stronge_only]) = energy_gains(&r);
    assert_eq!(stronge, 0.0);
    assert_eq!(stronge_only, 0.0);
    assert!(newton > 0.05, "newton gains in {newton}");
    assert_eq!(newton_only, newton);
    let text = r.to_text();
    assert!(
        text.contains("energy_gain in stronge only 0 (≤ 1.9e-4), newton only"),
        "{text}"
    );
}

/// A drop's pairs count energy_gain at the first impact as a contact
/// scene's do: a thin rough rod dropped on the floor gains energy under
/// `newton` in many first impacts and never under `stronge`, and the two
/// one-sided counts differ by exactly the difference of the laws' counts.
#[test]
fn a_drops_pairs_count_where_one_law_gains_energy_at_the_first_impact() {
    let s = edited(
        "drop_dice",
        &[
            ("restitution = 0.6", "restitution = 1.0"),
            ("friction = 0.3", "friction = 1.0"),
            (
                "semi_axes = [0.03, 0.02, 0.01]",
                "semi_axes = [0.01, 0.01, 0.1]",
            ),
            ("bounces = 20", "bounces = 2"),
        ],
        4_000,
        &["newton", "stronge"],
    )
    .unwrap();
    let r = summary(&s, 2);
    let ([newton, stronge], [newton_only, stronge_only]) = energy_gains(&r);
    assert_eq!(stronge, 0.0);
    assert!(newton > 0.02, "newton gains in {newton}");
    assert_eq!(stronge_only, 0.0);
    assert!((newton_only - stronge_only - (newton - stronge)).abs() < 1e-12);
}
