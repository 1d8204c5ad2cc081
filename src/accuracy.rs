//! The accuracy ladder (`impactmc accuracy`): what each rung of accuracy
//! costs in time, on one scene's samples.
//!
//! Every rung is evaluated on the same samples (the scene's first
//! `accuracy.samples` draws) and compared with the finest compliant run
//! (the physical reference) and with the exact Newton LCP in f64:
//! RMS and p99 over samples of |Δv⁺| (m/s), |Δω⁺| (rad/s) and |ΔT⁺/T⁻|.
//! Costs are end-to-end nanoseconds per sample on one thread: for the rigid
//! laws and precisions a timed `run` of `accuracy.timing_samples` samples
//! (sampling, kernel and statistics); for the compliant rungs the
//! integration itself; for the contact-point rung one support-point
//! computation per touching plane.

use std::path::Path;
use std::time::Instant;

use glam::{DMat3, DVec3};
use polars::prelude::*;
use rayon::prelude::*;

use crate::config::RawScene;
use crate::engine::{evaluate_samples, run, RunOptions, SampleOutcome};
use crate::physics::{
    damping_table, solve_compliant_with, support_point_lagrange, CompliantParams, ContactGeometry,
    Law, Pose, State,
};
use crate::scene::{load_scene, parse_law, Overrides, Scene, SceneError};

/// Validated knobs of the ladder.
#[derive(Debug, Clone, PartialEq)]
pub struct Knobs {
    pub samples: usize,
    pub compliant_steps: Vec<u32>,
    pub reference_steps: u32,
    pub pgs_sweeps: Vec<u32>,
    pub sample_counts: Vec<u64>,
    pub timing_samples: u64,
    pub effective_modulus: f64,
    /// Drop scenes: RK4 steps of flight rotation (s) and time-of-impact
    /// tolerances (m) to compare; the reference is ten times finer than the
    /// finest of each.
    pub flight_steps: Vec<f64>,
    pub toi_tolerances: Vec<f64>,
}

fn field_err(file: &str, field: &str, message: String) -> SceneError {
    SceneError {
        file: file.to_string(),
        line: None,
        field: field.to_string(),
        message,
    }
}

impl Knobs {
    /// Defaults, then the scene's `[accuracy]` and `[material]`, validated.
    pub fn from_raw(file: &str, raw: &RawScene) -> Result<Self, SceneError> {
        let a = raw.accuracy.clone().unwrap_or_default();
        let k = Knobs {
            samples: a.samples.unwrap_or(2000) as usize,
            compliant_steps: a.compliant_steps.unwrap_or(vec![12, 25, 50, 100, 200, 400]),
            reference_steps: a.reference_steps.unwrap_or(1600),
            pgs_sweeps: a.pgs_sweeps.unwrap_or(vec![1, 2, 4, 8, 16, 32, 64]),
            sample_counts: a.sample_counts.unwrap_or(vec![
                1_000,
                10_000,
                100_000,
                1_000_000,
                10_000_000,
                100_000_000,
            ]),
            timing_samples: a.timing_samples.unwrap_or(1_000_000),
            flight_steps: a
                .flight_steps
                .clone()
                .unwrap_or(vec![2e-2, 1e-2, 5e-3, 2e-3, 1e-3]),
            toi_tolerances: a
                .toi_tolerances
                .clone()
                .unwrap_or(vec![1e-2, 1e-3, 1e-5, 1e-7, 1e-9]),
            effective_modulus: raw
                .material
                .as_ref()
                .and_then(|m| m.effective_modulus)
                .unwrap_or(1.15e11),
        };
        if !(1..=1_000_000).contains(&k.samples) {
            return Err(field_err(
                file,
                "accuracy.samples",
                format!("must be in 1..=1000000, got {}", k.samples),
            ));
        }
        for (name, steps) in [("accuracy.compliant_steps", &k.compliant_steps)] {
            if steps.is_empty() || steps.iter().any(|&s| s < 4) {
                return Err(field_err(
                    file,
                    name,
                    format!("must be a non-empty list of integers >= 4, got {steps:?}"),
                ));
            }
        }
        if k.reference_steps < 4 || k.compliant_steps.iter().any(|&s| s >= k.reference_steps) {
            return Err(field_err(
                file,
                "accuracy.reference_steps",
                format!(
                    "must exceed every compliant_steps value (the reference is the finest run), got {} with {:?}",
                    k.reference_steps, k.compliant_steps
                ),
            ));
        }
        if k.pgs_sweeps.contains(&0) {
            return Err(field_err(
                file,
                "accuracy.pgs_sweeps",
                format!("sweeps must be >= 1, got {:?}", k.pgs_sweeps),
            ));
        }
        if k.sample_counts.is_empty() || k.sample_counts.iter().any(|&n| n < 2) {
            return Err(field_err(
                file,
                "accuracy.sample_counts",
                format!("must list counts >= 2, got {:?}", k.sample_counts),
            ));
        }
        for (name, xs) in [
            ("accuracy.flight_steps", &k.flight_steps),
            ("accuracy.toi_tolerances", &k.toi_tolerances),
        ] {
            if xs.is_empty() || xs.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
                return Err(field_err(
                    file,
                    name,
                    format!("must list finite numbers > 0, got {xs:?}"),
                ));
            }
        }
        if k.timing_samples < 1000 {
            return Err(field_err(
                file,
                "accuracy.timing_samples",
                format!("must be >= 1000, got {}", k.timing_samples),
            ));
        }
        if !(k.effective_modulus.is_finite() && k.effective_modulus > 0.0) {
            return Err(field_err(
                file,
                "material.effective_modulus",
                format!(
                    "must be a finite number > 0 (Pa), got {}",
                    k.effective_modulus
                ),
            ));
        }
        Ok(k)
    }
}

