//! Drop studies: each sample is released from the scene's drop
//! box with its drawn orientation and velocities, flies under gravity with
//! torque-free rotation, hits the planes (time of impact by conservative
//! advancement), and bounces up to `effects.bounces` times or until its
//! kinetic energy after an impact falls below `effects.energy_floor` of the
//! kinetic energy it brought to its first impact.
//!
//! This path is scalar f64 per sample (the f64 reference physics), in
//! parallel over batches with the same counter-based draws as the engine,
//! merged in batch order: bit-identical for any thread count.

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;
use serde_json::{json, Map, Value};

use crate::config::Scene;
use crate::lanes::Real;
use crate::output::summary::{active_set_name, StatSummary};
use crate::physics::{
    solve_impact, time_of_impact, Ellipsoid, Impact, ImpactOutcome, Law, Motion, Plane, Pose,
    Rotation, State,
};
use crate::sampler::rng::CounterRng;
use crate::sampler::Sampler;
use crate::stats::Moments;

/// Tolerances at which the share of simultaneous impacts is reported (m).
pub const SIMULTANEITY_TOLERANCES: [f64; 12] = [
    1e-12, 1e-11, 1e-10, 1e-9, 1e-8, 1e-7, 1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 1e-1,
];

/// Statistics of the k-th impact of every sample that reached it.
#[derive(Debug, Clone, Default)]
pub struct BounceAcc {
    pub reached: u64,
    /// By set of planes that took an impulse (bit i: plane i).
    pub sets: Vec<u64>,
    pub energy_ratio: Moments,
    /// Time since release (first impact) or since the previous impact (s).
    pub interval: Moments,
    /// Speed of the centre just before the impact (m/s).
    pub speed_before: Moments,
    /// Impacts whose second-closest plane was within each tolerance of
    /// [`SIMULTANEITY_TOLERANCES`].
    pub within: [u64; 12],
    pub energy_gain: u64,
    pub degenerate: u64,
}

/// One law's drop statistics.
#[derive(Debug, Clone)]
pub struct DropAcc {
    pub samples: u64,
    pub bounces: Vec<BounceAcc>,
    /// Samples by number of impacts (index 0..=bounces).
    pub impacts: Vec<u64>,
    /// Samples with no further impact within the horizon.
    pub flew_away: u64,
    /// Samples stopped by the energy floor.
    pub came_to_rest: u64,
    /// Samples whose impact could not be solved (counted, then stopped).
    pub unsolved: u64,
    /// Body axis (a, b, c) closest to vertical when the bounces stop.
    pub final_axis_up: [u64; 3],
}

impl DropAcc {
    fn new(planes: usize, bounces: usize) -> Self {
        Self {
            samples: 0,
            bounces: (0..bounces)
                .map(|_| BounceAcc {
                    sets: vec![0; 1 << planes],
                    ..Default::default()
                })
                .collect(),
            impacts: vec![0; bounces + 1],
            flew_away: 0,
            came_to_rest: 0,
            unsolved: 0,
            final_axis_up: [0; 3],
        }
    }

    fn flush(&mut self) {
        for b in &mut self.bounces {
            b.energy_ratio.flush();
            b.interval.flush();
            b.speed_before.flush();
        }
    }

    fn merge(&mut self, o: &DropAcc) {
        self.samples += o.samples;
        self.flew_away += o.flew_away;
        self.came_to_rest += o.came_to_rest;
        self.unsolved += o.unsolved;
        for (a, b) in self.impacts.iter_mut().zip(&o.impacts) {
            *a += b;
        }
        for (a, b) in self.final_axis_up.iter_mut().zip(&o.final_axis_up) {
            *a += b;
        }
        for (a, b) in self.bounces.iter_mut().zip(&o.bounces) {
            a.reached += b.reached;
            a.energy_gain += b.energy_gain;
            a.degenerate += b.degenerate;
            for (x, y) in a.sets.iter_mut().zip(&b.sets) {
                *x += y;
            }
            for (x, y) in a.within.iter_mut().zip(&b.within) {
                *x += y;
            }
            a.energy_ratio.merge(&b.energy_ratio);
            a.interval.merge(&b.interval);
            a.speed_before.merge(&b.speed_before);
        }
    }
}

/// What one drop study produced.
pub struct DropRun {
    pub laws: Vec<(Law, DropAcc)>,
    pub wall_seconds: f64,
    pub threads: usize,
}

