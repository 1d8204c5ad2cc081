//! Impacts happen at contact, whatever the contact tolerance: the
//! time-of-impact search stops at a tight length of its own, then every
//! plane within `contact_tolerance` of the body at that moment joins the
//! impact.

use crate::support;

use impactmc::config::{Overrides, Scene};
use impactmc::engine::{run, RunOptions};
use impactmc::output::summary::Summary;
use serde_json::Value;

fn overrides(samples: u64, precision: &str) -> Overrides {
    Overrides {
        samples: Some(samples),
        precision: Some(precision.parse().expect("f32 or f64")),
        laws: Some(vec!["newton".into()]),
        ..Overrides::default()
    }
}

/// The first bounce of law `newton` in a drop scene's summary.
fn first_bounce(s: &Scene) -> Value {
    let r = run(
        s,
        &RunOptions {
            threads: 2,
            ..RunOptions::default()
        },
    )
    .expect("run");
    let summary = Summary::new(s, &r);
    serde_json::to_value(&summary.drops["newton"].bounces[0]).expect("serialisable")
}

fn share(b: &Value, key: &str, cell: &str) -> f64 {
    b[key][cell].as_f64().unwrap_or(0.0)
}

/// The share of first impacts that meet two planes or more.
fn multi_plane_share(b: &Value) -> f64 {
    b["planes_hit"]
        .as_object()
        .expect("planes_hit")
        .iter()
        .filter(|(set, _)| set.contains('+'))
        .map(|(_, v)| v.as_f64().unwrap())
        .sum()
}

/// A sphere (radius 0.5 m) thrown without gravity at the edge of the walls
/// x = 0 and y = 0, from (0.5 + dx, 0.5 + dy, 3) at v = (−1, −1/2, 0):
/// it touches wall x first, at t = dx, when its gap to wall y is
/// g = dy − dx/2. Wall y joins that impact exactly when g ≤
/// contact_tolerance (1 mm here), and the impact is at t = dx, not where
/// the search first came within a millimetre.
#[test]
fn a_plane_joins_the_impact_exactly_when_its_gap_is_within_the_contact_tolerance() {
    let dx = 0.1;
    for (gap, joins) in [
        (0.999e-3, true),
        (1.001e-3, false),
        (0.2e-3, true),
        (5e-3, false),
    ] {
        let dy = gap + 0.5 * dx;
        let start = format!(
            "drop = {{ min = [{x}, {y}, 3.0], max = [{x}, {y}, 3.0] }}",
            x = 0.5 + dx,
            y = 0.5 + dy
        );
        let s = support::edited_scene(
            "drop_corner",
            &[
                ("seed = 42", "seed = 42\ncontact_tolerance = 1e-3"),
                ("semi_axes = [0.5, 0.3, 0.2]", "semi_axes = [0.5, 0.5, 0.5]"),
                (
                    "drop = { min = [0.6, 0.6, 1.0], max = [1.2, 1.2, 2.0] }",
                    &start,
                ),
                ("gravity = 9.81", "gravity = 0.0"),
                ("bounces = 5", "bounces = 1"),
                (
                    "mean = [-1.5, -1.5, 0.0]\nsd = [0.5, 0.5, 0.5]",
                    "mean = [-1.0, -0.5, 0.0]\nsd = [0.0, 0.0, 0.0]",
                ),
                ("sd = [2.0, 2.0, 2.0]", "sd = [0.0, 0.0, 0.0]"),
            ],
            &format!("toi-edge-{gap}"),
            &overrides(64, "f64"),
        )
        .expect("scene");
        assert_eq!(s.effects().toi_tolerance, 5e-10, "the tight default");
        let b = first_bounce(&s);
        let (both, alone) = (
            share(&b, "planes_hit", "wall_x+wall_y"),
            share(&b, "planes_hit", "wall_x"),
        );
        assert_eq!(
            (both, alone),
            if joins { (1.0, 0.0) } else { (0.0, 1.0) },
            "gap {gap:e}: {b}"
        );
        let t = b["interval_seconds"]["mean"].as_f64().unwrap();
        assert!(
            (t - dx).abs() <= 1e-9,
            "gap {gap:e}: the impact is at t = {t}, not at contact ({dx})"
        );
    }
}

/// `drop_corner` with `contact_tolerance = 1e-3`: the share of first
/// impacts that meet two planes or more is the share whose second plane is
/// within 1 mm at contact, as the shipped scene's own simultaneity curve
/// (default contact tolerance) measures it, and the same as with the
/// search tolerance set by hand to the tight default; in every precision a
/// drop scene can be asked for (drops run the f64 reference).
#[test]
fn coupled_first_impacts_match_the_simultaneity_curve_at_the_contact_tolerance() {
    let n = 200_000u64;
    for precision in ["f64", "f32"] {
        let scene = |edits: &[(&str, &str)], tag: &str| {
            let mut all = vec![("bounces = 5", "bounces = 1")];
            all.extend_from_slice(edits);
            support::edited_scene("drop_corner", &all, tag, &overrides(n, precision))
                .expect("scene")
        };
        let curve = share(
            &first_bounce(&scene(&[], &format!("toi-curve-{precision}"))),
            "simultaneous_within_tolerance",
            "1e-3",
        );
        let coarse = [("seed = 42", "seed = 42\ncontact_tolerance = 1e-3")];
        let by_default = multi_plane_share(&first_bounce(&scene(
            &coarse,
            &format!("toi-default-{precision}"),
        )));
        let by_hand = multi_plane_share(&first_bounce(&scene(
            &[
                coarse[0],
                (
                    "energy_floor = 1e-4",
                    "energy_floor = 1e-4\ntoi_tolerance = 5e-10",
                ),
            ],
            &format!("toi-hand-{precision}"),
        )));
        // A binomial share of about 0.27 %: its standard error.
        let se = (curve * (1.0 - curve) / n as f64).sqrt();
        assert!(
            curve > 0.002 && curve < 0.0035,
            "{precision}: curve {curve}"
        );
        for (what, got) in [("default", by_default), ("by hand", by_hand)] {
            assert!(
                (got - curve).abs() <= 3.0 * se,
                "{precision}: two-plane share {got} ({what} toi_tolerance) against the curve's {curve} at 1 mm (se {se:e})"
            );
        }
    }
}