/// Post-impact outcome of one sample under one rung.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Post {
    pub v: DVec3,
    pub w: DVec3,
    pub ratio: f64,
}

/// RMS and p99 of |Δv⁺|, |Δω⁺| and |ΔT⁺/T⁻| against a reference.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Errors {
    pub v_rms: f64,
    pub v_p99: f64,
    pub w_rms: f64,
    pub w_p99: f64,
    pub ratio_rms: f64,
    pub ratio_p99: f64,
}

impl Errors {
    /// For rungs a reference does not apply to (NaN, null in the table).
    pub const NONE: Errors = Errors {
        v_rms: f64::NAN,
        v_p99: f64::NAN,
        w_rms: f64::NAN,
        w_p99: f64::NAN,
        ratio_rms: f64::NAN,
        ratio_p99: f64::NAN,
    };
}

fn rms_p99(mut xs: Vec<f64>) -> (f64, f64) {
    if xs.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let rms = (xs.iter().map(|x| x * x).sum::<f64>() / xs.len() as f64).sqrt();
    xs.sort_by(f64::total_cmp);
    let k = ((0.99 * xs.len() as f64).ceil() as usize).clamp(1, xs.len()) - 1;
    (rms, xs[k])
}

/// Errors of `got` against `want`, sample by sample.
pub fn errors(got: &[Post], want: &[Post]) -> Errors {
    let (v_rms, v_p99) = rms_p99(
        got.iter()
            .zip(want)
            .map(|(a, b)| (a.v - b.v).length())
            .collect(),
    );
    let (w_rms, w_p99) = rms_p99(
        got.iter()
            .zip(want)
            .map(|(a, b)| (a.w - b.w).length())
            .collect(),
    );
    let (ratio_rms, ratio_p99) = rms_p99(
        got.iter()
            .zip(want)
            .map(|(a, b)| (a.ratio - b.ratio).abs())
            .collect(),
    );
    Errors {
        v_rms,
        v_p99,
        w_rms,
        w_p99,
        ratio_rms,
        ratio_p99,
    }
}

fn post_of(o: &SampleOutcome) -> Post {
    Post {
        v: DVec3::from_array(o.velocity_after),
        w: DVec3::from_array(o.omega_after),
        ratio: o.energy_after / o.energy_before,
    }
}

/// The pose and velocities of a sample as drawn (f64 draws).
pub fn sample_input(scene: &Scene, o: &SampleOutcome) -> (Pose, State) {
    let rotation = DMat3::from_cols_array(&o.rotation).transpose();
    (
        Pose {
            rotation,
            centre: scene.centre(rotation),
        },
        State {
            velocity: DVec3::from_array(o.velocity),
            omega: DVec3::from_array(o.omega),
        },
    )
}

/// Compliant outcomes of the samples with `steps` RK4 steps per contact
/// duration (in parallel; each sample is independent), and the
/// single-thread time per sample (ns) measured on the first samples.
pub fn compliant_posts(
    scene: &Scene,
    inputs: &[(Pose, State)],
    modulus: f64,
    steps: u32,
) -> (Vec<Post>, f64) {
    let planes: Vec<_> = scene.planes().iter().map(|p| p.plane).collect();
    let params = CompliantParams {
        effective_modulus: modulus,
        steps_per_contact: steps,
    };
    let alpha = damping_table(&planes);
    let one = |(pose, state): &(Pose, State)| -> Post {
        match solve_compliant_with(scene.body(), *pose, *state, &planes, params, &alpha) {
            Ok(o) => Post {
                v: o.after.velocity,
                w: o.after.omega,
                ratio: o.energy_after / o.energy_before,
            },
            // Nothing approaching: the body leaves untouched.
            Err(_) => Post {
                v: state.velocity,
                w: state.omega,
                ratio: 1.0,
            },
        }
    };
    let timed = inputs.len().min(200);
    let t0 = Instant::now();
    for x in &inputs[..timed] {
        std::hint::black_box(one(x));
    }
    let ns = t0.elapsed().as_secs_f64() * 1e9 / timed as f64;
    (inputs.par_iter().map(one).collect(), ns)
}