/// The start of sample `i`: drawn orientation and velocities, centre
/// uniform in the drop box (its own stream, so the engine's draws are
/// unchanged).
pub fn start_of(scene: &Scene, sampler: &Sampler, boxes: &CounterRng, i: u64) -> Motion {
    let (a, v, w) = sampler.reference(i);
    let (lo, hi) = scene.drop_box().expect("a drop scene");
    let u = DVec3::new(
        f64::uniform(boxes.bits(i, 0)),
        f64::uniform(boxes.bits(i, 1)),
        f64::uniform(boxes.bits(i, 2)),
    );
    Motion {
        centre: lo + (hi - lo) * u,
        rotation: a,
        velocity: v,
        omega: w,
    }
}

/// What every flight of a run shares, built once per run (not per sample).
pub struct Flight {
    planes: Vec<Plane>,
    gravity: DVec3,
    rotation: Rotation,
    toi_tolerance: f64,
    horizon: f64,
    /// Planes within this distance at the impact take part.
    contact_tolerance: f64,
}

/// Why a flight ended without a solved impact.
enum Stop {
    FlewAway,
    Unsolved,
}

impl Flight {
    /// The scene's flight with the given RK4 step and time-of-impact
    /// tolerance (a tolerance above the scene's contact tolerance widens it).
    pub fn new(scene: &Scene, flight_step: f64, toi_tolerance: f64) -> Self {
        let fx = scene.effects();
        Self {
            planes: scene.planes().iter().map(|p| p.plane).collect(),
            gravity: DVec3::new(0.0, 0.0, -fx.gravity),
            rotation: Rotation::for_body(scene.body(), flight_step),
            toi_tolerance,
            horizon: fx.horizon,
            contact_tolerance: scene.tolerance().max(toi_tolerance),
        }
    }

    /// Flies from `m` to the next impact and solves it under `law`.
    fn next(
        &self,
        body: &Ellipsoid,
        m: &Motion,
        law: Law,
    ) -> Result<(Impact, ImpactOutcome), Stop> {
        let hit = time_of_impact(
            body,
            m,
            &self.planes,
            self.gravity,
            self.rotation,
            self.toi_tolerance,
            self.horizon,
        )
        .ok_or(Stop::FlewAway)?;
        let pose = Pose {
            rotation: hit.motion.rotation,
            centre: hit.motion.centre,
        };
        let state = State {
            velocity: hit.motion.velocity,
            omega: hit.motion.omega,
        };
        let o = solve_impact(body, pose, state, &self.planes, law, self.contact_tolerance)
            .map_err(|_| Stop::Unsolved)?;
        Ok((hit, o))
    }
}

fn simulate(scene: &Scene, flight: &Flight, law: Law, start: Motion, acc: &mut DropAcc) {
    let fx = scene.effects();
    let body = scene.body();
    // The energy floor is relative to the kinetic energy of the first impact.
    let mut t0 = f64::INFINITY;
    let mut m = start;
    let mut impacts = 0usize;
    let mut since = 0.0;
    acc.samples += 1;
    // A few non-impacts (a touch without approach) are tolerated per bounce.
    let mut attempts = 0;
    while impacts < fx.bounces as usize && attempts < 4 * fx.bounces as usize + 4 {
        attempts += 1;
        let (hit, o) = match flight.next(body, &m, law) {
            Ok(x) => x,
            Err(Stop::FlewAway) => {
                acc.flew_away += 1;
                break;
            }
            Err(Stop::Unsolved) => {
                acc.unsolved += 1;
                break;
            }
        };
        since += hit.time;
        m = hit.motion;
        let mask = o
            .contacts
            .iter()
            .enumerate()
            .filter(|(_, c)| c.impulse > 0.0)
            .fold(0usize, |s, (i, _)| s | 1 << i);
        if mask == 0 {
            // Touched without approaching: fly on.
            continue;
        }
        if impacts == 0 {
            t0 = o.energy_before;
        }
        let b = &mut acc.bounces[impacts];
        b.reached += 1;
        b.sets[mask] += 1;
        b.energy_ratio.push(o.energy_after / o.energy_before);
        b.interval.push(since);
        b.speed_before.push(m.velocity.length());
        b.energy_gain += o.flags.energy_gain as u64;
        b.degenerate += o.flags.degenerate as u64;
        let mut d = hit.distances;
        d.sort_by(f64::total_cmp);
        if let Some(&second) = d.get(1) {
            for (k, &tol) in SIMULTANEITY_TOLERANCES.iter().enumerate() {
                b.within[k] += (second <= tol) as u64;
            }
        }
        impacts += 1;
        since = 0.0;
        m.velocity = o.after.velocity;
        m.omega = o.after.omega;
        if o.energy_after < fx.energy_floor * t0 {
            acc.came_to_rest += 1;
            break;
        }
    }
    acc.impacts[impacts] += 1;
    // Which body axis is closest to vertical (world Z) at the end.
    let z = m.rotation.row(2).abs();
    let axis = if z.x >= z.y && z.x >= z.z {
        0
    } else if z.y >= z.z {
        1
    } else {
        2
    };
    acc.final_axis_up[axis] += 1;
}

