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

mod flight;
mod ladder;
mod plot;
mod report;

pub use flight::flight_ladder;
pub use ladder::{contact_point_rungs, ladder, ladder_of};
pub use plot::plot_svg;
pub use report::write_folder;

use std::time::Instant;

use glam::{DMat3, DVec3};
use rayon::prelude::*;

use crate::config::{Overrides, RawScene, Scene, SceneError, SceneText};
use crate::engine::{SampleOutcome, Watch};
use crate::physics::{damping_table, solve_compliant_with, CompliantParams, Pose, State};

/// Why a ladder did not finish.
#[derive(Debug, thiserror::Error)]
pub enum LadderError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error("the accuracy ladder was cancelled")]
    Cancelled,
}

/// How a ladder reports as it goes: a line per step to `line`, and, with a
/// [`Watch`], the steps done of the ladder's total; the watch's cancel
/// stops the ladder before its next step.
pub struct Steps<'a> {
    line: &'a mut dyn FnMut(&str),
    watch: Option<&'a Watch>,
}

impl<'a> Steps<'a> {
    pub fn new(line: &'a mut dyn FnMut(&str), watch: Option<&'a Watch>) -> Self {
        Self { line, watch }
    }

    /// The ladder has `total` steps; stops at once if already cancelled.
    fn begin(&mut self, total: usize) -> Result<(), LadderError> {
        if let Some(w) = self.watch {
            w.set_total(total as u64);
        }
        self.check()
    }

    /// A line that ends no step.
    fn say(&mut self, line: &str) {
        (self.line)(line);
    }

    /// A step done, with its line.
    fn step(&mut self, line: &str) -> Result<(), LadderError> {
        self.say(line);
        if let Some(w) = self.watch {
            w.advance(1);
        }
        self.check()
    }