/// One rung of the ladder.
#[derive(Debug, Clone, PartialEq)]
pub struct Rung {
    /// `law`, `compliant`, `precision` or `contact_point`.
    pub family: String,
    pub rung: String,
    pub precision: String,
    pub ns_per_sample: f64,
    pub vs_compliant: Errors,
    pub vs_newton: Errors,
    /// Contact-point rung only: RMS and p99 of |ΔP| / length scale.
    pub point_error: Option<(f64, f64)>,
    /// Flight rungs only (drop scenes): first-impact errors against the
    /// finest flight settings, and RMS and p99 of the impact-time error (s).
    pub vs_flight_reference: Option<Errors>,
    pub time_error: Option<(f64, f64)>,
}

/// One point of the sample-count rung.
#[derive(Debug, Clone, PartialEq)]
pub struct CountRow {
    pub samples: u64,
    pub wall_seconds: f64,
    pub threads: usize,
    pub mean: f64,
    pub ci95: f64,
}

pub struct Ladder {
    pub scene: String,
    pub law_for_counts: String,
    pub knobs: Knobs,
    pub rungs: Vec<Rung>,
    pub counts: Vec<CountRow>,
}

fn variant(
    path: &Path,
    laws: Vec<String>,
    precision: &str,
    samples: u64,
) -> Result<Scene, SceneError> {
    load_scene(
        path,
        &Overrides {
            laws: Some(laws),
            precision: Some(precision.into()),
            samples: Some(samples),
            ..Default::default()
        },
    )
}

/// Nanoseconds per sample of an end-to-end run on one thread.
fn timed_run(scene: &Scene) -> f64 {
    let r = run(
        scene,
        &RunOptions {
            threads: 1,
            ..Default::default()
        },
    )
    .expect("a one-thread pool");
    r.wall_seconds * 1e9 / scene.samples() as f64
}

/// Runs the ladder on the scene at `path` (its `[accuracy]` and
/// `[material]` knobs). `progress` receives one line per rung.
pub fn ladder(path: &Path, progress: &mut dyn FnMut(&str)) -> Result<Ladder, SceneError> {
    let file = path.display().to_string();
    let base = load_scene(path, &Overrides::default())?;
    let knobs = Knobs::from_raw(&file, base.raw())?;
    if base.drop_box().is_some() {
        return Ok(flight_ladder(&base, knobs, progress));
    }
    let n = knobs.samples;
    let newton64 = variant(path, vec!["newton".into()], "f64", knobs.timing_samples)?;
    let reference_outcomes = evaluate_samples(&newton64, Law::Newton, 0, n);
    let inputs: Vec<(Pose, State)> = reference_outcomes
        .iter()
        .map(|o| sample_input(&newton64, o))
        .collect();
    let newton_posts: Vec<Post> = reference_outcomes.iter().map(post_of).collect();
    progress(&format!(
        "reference: compliant, {} RK4 steps per contact, E* = {:e} Pa, {n} samples",
        knobs.reference_steps, knobs.effective_modulus
    ));
    let (reference, _) = compliant_posts(
        &newton64,
        &inputs,
        knobs.effective_modulus,
        knobs.reference_steps,
    );
    let mut rungs = Vec::new();

    let mut laws: Vec<String> = vec!["paper".into()];
    laws.extend(knobs.pgs_sweeps.iter().map(|s| format!("pgs{s}")));
    laws.extend(["newton".into(), "poisson".into()]);
    for name in &laws {
        let law = parse_law(name).expect("ladder law names are valid");
        let scene = variant(path, vec![name.clone()], "f64", knobs.timing_samples)?;
        let posts: Vec<Post> = evaluate_samples(&scene, law, 0, n)
            .iter()
            .map(post_of)
            .collect();
        let ns = timed_run(&scene);
        progress(&format!("law {name}: {ns:.1} ns/sample"));
        rungs.push(Rung {
            family: "law".into(),
            rung: name.clone(),
            precision: "f64".into(),
            ns_per_sample: ns,
            vs_compliant: errors(&posts, &reference),
            vs_newton: errors(&posts, &newton_posts),
            point_error: None,
            vs_flight_reference: None,
            time_error: None,
        });
    }
    for &steps in &knobs.compliant_steps {
        let (posts, ns) = compliant_posts(&newton64, &inputs, knobs.effective_modulus, steps);
        progress(&format!("compliant {steps} steps: {ns:.0} ns/sample"));
        rungs.push(Rung {
            family: "compliant".into(),
            rung: format!("compliant{steps}"),
            precision: "f64".into(),
            ns_per_sample: ns,
            vs_compliant: errors(&posts, &reference),
            vs_newton: errors(&posts, &newton_posts),
            point_error: None,
            vs_flight_reference: None,
            time_error: None,
        });
    }
    {
        let scene = variant(path, vec!["newton".into()], "f32", knobs.timing_samples)?;
        let posts: Vec<Post> = evaluate_samples(&scene, Law::Newton, 0, n)
            .iter()
            .map(post_of)
            .collect();
        let ns = timed_run(&scene);
        progress(&format!("newton f32: {ns:.1} ns/sample"));
        rungs.push(Rung {
            family: "precision".into(),
            rung: "newton".into(),
            precision: "f32".into(),
            ns_per_sample: ns,
            vs_compliant: errors(&posts, &reference),
            vs_newton: errors(&posts, &newton_posts),
            point_error: None,
            vs_flight_reference: None,
            time_error: None,
        });
    }
    rungs.extend(contact_point_rungs(&newton64, &inputs));

    let law_for_counts = base.laws()[0].name();
    let mut counts = Vec::new();
    for &samples in &knobs.sample_counts {
        let scene = variant(
            path,
            vec![law_for_counts.clone()],
            base.precision().name(),
            samples,
        )?;
        let r = run(&scene, &RunOptions::default()).expect("thread pool");
        let m = &r.acc.laws[0].energy_ratio.moments;
        progress(&format!(
            "N = {samples}: {:.3} s, ci95 {:.2e}",
            r.wall_seconds,
            m.ci95()
        ));
        counts.push(CountRow {
            samples,
            wall_seconds: r.wall_seconds,
            threads: r.threads,
            mean: m.mean(),
            ci95: m.ci95(),
        });
    }
    Ok(Ladder {
        scene: base.name().to_string(),
        law_for_counts,
        knobs,
        rungs,
        counts,
    })
}