/// Runs a drop scene with `threads` workers (0: all cores).
pub fn run_drop(scene: &Scene, threads: usize) -> Result<DropRun, rayon::ThreadPoolBuildError> {
    let threads = if threads == 0 {
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1)
    } else {
        threads
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let sampler = Sampler::new(scene);
    let boxes = crate::sampler::rng::drop_start_rng(scene.seed());
    let n_planes = scene.planes().len();
    let bounces = scene.effects().bounces as usize;
    let batch = scene.batch_size().min(4096);
    let batches = scene.samples().div_ceil(batch);
    let fx = scene.effects();
    let flight = Flight::new(scene, fx.flight_step, fx.toi_tolerance);
    let t0 = Instant::now();
    let laws = pool.install(|| {
        scene
            .laws()
            .iter()
            .map(|&law| {
                let mut total = DropAcc::new(n_planes, bounces);
                let mut start = 0;
                while start < batches {
                    let end = (start + 256).min(batches);
                    let parts: Vec<DropAcc> = (start..end)
                        .into_par_iter()
                        .map(|b| {
                            let mut acc = DropAcc::new(n_planes, bounces);
                            let lo = b * batch;
                            let hi = (lo + batch).min(scene.samples());
                            for i in lo..hi {
                                simulate(
                                    scene,
                                    &flight,
                                    law,
                                    start_of(scene, &sampler, &boxes, i),
                                    &mut acc,
                                );
                            }
                            acc.flush();
                            acc
                        })
                        .collect();
                    for p in &parts {
                        total.merge(p);
                    }
                    start = end;
                }
                (law, total)
            })
            .collect()
    });
    Ok(DropRun {
        laws,
        wall_seconds: t0.elapsed().as_secs_f64(),
        threads,
    })
}

fn stat(m: &Moments) -> Value {
    serde_json::to_value(StatSummary::from_moments(m)).expect("summary values serialise")
}

impl DropRun {
    /// The JSON printed by `--format json` and saved as summary.json.
    pub fn summary_json(&self, scene: &Scene) -> Value {
        let names: Vec<String> = scene.planes().iter().map(|p| p.name.clone()).collect();
        let mut laws = Map::new();
        for (law, a) in &self.laws {
            let n = a.samples.max(1) as f64;
            let bounces: Vec<Value> = a
                .bounces
                .iter()
                .enumerate()
                .map(|(k, b)| {
                    let mut sets = Map::new();
                    for (mask, &c) in b.sets.iter().enumerate() {
                        if c > 0 {
                            sets.insert(
                                active_set_name(mask, &names),
                                json!(c as f64 / b.reached.max(1) as f64),
                            );
                        }
                    }
                    let mut within = Map::new();
                    for (tol, &c) in SIMULTANEITY_TOLERANCES.iter().zip(&b.within) {
                        within.insert(
                            format!("{tol:e}"),
                            json!(c as f64 / b.reached.max(1) as f64),
                        );
                    }
                    json!({
                        "bounce": k + 1,
                        "reached": b.reached,
                        "fraction_of_samples": b.reached as f64 / n,
                        "planes_hit": sets,
                        "energy_ratio": stat(&b.energy_ratio),
                        "interval_seconds": stat(&b.interval),
                        "speed_before": stat(&b.speed_before),
                        "simultaneous_within_tolerance": within,
                        "energy_gain": b.energy_gain,
                        "degenerate": b.degenerate,
                    })
                })
                .collect();
            let axes = ["a", "b", "c"];
            let mut up = Map::new();
            for (name, &c) in axes.iter().zip(&a.final_axis_up) {
                up.insert((*name).into(), json!(c as f64 / n));
            }
            laws.insert(
                law.name(),
                json!({
                    "samples": a.samples,
                    "impacts_per_sample": a.impacts.iter().enumerate().map(|(k, &c)| (k.to_string(), json!(c as f64 / n))).collect::<Map<_, _>>(),
                    "flew_away": a.flew_away as f64 / n,
                    "came_to_rest": a.came_to_rest as f64 / n,
                    "unsolved": a.unsolved as f64 / n,
                    "final_axis_up": up,
                    "bounces": bounces,
                }),
            );
        }
        let samples = scene.samples();
        json!({
            "scene": scene.name(),
            "samples": samples,
            "seed": scene.seed(),
            "threads": self.threads,
            "throughput": {"samples_per_second": samples as f64 * self.laws.len() as f64 / self.wall_seconds, "wall_seconds": self.wall_seconds},
            "effects": scene.effects(),
            "planes": names,
            "laws": laws,
        })
    }

