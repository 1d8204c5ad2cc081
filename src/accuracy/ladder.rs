//! The contact ladder: rigid laws, solver settings and precisions against
//! the compliant reference, on one scene's samples.

use std::path::Path;
use std::time::Instant;

use glam::DVec3;

use crate::config::{parse_law, Overrides, Placement, Precision, Scene, SceneError, SceneText};
use crate::engine::{evaluate_samples, run, RunOptions};
use crate::physics::{support_point_lagrange, ContactGeometry, Law, Pose, State};

use super::*;

fn variant(
    src: &SceneText,
    laws: Vec<String>,
    precision: Precision,
    samples: u64,
) -> Result<Scene, SceneError> {
    src.scene(&Overrides {
        laws: Some(laws),
        precision: Some(precision),
        samples: Some(samples),
        ..Default::default()
    })
}

/// Nanoseconds per sample of an end-to-end run on one thread, of
/// `accuracy.timing_samples` samples, or of fewer when that would take more
/// than about [`TIMING_BUDGET_S`] (a probe of 1 000 samples decides).
fn timed_run(
    src: &SceneText,
    law: &str,
    precision: Precision,
    knobs: &Knobs,
) -> Result<f64, SceneError> {
    let one = |samples: u64| -> Result<f64, SceneError> {
        let scene = variant(src, vec![law.to_string()], precision, samples)?;
        let r = run(
            &scene,
            &RunOptions {
                threads: 1,
                ..Default::default()
            },
        )
        .expect("a one-thread pool");
        Ok(r.wall_seconds * 1e9 / samples as f64)
    };
    let probe = one(1000)?;
    let affordable = (TIMING_BUDGET_S * 1e9 / probe) as u64;
    let samples = knobs.timing_samples.min(affordable.max(1000));
    if samples <= 1000 {
        return Ok(probe);
    }
    one(samples)
}

/// Wall-time budget of one rung's timing run (s).
const TIMING_BUDGET_S: f64 = 5.0;

/// Runs the ladder on the scene at `path` (its `[accuracy]` and
/// `[material]` knobs). `progress` receives one line per rung.
///
/// With friction on a touching plane the rigid rungs are `paper`, `pgsN`
/// and `newton` (`poisson` is not defined with friction), the compliant
/// rungs add regularised Coulomb, and with one touching plane `stronge`
/// joins as a rung and as a second rigid reference (`vs_stronge`).
pub fn ladder(path: &Path, steps: &mut Steps) -> Result<Ladder, LadderError> {
    ladder_of(&SceneText::read(path)?, steps)
}