/// Time, v⁺, ω⁺ and energy ratio of a first impact.
type FirstImpact = (f64, DVec3, DVec3, f64);

/// The flight rungs of a drop scene: the first impact of `knobs.samples`
/// samples with each RK4 step of flight rotation and each time-of-impact
/// tolerance, against a reference ten times finer than the finest of both
/// (the scene's law). Cost: one-thread ns per sample of the first impact.
pub fn flight_ladder(scene: &Scene, knobs: Knobs, progress: &mut dyn FnMut(&str)) -> Ladder {
    use crate::drop::{first_impact, start_of};
    use crate::lanes::CounterRng;
    let law = scene.laws()[0];
    let sampler = crate::sampler::Sampler::new(scene);
    let boxes = CounterRng::new(scene.seed() ^ 0xd20b_0c5e_5eed_0001, 3);
    let starts: Vec<_> = (0..knobs.samples as u64)
        .map(|i| start_of(scene, &sampler, &boxes, i))
        .collect();
    let fine_step = knobs
        .flight_steps
        .iter()
        .cloned()
        .fold(f64::INFINITY, f64::min)
        / 10.0;
    let fine_tol = knobs
        .toi_tolerances
        .iter()
        .cloned()
        .fold(f64::INFINITY, f64::min)
        / 10.0;
    let run = |step: f64, tol: f64| -> (Vec<Option<FirstImpact>>, f64) {
        let timed = starts.len().min(200);
        let t0 = Instant::now();
        for s in &starts[..timed] {
            std::hint::black_box(first_impact(scene, law, s, step, tol));
        }
        let ns = t0.elapsed().as_secs_f64() * 1e9 / timed as f64;
        (
            starts
                .par_iter()
                .map(|s| first_impact(scene, law, s, step, tol))
                .collect(),
            ns,
        )
    };
    progress(&format!(
        "flight reference: step {fine_step:e} s, TOI tolerance {fine_tol:e} m, {} samples",
        knobs.samples
    ));
    let (reference, _) = run(fine_step, fine_tol);
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
    let default_step = scene.effects().flight_step;
    let mut rungs = Vec::new();
    for &step in &knobs.flight_steps {
        let (got, ns) = run(step, default_tol);
        let (e, t) = compare(&got);
        progress(&format!(
            "flight step {step:e} s: {ns:.0} ns/sample, v⁺ RMS error {:.2e}",
            e.v_rms
        ));
        rungs.push(Rung {
            family: "flight_step".into(),
            rung: format!("step {step:e} s"),
            precision: "f64".into(),
            ns_per_sample: ns,
            vs_compliant: Errors::NONE,
            vs_newton: Errors::NONE,
            point_error: None,
            vs_flight_reference: Some(e),
            time_error: Some(t),
        });
    }
    for &tol in &knobs.toi_tolerances {
        let (got, ns) = run(default_step, tol);
        let (e, t) = compare(&got);
        progress(&format!(
            "TOI tolerance {tol:e} m: {ns:.0} ns/sample, v⁺ RMS error {:.2e}",
            e.v_rms
        ));
        rungs.push(Rung {
            family: "toi_tolerance".into(),
            rung: format!("toi {tol:e} m"),
            precision: "f64".into(),
            ns_per_sample: ns,
            vs_compliant: Errors::NONE,
            vs_newton: Errors::NONE,
            point_error: None,
            vs_flight_reference: Some(e),
            time_error: Some(t),
        });
    }
    Ladder {
        scene: scene.name().to_string(),
        law_for_counts: law.name(),
        knobs,
        rungs,
        counts: Vec::new(),
    }
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
            family: "contact_point".into(),
            rung: "closed_form".into(),
            precision: "f64".into(),
            ns_per_sample: closed,
            vs_compliant: Errors::NONE,
            vs_newton: Errors::NONE,
            point_error: Some((0.0, 0.0)),
            vs_flight_reference: None,
            time_error: None,
        },
        Rung {
            family: "contact_point".into(),
            rung: "lagrange".into(),
            precision: "f64".into(),
            ns_per_sample: lagrange,
            vs_compliant: Errors::NONE,
            vs_newton: Errors::NONE,
            point_error: Some((rms, p99)),
            vs_flight_reference: None,
            time_error: None,
        },
    ]
}