    /// The terminal summary.
    pub fn text(&self, scene: &Scene) -> String {
        let names: Vec<String> = scene.planes().iter().map(|p| p.name.clone()).collect();
        let mut s = format!(
            "scene {}: {} samples, seed {}, drop with flight, {} thread(s), {:.3} s wall\n",
            scene.name(),
            scene.samples(),
            scene.seed(),
            self.threads,
            self.wall_seconds
        );
        for (law, a) in &self.laws {
            let n = a.samples.max(1) as f64;
            s.push_str(&format!(
                "\n[{}] flew away {:.4}, came to rest {:.4}, unsolved {:.2e}; axis closest to vertical at the end: a {:.4}, b {:.4}, c {:.4}\n",
                law.name(),
                a.flew_away as f64 / n,
                a.came_to_rest as f64 / n,
                a.unsolved as f64 / n,
                a.final_axis_up[0] as f64 / n,
                a.final_axis_up[1] as f64 / n,
                a.final_axis_up[2] as f64 / n,
            ));
            s.push_str("  bounce  reached    T+/T- mean ± ci95      interval (s) mean   simultaneous@contact_tol  most frequent planes\n");
            let tol_k = SIMULTANEITY_TOLERANCES
                .iter()
                .position(|&t| t >= scene.tolerance())
                .unwrap_or(SIMULTANEITY_TOLERANCES.len() - 1);
            for (k, b) in a.bounces.iter().enumerate() {
                if b.reached == 0 {
                    continue;
                }
                let (best, c) = b
                    .sets
                    .iter()
                    .enumerate()
                    .max_by_key(|(_, &c)| c)
                    .map(|(m, &c)| (active_set_name(m, &names), c))
                    .unwrap_or_default();
                s.push_str(&format!(
                    "  {:>6}  {:>8}  {:.5} ± {:.1e}   {:>10.4}          {:.2e}                  {} ({:.3})\n",
                    k + 1,
                    b.reached,
                    b.energy_ratio.mean(),
                    b.energy_ratio.ci95(),
                    b.interval.mean(),
                    b.within[tol_k] as f64 / b.reached as f64,
                    best,
                    c as f64 / b.reached as f64
                ));
            }
        }
        s
    }
}