/// [`ladder`](fn@ladder) of scene text (the file it names is only for errors).
pub fn ladder_of(src: &SceneText, steps: &mut Steps) -> Result<Ladder, LadderError> {
    let file = src.file.clone();
    let base = src.scene(&Overrides::default())?;
    let knobs = Knobs::from_raw(&file, base.raw())?;
    // The ladder's body by the kind of scene: flights for a drop.
    if let Placement::Drop(start) = base.placement() {
        return flight_ladder(src, &base, start, knobs, steps);
    }
    let n = knobs.samples;
    let touching = base.touching_planes();
    let rough = touching.iter().any(|p| p.friction() > 0.0);
    let with_stronge = rough && touching.len() == 1;
    let mut laws: Vec<String> = vec!["paper".into()];
    laws.extend(knobs.pgs_sweeps.iter().map(|s| format!("pgs{s}")));
    laws.push("newton".into());
    if !rough {
        laws.push("poisson".into());
    }
    if with_stronge {
        laws.push("stronge".into());
    }
    // The reference, each law, each compliant step count, f32, each count.
    steps.begin(1 + laws.len() + knobs.compliant_steps.len() + 1 + knobs.sample_counts.len())?;
    let newton64 = variant(src, vec!["newton".into()], Precision::F64, 1)?;
    let reference_outcomes = evaluate_samples(&newton64, Law::Newton, 0, n);
    let inputs: Vec<(Pose, State)> = reference_outcomes
        .iter()
        .map(|o| sample_input(&newton64, o))
        .collect();
    let newton_posts: Vec<Post> = reference_outcomes.iter().map(post_of).collect();
    let stronge_posts: Option<Vec<Post>> = if with_stronge {
        let scene = variant(src, vec!["stronge".into()], Precision::F64, 1)?;
        Some(
            evaluate_samples(&scene, Law::Stronge, 0, n)
                .iter()
                .map(post_of)
                .collect(),
        )
    } else {
        None
    };
    steps.say(&format!(
        "reference: compliant, {} RK4 steps per contact, E* = {:e} Pa{}, {n} samples",
        knobs.reference_steps,
        knobs.effective_modulus,
        if rough {
            format!(
                ", regularised Coulomb ε = {:e} (|v| + L|ω|)",
                knobs.friction_regularisation
            )
        } else {
            String::new()
        }
    ));
    let (reference, _, reference_unseparated) =
        compliant_posts(&newton64, &inputs, knobs.compliant(knobs.reference_steps));
    steps.step(&if reference_unseparated > 0 {
        format!("reference: {reference_unseparated} samples not separated within the step budget")
    } else {
        "reference: every sample separated".into()
    })?;
    let judged = |mut r: Rung, posts: &[Post]| -> Rung {
        r.vs_compliant = errors(posts, &reference);
        r.vs_newton = errors(posts, &newton_posts);
        r.vs_stronge = stronge_posts.as_ref().map(|s| errors(posts, s));
        r
    };
    let mut rungs = Vec::new();
    for name in &laws {
        let law = parse_law(name).expect("ladder law names are valid");
        let scene = variant(src, vec![name.clone()], Precision::F64, 1)?;
        let posts: Vec<Post> = evaluate_samples(&scene, law, 0, n)
            .iter()
            .map(post_of)
            .collect();
        let ns = timed_run(src, name, Precision::F64, &knobs)?;
        steps.step(&format!("law {name}: {ns:.1} ns/sample"))?;
        rungs.push(judged(Rung::new("law", name, "f64", ns), &posts));
    }
    for &count in &knobs.compliant_steps {
        let (posts, ns, unseparated) = compliant_posts(&newton64, &inputs, knobs.compliant(count));
        steps.step(&format!(
            "compliant {count} steps: {ns:.0} ns/sample, {unseparated} not separated"
        ))?;
        rungs.push(judged(
            Rung {
                unseparated: Some(unseparated as f64 / n as f64),
                ..Rung::new("compliant", &format!("compliant{count}"), "f64", ns)
            },
            &posts,
        ));
    }
    {
        let scene = variant(src, vec!["newton".into()], Precision::F32, 1)?;
        let posts: Vec<Post> = evaluate_samples(&scene, Law::Newton, 0, n)
            .iter()
            .map(post_of)
            .collect();
        let ns = timed_run(src, "newton", Precision::F32, &knobs)?;
        steps.step(&format!("newton f32: {ns:.1} ns/sample"))?;
        rungs.push(judged(Rung::new("precision", "newton", "f32", ns), &posts));
    }
    rungs.extend(contact_point_rungs(&newton64, &inputs));

    let law_for_counts = base.laws()[0].name();
    let counts = count_rows(src, &law_for_counts, &knobs.sample_counts, steps)?;
    Ok(Ladder {
        friction: rough,
        reference_unseparated,
        scene: base.name().to_string(),
        law_for_counts,
        knobs,
        rungs,
        counts,
    })
}

/// Closed-form support point against the paper's Lagrange route, on the
/// touching planes of every sample: error of the Lagrange point relative to
/// the closed form (in units of the body's length scale), and time per call.
pub fn contact_point_rungs(scene: &Scene, inputs: &[(Pose, State)]) -> Vec<Rung> {
    let planes = scene.touching_planes();
    let body = scene.body();
    let l = body.length_scale();
    let mut errs = Vec::new();
    for (pose, _) in inputs {
        for p in &planes {
            let g = ContactGeometry::new(body, pose.rotation, pose.centre, p);
            let (pt, _) = support_point_lagrange(body, pose.rotation, pose.centre, p);
            errs.push((pt - g.point).length() / l);
        }
    }
    let calls = (inputs.len() * planes.len()).max(1) as f64;
    let time = |f: &dyn Fn(&Pose, &crate::physics::Plane) -> DVec3| -> f64 {
        let reps = 20;
        let t0 = Instant::now();
        for _ in 0..reps {
            for (pose, _) in inputs {
                for p in &planes {
                    std::hint::black_box(f(std::hint::black_box(pose), p));
                }
            }
        }
        t0.elapsed().as_secs_f64() * 1e9 / (calls * reps as f64)
    };
    let closed = time(&|pose, p| ContactGeometry::new(body, pose.rotation, pose.centre, p).point);
    let lagrange = time(&|pose, p| support_point_lagrange(body, pose.rotation, pose.centre, p).0);
    let (rms, p99) = rms_p99(errs);
    vec![
        Rung {
            point_error: Some((0.0, 0.0)),
            ..Rung::new("contact_point", "closed_form", "f64", closed)
        },
        Rung {
            point_error: Some((rms, p99)),
            ..Rung::new("contact_point", "lagrange", "f64", lagrange)
        },
    ]
}