impl Ladder {
    /// `accuracy.parquet`: one row per rung (family `law`, `compliant`,
    /// `precision`, `contact_point`) and per sample count (family
    /// `sample_count`); columns that do not apply are null.
    pub fn frame(&self) -> PolarsResult<DataFrame> {
        let mut family = Vec::new();
        let mut rung = Vec::new();
        let mut precision = Vec::new();
        let mut ns = Vec::new();
        let mut cols: Vec<Vec<Option<f64>>> = vec![Vec::new(); 12];
        let mut point: [Vec<Option<f64>>; 2] = [Vec::new(), Vec::new()];
        let mut samples = Vec::new();
        let mut wall = Vec::new();
        let mut ci = Vec::new();
        let mut mean = Vec::new();
        let fin = |x: f64| x.is_finite().then_some(x);
        for r in &self.rungs {
            family.push(r.family.clone());
            rung.push(r.rung.clone());
            precision.push(r.precision.clone());
            ns.push(Some(r.ns_per_sample));
            let e = [r.vs_compliant, r.vs_newton];
            let vals: Vec<f64> = e
                .iter()
                .flat_map(|e| [e.v_rms, e.v_p99, e.w_rms, e.w_p99, e.ratio_rms, e.ratio_p99])
                .collect();
            for (c, v) in cols.iter_mut().zip(vals) {
                c.push(fin(v));
            }
            point[0].push(r.point_error.map(|p| p.0));
            point[1].push(r.point_error.map(|p| p.1));
            samples.push(Some(self.knobs.samples as u64));
            wall.push(None);
            ci.push(None);
            mean.push(None);
        }
        for c in &self.counts {
            family.push("sample_count".into());
            rung.push(format!("n{}", c.samples));
            precision.push(String::new());
            ns.push(Some(
                c.wall_seconds * 1e9 * c.threads as f64 / c.samples as f64,
            ));
            for col in cols.iter_mut() {
                col.push(None);
            }
            point[0].push(None);
            point[1].push(None);
            samples.push(Some(c.samples));
            wall.push(Some(c.wall_seconds));
            ci.push(Some(c.ci95));
            mean.push(Some(c.mean));
        }
        let names = [
            "v_after_rms_vs_compliant",
            "v_after_p99_vs_compliant",
            "omega_after_rms_vs_compliant",
            "omega_after_p99_vs_compliant",
            "energy_ratio_rms_vs_compliant",
            "energy_ratio_p99_vs_compliant",
            "v_after_rms_vs_newton",
            "v_after_p99_vs_newton",
            "omega_after_rms_vs_newton",
            "omega_after_p99_vs_newton",
            "energy_ratio_rms_vs_newton",
            "energy_ratio_p99_vs_newton",
        ];
        let height = family.len();
        let mut columns = vec![
            Column::new("family".into(), family),
            Column::new("rung".into(), rung),
            Column::new("precision".into(), precision),
            Column::new("ns_per_sample".into(), ns),
            Column::new("samples".into(), samples),
        ];
        for (name, c) in names.iter().zip(cols) {
            columns.push(Column::new((*name).into(), c));
        }
        let [p0, p1] = point;
        columns.push(Column::new("point_error_rms".into(), p0));
        columns.push(Column::new("point_error_p99".into(), p1));
        let fl = |f: &dyn Fn(&Rung) -> Option<f64>| -> Vec<Option<f64>> {
            self.rungs
                .iter()
                .map(f)
                .chain(self.counts.iter().map(|_| None))
                .collect()
        };
        columns.push(Column::new(
            "v_after_rms_vs_flight_reference".into(),
            fl(&|r| r.vs_flight_reference.map(|e| e.v_rms)),
        ));
        columns.push(Column::new(
            "v_after_p99_vs_flight_reference".into(),
            fl(&|r| r.vs_flight_reference.map(|e| e.v_p99)),
        ));
        columns.push(Column::new(
            "omega_after_rms_vs_flight_reference".into(),
            fl(&|r| r.vs_flight_reference.map(|e| e.w_rms)),
        ));
        columns.push(Column::new(
            "energy_ratio_rms_vs_flight_reference".into(),
            fl(&|r| r.vs_flight_reference.map(|e| e.ratio_rms)),
        ));
        columns.push(Column::new(
            "impact_time_rms_error".into(),
            fl(&|r| r.time_error.map(|t| t.0)),
        ));
        columns.push(Column::new(
            "impact_time_p99_error".into(),
            fl(&|r| r.time_error.map(|t| t.1)),
        ));
        columns.push(Column::new("wall_seconds".into(), wall));
        columns.push(Column::new("energy_ratio_mean".into(), mean));
        columns.push(Column::new("energy_ratio_ci95".into(), ci));
        DataFrame::new(height, columns)
    }