    fn check(&self) -> Result<(), LadderError> {
        match self.watch {
            Some(w) if w.cancelled() => Err(LadderError::Cancelled),
            _ => Ok(()),
        }
    }
}

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
    /// Regularised Coulomb of the compliant rungs: ε relative to the
    /// velocity scale `|v| + L|ω|` (friction.md's default 1e-6).
    pub friction_regularisation: f64,
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
    /// The compliant model with `steps` RK4 steps per contact duration.
    pub fn compliant(&self, steps: u32) -> CompliantParams {
        CompliantParams {
            effective_modulus: self.effective_modulus,
            steps_per_contact: steps,
            friction_regularisation: self.friction_regularisation,
        }
    }

    pub fn from_raw(file: &str, raw: &RawScene) -> Result<Self, SceneError> {
        let a = raw.accuracy.clone().unwrap_or_default();
        let k = Knobs {
            samples: a.samples.unwrap_or(2000) as usize,
            compliant_steps: a.compliant_steps.unwrap_or(vec![12, 25, 50, 100, 200, 400]),
            reference_steps: a.reference_steps.unwrap_or(1600),
            pgs_sweeps: a.pgs_sweeps.unwrap_or(vec![1, 2, 4, 8, 16, 32, 64]),
            // A drop sample costs hundreds of contact samples.
            sample_counts: a.sample_counts.unwrap_or(if raw.placement.drop.is_some() {
                vec![1_000, 10_000, 100_000]
            } else {
                vec![1_000, 10_000, 100_000, 1_000_000, 10_000_000, 100_000_000]
            }),
            timing_samples: a.timing_samples.unwrap_or(1_000_000),
            flight_steps: a
                .flight_steps
                .clone()
                .unwrap_or(vec![2e-2, 1e-2, 5e-3, 2e-3, 1e-3]),
            toi_tolerances: a
                .toi_tolerances
                .clone()
                .unwrap_or(vec![1e-2, 1e-3, 1e-5, 1e-7, 1e-9]),
            friction_regularisation: a
                .friction_regularisation
                .unwrap_or(CompliantParams::REGULARISATION),
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
        if !(k.friction_regularisation.is_finite() && k.friction_regularisation > 0.0) {
            return Err(field_err(
                file,
                "accuracy.friction_regularisation",
                format!(
                    "must be a finite number > 0 (a fraction of |v| + L|ω|), got {}",
                    k.friction_regularisation
                ),
            ));
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

/// Compliant outcomes of the samples with `params` (in parallel; each
/// sample is independent), the single-thread time per sample (ns) measured
/// on the first samples, and how many samples had not separated when the
/// step budget (200 contact durations) ran out: their outcome is where the
/// integration stopped, which coarse steps can leave in a long rolling or
/// sliding contact that finer steps resolve.
pub fn compliant_posts(
    scene: &Scene,
    inputs: &[(Pose, State)],
    params: CompliantParams,
) -> (Vec<Post>, f64, usize) {
    let planes: Vec<_> = scene.planes().iter().map(|p| p.plane).collect();
    let alpha = damping_table(&planes);
    let one = |(pose, state): &(Pose, State)| -> (Post, bool) {
        match solve_compliant_with(scene.body(), *pose, *state, &planes, params, &alpha) {
            Ok(o) => (
                Post {
                    v: o.after.velocity,
                    w: o.after.omega,
                    ratio: o.energy_after / o.energy_before,
                },
                o.separated,
            ),
            // Nothing approaching: the body leaves untouched.
            Err(_) => (
                Post {
                    v: state.velocity,
                    w: state.omega,
                    ratio: 1.0,
                },
                true,
            ),
        }
    };
    let timed = inputs.len().min(200);
    let t0 = Instant::now();
    for x in &inputs[..timed] {
        std::hint::black_box(one(x));
    }
    let ns = t0.elapsed().as_secs_f64() * 1e9 / timed as f64;
    let runs: Vec<(Post, bool)> = inputs.par_iter().map(one).collect();
    let unseparated = runs.iter().filter(|(_, separated)| !separated).count();
    (runs.into_iter().map(|(p, _)| p).collect(), ns, unseparated)
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
    /// Scenes with friction and one touching plane: errors against
    /// `stronge`, the rigid reference for one frictional contact.
    pub vs_stronge: Option<Errors>,
    /// Compliant rungs only: the fraction of samples whose integration had
    /// not separated when its step budget ran out.
    pub unseparated: Option<f64>,
    /// Contact-point rung only: RMS and p99 of |ΔP| / length scale.
    pub point_error: Option<(f64, f64)>,
    /// Flight rungs only (drop scenes): first-impact errors against the
    /// finest flight settings, and RMS and p99 of the impact-time error (s).
    pub vs_flight_reference: Option<Errors>,
    pub time_error: Option<(f64, f64)>,
}

impl Rung {
    /// A rung of `family` with its cost and no errors yet (each family
    /// fills the ones that apply).
    pub fn new(family: &str, rung: &str, precision: &str, ns_per_sample: f64) -> Self {
        Rung {
            family: family.into(),
            rung: rung.into(),
            precision: precision.into(),
            ns_per_sample,
            vs_compliant: Errors::NONE,
            vs_newton: Errors::NONE,
            vs_stronge: None,
            unseparated: None,
            point_error: None,
            vs_flight_reference: None,
            time_error: None,
        }
    }
}

/// One point of the sample-count rung: a run of the scene's first law
/// with `sampling` (`mc`, or `rqmc` with its default replicates).
#[derive(Debug, Clone, PartialEq)]
pub struct CountRow {
    /// `mc` or `rqmc`.
    pub sampling: String,
    /// The samples run (RQMC: whole replicates, at least those asked for).
    pub samples: u64,
    pub wall_seconds: f64,
    pub threads: usize,
    /// The mean energy ratio (a drop's first impact) and its ci95.
    pub mean: f64,
    pub ci95: f64,
    /// The most frequent active set (a drop: set of planes first hit),
    /// its share of the samples and the share's ci95.
    pub share_name: String,
    pub share: f64,
    pub share_ci95: f64,
}

/// The sample-count rungs: for each count, a run of `law` at the scene's
/// precision on all cores with MC and with RQMC, the 95 % half-widths of
/// the mean energy ratio and of the most frequent active set's share as
/// the summary reports them (RQMC: from its replicates).
pub(crate) fn count_rows(
    src: &SceneText,
    law: &str,
    counts: &[u64],
    steps: &mut Steps,
) -> Result<Vec<CountRow>, LadderError> {
    let mut rows = Vec::new();
    for &samples in counts {
        let mut line = format!("N = {samples}:");
        for sampling in ["mc", "rqmc"] {
            if sampling == "rqmc" && samples < crate::config::Sampling::DEFAULT_REPLICATES {
                continue;
            }
            let scene = src.scene(&Overrides {
                laws: Some(vec![law.to_string()]),
                samples: Some(samples),
                sampling: Some(sampling.into()),
                ..Default::default()
            })?;
            let r = crate::engine::run(&scene, &crate::engine::RunOptions::default())
                .expect("thread pool");
            let summary = crate::output::summary::Summary::new(&scene, &r);
            let all = summary.all_group(law).expect("the law's summary");
            let er = &all.stats["energy_ratio"];
            let (share_name, share) = all
                .active_sets
                .iter()
                .max_by(|a, b| a.1.total_cmp(b.1))
                .map(|(k, v)| (k.clone(), *v))
                .unwrap_or_default();
            // The interval's half-width, to compare with the mean's.
            let share_ci95 = all
                .active_sets_ci95
                .get(&share_name)
                .map_or(f64::NAN, |ci| ci.half_width());
            line += &format!(
                " {sampling} {} samples {:.3} s, ci95 {:.2e} (share {share_ci95:.2e});",
                r.acc.laws[0].samples, r.wall_seconds, er.ci95
            );
            rows.push(CountRow {
                sampling: sampling.into(),
                samples: r.acc.laws[0].samples,
                wall_seconds: r.wall_seconds,
                threads: r.threads,
                mean: er.mean,
                ci95: er.ci95,
                share_name: if share_name.is_empty() {
                    "(none)".into()
                } else {
                    share_name
                },
                share,
                share_ci95,
            });
        }
        steps.step(line.trim_end_matches(';'))?;
    }
    Ok(rows)
}

pub struct Ladder {
    pub scene: String,
    /// A touching plane has μ > 0: the compliant rungs carry regularised
    /// Coulomb.
    pub friction: bool,
    /// Samples whose reference (finest compliant) run had not separated
    /// when its step budget ran out.
    pub reference_unseparated: usize,
    pub law_for_counts: String,
    pub knobs: Knobs,
    pub rungs: Vec<Rung>,
    pub counts: Vec<CountRow>,
}