/// The tables of a drop study: `bounces.parquet` (one row per law and
/// bounce), `planes_hit.parquet` (law, bounce, planes, count, fraction) and
/// `simultaneity.parquet` (law, bounce, tolerance, fraction of impacts whose
/// second-closest plane was within it).
pub fn frames(
    run: &DropRun,
    scene: &Scene,
) -> polars::prelude::PolarsResult<[(&'static str, polars::prelude::DataFrame); 3]> {
    use polars::prelude::*;
    let names: Vec<String> = scene.planes().iter().map(|p| p.name.clone()).collect();
    let (mut law, mut bounce, mut reached, mut frac) = (vec![], vec![], vec![], vec![]);
    let mut cols: Vec<Vec<Option<f64>>> = vec![Vec::new(); 6];
    let (mut p_law, mut p_bounce, mut p_set, mut p_count, mut p_frac) =
        (vec![], vec![], vec![], vec![], vec![]);
    let (mut s_law, mut s_bounce, mut s_tol, mut s_frac) = (vec![], vec![], vec![], vec![]);
    for (l, a) in &run.laws {
        for (k, b) in a.bounces.iter().enumerate() {
            law.push(l.name());
            bounce.push(k as u32 + 1);
            reached.push(b.reached);
            frac.push(b.reached as f64 / a.samples.max(1) as f64);
            let some = |x: f64| (b.reached > 0 && x.is_finite()).then_some(x);
            for (c, x) in cols.iter_mut().zip([
                b.energy_ratio.mean(),
                b.energy_ratio.ci95(),
                b.energy_ratio.sd(),
                b.interval.mean(),
                b.interval.ci95(),
                b.speed_before.mean(),
            ]) {
                c.push(some(x));
            }
            for (mask, &c) in b.sets.iter().enumerate() {
                if c > 0 {
                    p_law.push(l.name());
                    p_bounce.push(k as u32 + 1);
                    p_set.push(active_set_name(mask, &names));
                    p_count.push(c);
                    p_frac.push(c as f64 / b.reached as f64);
                }
            }
            for (&tol, &c) in SIMULTANEITY_TOLERANCES.iter().zip(&b.within) {
                s_law.push(l.name());
                s_bounce.push(k as u32 + 1);
                s_tol.push(tol);
                s_frac.push((b.reached > 0).then(|| c as f64 / b.reached as f64));
            }
        }
    }
    let n = law.len();
    let mut columns = vec![
        Column::new("law".into(), law),
        Column::new("bounce".into(), bounce),
        Column::new("reached".into(), reached),
        Column::new("fraction_of_samples".into(), frac),
    ];
    for (name, c) in [
        "energy_ratio_mean",
        "energy_ratio_ci95",
        "energy_ratio_sd",
        "interval_seconds_mean",
        "interval_seconds_ci95",
        "speed_before_mean",
    ]
    .into_iter()
    .zip(cols)
    {
        columns.push(Column::new(name.into(), c));
    }
    let bounces = DataFrame::new(n, columns)?;
    let n = p_law.len();
    let planes = DataFrame::new(
        n,
        vec![
            Column::new("law".into(), p_law),
            Column::new("bounce".into(), p_bounce),
            Column::new("planes".into(), p_set),
            Column::new("count".into(), p_count),
            Column::new("fraction".into(), p_frac),
        ],
    )?;
    let n = s_law.len();
    let sim = DataFrame::new(
        n,
        vec![
            Column::new("law".into(), s_law),
            Column::new("bounce".into(), s_bounce),
            Column::new("tolerance".into(), s_tol),
            Column::new("fraction".into(), s_frac),
        ],
    )?;
    Ok([
        ("bounces.parquet", bounces),
        ("planes_hit.parquet", planes),
        ("simultaneity.parquet", sim),
    ])
}

/// Writes a drop study's folder: the three tables, summary.json and
/// manifest.json (last), staged and renamed together.
pub fn write_outputs(
    run: &DropRun,
    scene: &Scene,
    dir: &std::path::Path,
    started: std::time::SystemTime,
) -> Result<Vec<std::path::PathBuf>, crate::output::OutputError> {
    use crate::output::manifest::{Manifest, Timing};
    use crate::output::{schema_metadata, write_parquet, OutputError, Staging};
    let mut staging = Staging::new(dir);
    let path = |n: &str| dir.join(n).display().to_string();
    let frames = frames(run, scene).map_err(|source| OutputError::Parquet {
        path: path("bounces.parquet"),
        source,
    })?;
    let mut files = Vec::new();
    for (name, mut df) in frames {
        write_parquet(&mut staging, name, &mut df, schema_metadata())?;
        files.push(name.to_string());
    }
    staging.write_json("summary.json", &run.summary_json(scene))?;
    files.push("summary.json".into());
    let timing = Timing {
        started,
        finished: std::time::SystemTime::now(),
        wall_seconds: run.wall_seconds,
        cpu_seconds: None,
        threads: run.threads,
    };
    let mut manifest = Manifest::new(scene.raw(), scene.effects(), 1, timing);
    manifest.files = files;
    staging.write_json("manifest.json", &manifest)?;
    staging.commit()
}

/// A sample's first impact with the given flight knobs (for the accuracy
/// ladder): the time from release and the post-impact velocities and energy
/// ratio. Planes within the larger of the contact and time-of-impact
/// tolerances take part. `None` if nothing is hit within the horizon, the
/// impact cannot be solved, or no plane takes an impulse.
pub fn first_impact(
    scene: &Scene,
    law: Law,
    start: &Motion,
    flight_step: f64,
    toi_tolerance: f64,
) -> Option<(f64, DVec3, DVec3, f64)> {
    let (hit, o) = Flight::new(scene, flight_step, toi_tolerance)
        .next(scene.body(), start, law)
        .ok()?;
    if o.contacts.iter().all(|c| c.impulse <= 0.0) {
        return None;
    }
    Some((
        hit.time,
        o.after.velocity,
        o.after.omega,
        o.energy_after / o.energy_before,
    ))
}