    /// The Markdown report.
    pub fn markdown(&self, header: &str) -> String {
        let mut s = String::new();
        s.push_str(&format!(
            "# Accuracy ladder: {}\n\n{header}\n\n",
            self.scene
        ));
        if self.rungs.iter().any(|r| r.vs_flight_reference.is_some()) {
            s.push_str(&format!(
                "Drop scene: the first impact of the same {} samples with each flight setting, against a reference ten times finer than the finest step and tolerance. Errors: RMS and p99 of |Δv⁺| (m/s), RMS of |Δω⁺| (rad/s) and |Δ(T⁺/T⁻)|, and of the impact time (s). Cost: one-thread ns per sample (flight, time of impact and impact).\n\n| rung | ns/sample | v⁺ RMS | v⁺ p99 | ω⁺ RMS | T⁺/T⁻ RMS | impact time RMS | impact time p99 |\n|---|---|---|---|---|---|---|---|\n",
                self.knobs.samples
            ));
            let g = |x: f64| {
                if x.is_finite() {
                    format!("{x:.2e}")
                } else {
                    "–".into()
                }
            };
            for r in &self.rungs {
                if let (Some(e), Some(t)) = (r.vs_flight_reference, r.time_error) {
                    s.push_str(&format!(
                        "| {} | {:.0} | {} | {} | {} | {} | {} | {} |\n",
                        r.rung,
                        r.ns_per_sample,
                        g(e.v_rms),
                        g(e.v_p99),
                        g(e.w_rms),
                        g(e.ratio_rms),
                        g(t.0),
                        g(t.1)
                    ));
                }
            }
            return s;
        }
        s.push_str(&format!(
            "Errors over the same {} samples, against the finest compliant run ({} RK4 steps per contact, E* = {:e} Pa) and against the exact Newton LCP in f64: RMS and p99 of |Δv⁺| (m/s), |Δω⁺| (rad/s) and |Δ(T⁺/T⁻)|. Cost: end-to-end ns per sample on one thread (rigid laws: a timed run of {} samples with sampling and statistics; compliant: the integration alone).\n\n",
            self.knobs.samples, self.knobs.reference_steps, self.knobs.effective_modulus, self.knobs.timing_samples
        ));
        s.push_str("| rung | precision | ns/sample | v⁺ RMS vs compliant | v⁺ p99 | ω⁺ RMS | T⁺/T⁻ RMS | v⁺ RMS vs newton | ω⁺ RMS vs newton | T⁺/T⁻ RMS vs newton |\n|---|---|---|---|---|---|---|---|---|---|\n");
        let g = |x: f64| {
            if x.is_finite() {
                format!("{x:.2e}")
            } else {
                "–".into()
            }
        };
        for r in self.rungs.iter().filter(|r| r.family != "contact_point") {
            let (c, n) = (r.vs_compliant, r.vs_newton);
            s.push_str(&format!(
                "| {} | {} | {:.1} | {} | {} | {} | {} | {} | {} | {} |\n",
                r.rung,
                r.precision,
                r.ns_per_sample,
                g(c.v_rms),
                g(c.v_p99),
                g(c.w_rms),
                g(c.ratio_rms),
                g(n.v_rms),
                g(n.w_rms),
                g(n.ratio_rms)
            ));
        }
        s.push_str("\n**Contact point** (per touching plane; error of the point relative to the closed form, in units of the body's largest semi-axis):\n\n| route | ns/call | error RMS | error p99 |\n|---|---|---|---|\n");
        for r in self.rungs.iter().filter(|r| r.family == "contact_point") {
            let (a, b) = r.point_error.unwrap_or((f64::NAN, f64::NAN));
            s.push_str(&format!(
                "| {} | {:.1} | {} | {} |\n",
                r.rung,
                r.ns_per_sample,
                g(a),
                g(b)
            ));
        }
        s.push_str(&format!(
            "\n**Sample count** ({} law, all cores): the 95 % CI half-width of the mean energy ratio against wall time.\n\n| N | wall (s) | mean | ci95 | ci95·√N |\n|---|---|---|---|---|\n",
            self.law_for_counts
        ));
        for c in &self.counts {
            s.push_str(&format!(
                "| {} | {:.3} | {:.6} | {:.2e} | {:.3} |\n",
                c.samples,
                c.wall_seconds,
                c.mean,
                c.ci95,
                c.ci95 * (c.samples as f64).sqrt()
            ));
        }
        s
    }

