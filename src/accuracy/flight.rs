//! The flight ladder: flight step and time-of-impact tolerance of a drop
//! scene's first impact.

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use crate::config::{DropBox, Scene};
use crate::physics::Rotation;

use super::*;

/// Time, v⁺, ω⁺ and energy ratio of a first impact.
type FirstImpact = (f64, DVec3, DVec3, f64);

/// The flight rungs of a drop scene: the first impact of `knobs.samples`
/// samples with RK4 rotation at each step, and with the exact rotation
/// (elliptic, or precession for a = b) at each time-of-impact tolerance,
/// against the exact rotation at a tolerance ten times finer than the
/// finest (the scene's law). Cost: one-thread ns per sample of the first
/// impact.
pub fn flight_ladder(
    src: &SceneText,
    scene: &Scene,
    start: &DropBox,
    knobs: Knobs,
    steps: &mut Steps,
) -> Result<Ladder, LadderError> {
    // The reference, each step, each tolerance, each sample count.
    steps.begin(
        1 + knobs.flight_steps.len() + knobs.toi_tolerances.len() + knobs.sample_counts.len(),
    )?;
    use crate::engine::drop::{first_impact, start_of};
    let law = scene.laws()[0];
    let sampler = crate::sampler::Sampler::new(scene);
    let starts: Vec<_> = (0..knobs.samples as u64)
        .map(|i| start_of(start, &sampler, i))
        .collect();
    let fine_tol = knobs
        .toi_tolerances
        .iter()
        .cloned()
        .fold(f64::INFINITY, f64::min)
        / 10.0;
    let run = |rotation: Rotation, tol: f64| -> (Vec<Option<FirstImpact>>, f64) {
        let timed = starts.len().min(200);
        let t0 = Instant::now();
        for s in &starts[..timed] {
            std::hint::black_box(first_impact(scene, law, s, rotation, tol));
        }
        let ns = t0.elapsed().as_secs_f64() * 1e9 / timed as f64;
        (
            starts
                .par_iter()
                .map(|s| first_impact(scene, law, s, rotation, tol))
                .collect(),
            ns,
        )
    };
    let exact = Rotation::exact_for(scene.body());
    steps.say(&format!(
        "flight reference: {} rotation, TOI tolerance {fine_tol:e} m, {} samples",
        exact.name(),
        knobs.samples
    ));
    let (reference, _) = run(exact, fine_tol);
    steps.step("flight reference: done")?;
    let compare = |got: &[Option<FirstImpact>]| -> (Errors, (f64, f64)) {
        let mut a = Vec::new();
        let mut b = Vec::new();
        let mut dt = Vec::new();
        for (x, y) in got.iter().zip(&reference) {
            if let (Some(x), Some(y)) = (x, y) {
                a.push(Post {
                    v: x.1,
                    w: x.2,
                    ratio: x.3,
                });
                b.push(Post {
                    v: y.1,
                    w: y.2,
                    ratio: y.3,
                });
                dt.push((x.0 - y.0).abs());
            }
        }
        (errors(&a, &b), rms_p99(dt))
    };
    let default_tol = scene.effects().toi_tolerance;
    let mut rungs = Vec::new();
    for &step in &knobs.flight_steps {
        let (got, ns) = run(Rotation::Rk4 { max_step: step }, default_tol);
        let (e, t) = compare(&got);
        steps.step(&format!(
            "flight step {step:e} s: {ns:.0} ns/sample, v⁺ RMS error {:.2e}",
            e.v_rms
        ))?;
        rungs.push(Rung {
            vs_flight_reference: Some(e),
            time_error: Some(t),
            ..Rung::new("flight_step", &format!("rk4 step {step:e} s"), "f64", ns)
        });
    }
    for &tol in &knobs.toi_tolerances {
        let (got, ns) = run(exact, tol);
        let (e, t) = compare(&got);
        steps.step(&format!(
            "TOI tolerance {tol:e} m: {ns:.0} ns/sample, v⁺ RMS error {:.2e}",
            e.v_rms
        ))?;
        rungs.push(Rung {
            vs_flight_reference: Some(e),
            time_error: Some(t),
            ..Rung::new(
                "toi_tolerance",
                &format!("{} toi {tol:e} m", exact.name()),
                "f64",
                ns,
            )
        });
    }
    let counts = count_rows(src, &law.name(), &knobs.sample_counts, steps)?;
    Ok(Ladder {
        friction: false,
        reference_unseparated: 0,
        scene: scene.name().to_string(),
        law_for_counts: law.name(),
        knobs,
        rungs,
        counts,
    })
}