    /// The rungs on the Pareto front of (cost, v⁺ error vs compliant):
    /// none is both cheaper and at least as accurate.
    pub fn pareto(&self) -> Vec<&Rung> {
        let mut pts: Vec<&Rung> = self
            .rungs
            .iter()
            .filter(|r| {
                r.vs_compliant.v_rms.is_finite()
                    && r.rung != format!("compliant{}", self.knobs.reference_steps)
            })
            .collect();
        pts.sort_by(|a, b| a.ns_per_sample.total_cmp(&b.ns_per_sample));
        let mut front: Vec<&Rung> = Vec::new();
        for r in pts {
            if front
                .last()
                .is_none_or(|f| r.vs_compliant.v_rms < f.vs_compliant.v_rms)
            {
                front.push(r);
            }
        }
        front
    }
}

/// The log-log plot: error against ns/sample, one labelled point per rung
/// with the Pareto front (left), and the confidence-interval half-width
/// against wall time with its 1/√N line (right). SVG text needs no font
/// files (plotters' SVG backend writes `<text>` elements).
pub fn plot_svg(ladder: &Ladder) -> Result<String, String> {
    let mut svg = String::new();
    draw(ladder, &mut svg)?;
    Ok(svg)
}

fn draw(ladder: &Ladder, svg: &mut String) -> Result<(), String> {
    use plotters::prelude::*;
    let e = |x: &dyn std::fmt::Display| x.to_string();
    let root = SVGBackend::with_string(svg, (1400, 640)).into_drawing_area();
    root.fill(&WHITE).map_err(|x| e(&x))?;
    let (left, right) = root.split_horizontally(860);

    let pts: Vec<&Rung> = ladder
        .rungs
        .iter()
        .filter(|r| r.vs_compliant.v_rms.is_finite() && r.vs_compliant.v_rms > 0.0)
        .collect();
    // Rigid rungs against exact Newton (hollow squares): how far each
    // solver setting is from the LCP it approximates.
    let vs_newton: Vec<&Rung> = ladder
        .rungs
        .iter()
        .filter(|r| {
            r.family != "compliant" && r.vs_newton.v_rms.is_finite() && r.vs_newton.v_rms > 0.0
        })
        .collect();
    let span = |xs: &mut dyn Iterator<Item = f64>| -> (f64, f64) {
        let (lo, hi) = xs.fold((f64::INFINITY, 0.0f64), |(a, b), x| (a.min(x), b.max(x)));
        (lo / 2.0, hi * 2.0)
    };
    // Drop scenes: flight rungs against the finest flight settings.
    let flight: Vec<(&Rung, f64)> = ladder
        .rungs
        .iter()
        .filter_map(|r| {
            let e = r.vs_flight_reference?.v_rms;
            (e.is_finite() && e > 0.0).then_some((r, e))
        })
        .collect();
    let (x0, x1) = span(
        &mut pts
            .iter()
            .chain(vs_newton.iter())
            .map(|r| r.ns_per_sample)
            .chain(flight.iter().map(|(r, _)| r.ns_per_sample)),
    );
    let (y0, y1) = span(
        &mut pts
            .iter()
            .map(|r| r.vs_compliant.v_rms)
            .chain(vs_newton.iter().map(|r| r.vs_newton.v_rms))
            .chain(flight.iter().map(|(_, e)| *e)),
    );
    if !(x0 < x1 && y0 < y1) {
        return Err("nothing to plot: every rung's error is zero or missing".into());
    }
    let mut chart = ChartBuilder::on(&left)
        .caption(
            format!("{}: error vs cost per rung", ladder.scene),
            ("sans-serif", 22),
        )
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(75)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(|x| e(&x))?;
    chart
        .configure_mesh()
        .x_desc("ns per sample, one thread (log)")
        .y_desc("RMS |Δv⁺|, m/s (log): ● vs finest compliant, □ vs exact Newton")
        .x_label_formatter(&|x| format!("{x:.0e}"))
        .y_label_formatter(&|y| format!("{y:.0e}"))
        .draw()
        .map_err(|x| e(&x))?;
    let front: Vec<(f64, f64)> = ladder
        .pareto()
        .iter()
        .map(|r| (r.ns_per_sample, r.vs_compliant.v_rms))
        .collect();
    chart
        .draw_series(LineSeries::new(front, RED.stroke_width(2)))
        .map_err(|x| e(&x))?
        .label("Pareto front")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED.stroke_width(2)));
    // Labels are skipped where one is already close (the table has them all).
    let mut placed: Vec<(f64, f64)> = Vec::new();
    let mut label_for = |r: &Rung, y: f64| -> String {
        let (lx, ly) = (r.ns_per_sample.log10(), y.log10());
        if placed
            .iter()
            .any(|&(px, py)| (px - lx).abs() < 0.25 && (py - ly).abs() < 0.12)
        {
            return String::new();
        }
        placed.push((lx, ly));
        if r.family == "precision" {
            format!("{} {}", r.rung, r.precision)
        } else {
            r.rung.clone()
        }
    };
    for (family, colour) in [("law", BLUE), ("compliant", GREEN), ("precision", MAGENTA)] {
        let sel: Vec<&&Rung> = pts.iter().filter(|r| r.family == family).collect();
        let elems: Vec<_> = sel
            .iter()
            .map(|r| {
                let (x, y) = (r.ns_per_sample, r.vs_compliant.v_rms);
                EmptyElement::at((x, y))
                    + Circle::new((0, 0), 4, colour.filled())
                    + Text::new(label_for(r, y), (6, -12), ("sans-serif", 13))
            })
            .collect();
        chart
            .draw_series(elems)
            .map_err(|x| e(&x))?
            .label(format!("{family} vs compliant"))
            .legend(move |(x, y)| Circle::new((x + 10, y), 4, colour.filled()));
        let sel: Vec<&&Rung> = vs_newton.iter().filter(|r| r.family == family).collect();
        if sel.is_empty() {
            continue;
        }
        let elems: Vec<_> = sel
            .iter()
            .map(|r| {
                let (x, y) = (r.ns_per_sample, r.vs_newton.v_rms);
                EmptyElement::at((x, y))
                    + Rectangle::new([(-4, -4), (4, 4)], colour.stroke_width(1))
                    + Text::new(label_for(r, y), (6, -12), ("sans-serif", 13))
            })
            .collect();
        chart
            .draw_series(elems)
            .map_err(|x| e(&x))?
            .label(format!("{family} vs newton"))
            .legend(move |(x, y)| {
                Rectangle::new([(x + 6, y - 4), (x + 14, y + 4)], colour.stroke_width(1))
            });
    }
    for (family, colour) in [("flight_step", CYAN), ("toi_tolerance", BLACK)] {
        let elems: Vec<_> = flight
            .iter()
            .filter(|(r, _)| r.family == family)
            .map(|(r, y)| {
                EmptyElement::at((r.ns_per_sample, *y))
                    + TriangleMarker::new((0, 0), 5, colour.filled())
                    + Text::new(label_for(r, *y), (6, -12), ("sans-serif", 13))
            })
            .collect();
        if elems.is_empty() {
            continue;
        }
        chart
            .draw_series(elems)
            .map_err(|x| e(&x))?
            .label(format!("{family} vs finest flight"))
            .legend(move |(x, y)| TriangleMarker::new((x + 10, y), 5, colour.filled()));
    }
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()
        .map_err(|x| e(&x))?;

    let cs: Vec<&CountRow> = ladder.counts.iter().filter(|c| c.ci95 > 0.0).collect();
    if !cs.is_empty() {
        let (x0, x1) = span(&mut cs.iter().map(|c| c.wall_seconds.max(1e-6)));
        let (y0, y1) = span(&mut cs.iter().map(|c| c.ci95));
        let mut chart = ChartBuilder::on(&right)
            .caption("CI95 half-width vs wall time", ("sans-serif", 22))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(75)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .x_desc("wall seconds, all cores (log)")
            .y_desc("95 % CI of mean T⁺/T⁻ (log)")
            .x_label_formatter(&|x| format!("{x:.0e}"))
            .y_label_formatter(&|y| format!("{y:.0e}"))
            .draw()
            .map_err(|x| e(&x))?;
        // 1/√N through the largest N, drawn against the measured walls.
        let last = cs[cs.len() - 1];
        let c = last.ci95 * (last.samples as f64).sqrt();
        chart
            .draw_series(LineSeries::new(
                cs.iter()
                    .map(|r| (r.wall_seconds.max(1e-6), c / (r.samples as f64).sqrt())),
                BLACK.stroke_width(1),
            ))
            .map_err(|x| e(&x))?
            .label("σ·1.96/√N")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
        chart
            .draw_series(cs.iter().map(|r| {
                EmptyElement::at((r.wall_seconds.max(1e-6), r.ci95))
                    + Circle::new((0, 0), 4, BLUE.filled())
                    + Text::new(
                        format!("N={:.0e}", r.samples as f64),
                        (6, -12),
                        ("sans-serif", 13),
                    )
            }))
            .map_err(|x| e(&x))?;
        chart
            .configure_series_labels()
            .border_style(BLACK)
            .background_style(WHITE.mix(0.8))
            .draw()
            .map_err(|x| e(&x))?;
    }
    root.present().map_err(|x| e(&x))?;
    Ok(())
}
