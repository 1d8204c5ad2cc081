//! A study: every grid point of a scene file run in turn, summarised, and
//! written as one run folder (summary, histograms, manifest; staged and
//! renamed together at the end).
//!
//! Contact scenes and drop scenes alike ([`prepare`], then [`run`]); the
//! command line prints what it returns.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

use polars::prelude::{DataFrame, PolarsError};
use serde_json::json;

use crate::config::sweep::{plan_text, Axis, Plan};
use crate::config::RawScene;
use crate::config::{Overrides, Precision, Scene, SceneError, SceneText, Target};
use crate::engine::{run_with_samples, samples_run, RunError, RunOptions, SinkError, Watch};
use crate::output::arrow::{ArrowTable, MemoryRows};
use crate::output::manifest::{Manifest, MergeInfo, PerSample, ShardRef, Timing};
use crate::output::paired::Spread;
use crate::output::parquet::{Compression, SamplesWriter, WriteOptions};
use crate::output::plots::run_plots;
use crate::output::samples::{SampleRows, Selection};
use crate::output::shard::{
    check, cluster_frame, info_of, merge_clusters, merge_point, read_clusters, read_nodes,
    state_frames, BatchClusters, MergeError,
};
use crate::output::summary::Summary;
use crate::output::{
    drop_frames, histograms_frame, summary_frame, write_parquet, DropAccs, OutputError,
    PointValues, Staging,
};
use crate::stats::accumulators::Shape;
use crate::stats::tree::Shard;
use crate::stats::RunResult;

/// One grid point's run.
pub struct PointRun {
    /// The swept fields' values at this point (empty without a sweep).
    pub values: Vec<(String, f64)>,
    /// The point's scene.
    pub scene: Scene,
    /// The merged accumulators.
    pub result: RunResult,
    /// What they say: the summary the CLI prints and writes.
    pub summary: Summary,
}

impl PointRun {
    fn new(values: Vec<(String, f64)>, scene: Scene, result: RunResult) -> Self {
        let summary = Summary::new(&scene, &result);
        Self {
            values,
            scene,
            result,
            summary,
        }
    }
}

/// A sweep's paired differences: every point but the reference against
/// it ([`Summary::paired_with`]), by replicate under RQMC and by cluster
/// of samples under MC (a shard's over its own batches). Nothing without
/// a sweep, or where the points lack what pairs them (a partial merge).
fn pair_points(runs: &mut [PointRun], reference: usize) {
    if runs.len() < 2 || reference >= runs.len() {
        return;
    }
    let reps: Vec<Vec<Summary>> = runs
        .iter()
        .map(|p| Summary::replicate_summaries(&p.scene, &p.result))
        .collect();
    let base = runs[reference].summary.clone();
    let base_clusters = runs[reference].result.clusters.clone();
    for (i, p) in runs.iter_mut().enumerate() {
        if i == reference {
            continue;
        }
        let spread = if !reps[i].is_empty() && !reps[reference].is_empty() {
            Spread::Replicates {
                mine: &reps[i],
                reference: &reps[reference],
            }
        } else if let (Some(mine), Some(theirs)) = (&p.result.clusters, &base_clusters) {
            Spread::Clusters {
                mine,
                reference: theirs,
            }
        } else {
            continue;
        };
        p.summary.paired_points = Some(p.summary.paired_with(&base, reference, &spread));
    }
}

/// A finished run: the scene as given, every grid point's results, and
/// the per-sample rows when asked for ([`Study::write`] writes the run
/// folder).
#[must_use = "a run's results: write them (Study::write) or read them"]
pub struct Study {
    /// The scene as given (overrides applied, sweep included).
    pub raw: RawScene,
    /// The sweep's axes (empty without a sweep).
    pub axes: Vec<Axis>,
    /// Every grid point's run, in grid order.
    pub points: Vec<PointRun>,
    /// When the run started.
    pub started: SystemTime,
    /// When the last point finished.
    pub finished: SystemTime,
    /// What samples.parquet holds, when asked for.
    pub per_sample: Option<PerSample>,
    /// Set for a shard run: the folder then also holds the shard state.
    pub shard: Option<Shard>,
    /// Set for a merge of shards.
    pub merge: Option<MergeInfo>,
    /// The per-sample rows of a run without an output folder, when asked
    /// for.
    pub samples: Option<ArrowTable>,
    /// The run folder, and its staging area until it is written; none for
    /// a run kept in memory.
    folder: Option<PathBuf>,
    staging: Option<Staging>,
}

/// Where a study's per-sample rows go.
enum Rows {
    File(SamplesWriter, Precision),
    Memory(MemoryRows),
}

impl Rows {
    fn float_mask(&self) -> Vec<bool> {
        match self {
            Rows::File(w, _) => w.float_mask().to_vec(),
            Rows::Memory(m) => m.float_mask().to_vec(),
        }
    }
}

/// An error's message with its chain of causes (`a: b: c`), each once: the
/// words every front end prints.
pub fn message_chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut source = e.source();
    while let Some(c) = source {
        let m = c.to_string();
        if !s.contains(&m) {
            s.push_str(": ");
            s.push_str(&m);
        }
        source = c.source();
    }
    s
}

/// Why a run or a merge failed.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// A bad scene, override or grid point.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// The engine failed (or was cancelled).
    #[error(transparent)]
    Run(#[from] RunError),
    /// The run folder could not be written.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// Shards that do not make one run.
    #[error(transparent)]
    Merge(#[from] MergeError),
}

impl StudyError {
    /// Bad input (the scene, the shards to merge, an output folder that
    /// holds a run), as opposed to a failure while running or writing.
    pub fn is_bad_input(&self) -> bool {
        matches!(
            self,
            StudyError::Scene(_)
                | StudyError::Merge(_)
                | StudyError::Output(OutputError::Exists(_))
        )
    }
}

/// Validates every grid point and the per-sample columns first (so bad
/// input fails before any work), then runs the points in order, streaming
/// per-sample rows into the staging area of `dir` when the scene asks for
/// them. Without `dir` nothing is written: the rows stay in memory
/// ([`Study::samples`]) and [`Study::write`] refuses.
///
/// A scene with a target precision ([`Target`]) runs in rounds
/// ([`run_to_target`]).
pub fn run(
    src: &SceneText,
    overrides: &Overrides,
    opts: &RunOptions,
    dir: Option<&Path>,
) -> Result<Study, StudyError> {
    let points = plan_text(src, overrides)?.points;
    match points[0].scene.target() {
        Some(t) => run_to_target(src, overrides, opts, dir, &points[0].scene, &t.clone()),
        None => run_once(src, overrides, opts, dir),
    }
}

/// A target's error: the field is `target` (or the flag that set it).
fn target_error(
    src: &SceneText,
    overrides: &Overrides,
    field: &str,
    message: String,
) -> StudyError {
    let e = SceneError {
        file: src.file.clone(),
        line: crate::config::line_of(&src.text, &["target"]),
        field: field.into(),
        message,
    };
    overrides.blame(e).into()
}

/// Runs the study at growing sample counts until every target statistic's
/// 95 % half-width is at most its bound under every law and at every grid
/// point, or a round has run `max_samples`. Each round is a whole run from
/// the first sample: counter-based draws make the samples of a count a
/// prefix of the same stream, so the result is the fixed-count run of the
/// last round's count, bit for bit. The next count is predicted from
/// ci95·√N (the largest ratio², 5 % over, rounded up to whole batches, at
/// least 1.25× and at most `max_samples`); under RQMC, whose error falls
/// faster than N^-1/2, the points per replicate grow by the power of two
/// at or above the half-widths' ratio (at least 2×).
pub fn run_to_target(
    src: &SceneText,
    overrides: &Overrides,
    opts: &RunOptions,
    dir: Option<&Path>,
    scene: &Scene,
    target: &Target,
) -> Result<Study, StudyError> {
    use crate::output::summary::{TargetStatistic, TargetSummary};
    if opts.shard.is_some() {
        return Err(target_error(
            src,
            overrides,
            "target",
            "a run with a target precision cannot be sharded (its sample count is known only at its end): run it whole, or shard a run with --samples".into(),
        ));
    }
    // Every name must be a statistic or a fraction the summary has.
    let empty = RunResult {
        acc: crate::stats::accumulators::RunAcc::shaped(Shape::of(scene)),
        replicates: Vec::new(),
        clusters: None,
        nodes: Vec::new(),
        batches: 0,
        batches_run: 0,
        wall_seconds: 0.0,
        cpu_seconds: None,
        threads: 1,
    };
    let names = Summary::new(scene, &empty);
    let law = scene.laws()[0].name();
    let all = names.all_group(&law).expect("the first law's summary");
    for (name, _) in &target.ci95 {
        if all.half_width(name).is_none() {
            let mut known: Vec<&str> = all.stats.keys().map(String::as_str).collect();
            known.extend(all.fractions.keys().map(String::as_str));
            return Err(target_error(
                src,
                overrides,
                &format!("target.ci95.{name}"),
                format!(
                    "{name:?} is not a statistic or fraction of this scene's summary; it has {}",
                    known.join(", ")
                ),
            ));
        }
    }
    let mut n = scene.samples();
    let mut rounds = Vec::new();
    loop {
        let o = Overrides {
            samples: Some(n),
            ..overrides.clone()
        };
        let mut study = run_once(src, &o, opts, dir)?;
        let ran = study.points[0].scene.samples();
        rounds.push(ran);
        let statistics: Vec<TargetStatistic> = target
            .ci95
            .iter()
            .map(|(name, eps)| {
                // The widest over grid points and laws; an undefined one
                // (no sample yet has the statistic) counts as not reached.
                let achieved = study
                    .points
                    .iter()
                    .flat_map(|p| p.summary.laws.iter())
                    .map(|(_, l)| {
                        l.groups
                            .get("all")
                            .and_then(|g| g.half_width(name))
                            .filter(|h| !h.is_nan())
                            .unwrap_or(f64::INFINITY)
                    })
                    .fold(0.0, f64::max);
                TargetStatistic {
                    statistic: name.clone(),
                    ci95: *eps,
                    achieved,
                    reached: achieved <= *eps,
                }
            })
            .collect();
        let reached = statistics.iter().all(|t| t.reached);
        let rqmc = scene.sampling().replicates().is_some();
        let next = if rqmc {
            // Whole powers of two per replicate; the error falls at least
            // as N^-1/2 and at best as N^-1, so the count grows by at least
            // the half-widths' ratio (its square is the MC prediction).
            let ratio = statistics
                .iter()
                .map(|t| t.achieved / t.ci95)
                .fold(2.0f64, f64::max);
            let grow = if ratio.is_finite() && ratio < 1e6 {
                (ratio.ceil() as u64).next_power_of_two()
            } else {
                4
            };
            ran.saturating_mul(grow)
        } else {
            let factor = statistics
                .iter()
                .map(|t| (t.achieved / t.ci95).powi(2))
                .fold(1.25f64, f64::max);
            let batch = scene.batch_size();
            let want = if factor.is_finite() {
                (ran as f64 * factor * 1.05).ceil().min(u64::MAX as f64) as u64
            } else {
                ran.saturating_mul(4)
            };
            want.div_ceil(batch)
                .saturating_mul(batch)
                .min(target.max_samples)
        };
        // RQMC runs whole powers of two per replicate: none past the budget.
        if reached || ran >= target.max_samples || next <= ran || next > target.max_samples {
            let t = TargetSummary {
                reached,
                rounds,
                max_samples: target.max_samples,
                statistics,
            };
            for p in study.points.iter_mut() {
                p.summary.target = Some(t.clone());
            }
            return Ok(study);
        }
        n = next;
    }
}

/// One run of the study at the scene's sample count.
fn run_once(
    src: &SceneText,
    overrides: &Overrides,
    opts: &RunOptions,
    dir: Option<&Path>,
) -> Result<Study, StudyError> {
    let Plan {
        axes,
        points,
        reference,
    } = plan_text(src, overrides)?;
    let (file, text) = (&src.file, &src.text);
    let mut raw = src.raw(overrides)?;
    let mut staging = dir.map(Staging::new);
    // Every default explicit in the manifest.
    let output = raw.output.get_or_insert_with(Default::default);
    let field_error = |field: &str, message: String| SceneError {
        file: file.clone(),
        line: crate::config::line_of(text, &["output", field]),
        field: format!("output.{field}"),
        message,
    };
    let compression = Compression::new(output.compression.as_deref(), output.level)
        .map_err(|(field, m)| field_error(field, m))?;
    output.compression = Some(compression.name().into());
    output.level = compression.level();
    let output = output.clone();
    let sink_error = |e: Box<dyn std::error::Error + Send + Sync>| RunError::Sink(e);
    let mut writer = if output.per_sample {
        let selection = Selection::of_scene(&points[0].scene, output.columns.as_deref())
            .map_err(|m| field_error("columns", m))?;
        let precision = selection.precision();
        let threads = opts.worker_threads();
        let sweep: Vec<String> = axes.iter().map(|a| a.path.clone()).collect();
        Some(match staging.as_mut() {
            None => Rows::Memory(MemoryRows::new(selection, &sweep)),
            Some(staging) => {
                staging.create("samples.parquet")?;
                let path = staging
                    .temporary("samples.parquet")
                    .expect("just created")
                    .to_path_buf();
                let w = SamplesWriter::new(
                    &path,
                    selection,
                    WriteOptions {
                        compression,
                        threads,
                        sweep,
                    },
                )
                .map_err(|e| sink_error(Box::new(e)))?;
                Rows::File(w, precision)
            }
        })
    } else {
        None
    };
    // The engine computes only the float columns the rows keep.
    let opts = &RunOptions {
        sample_floats: writer.as_ref().map(Rows::float_mask),
        ..opts.clone()
    };
    if let Some(w) = &opts.watch {
        w.set_total(
            points
                .iter()
                .map(|p| samples_run(&p.scene, opts.shard))
                .sum(),
        );
    }
    // An MC sweep's points record cluster sums for their paired
    // differences (RQMC pairs by replicate).
    let opts = &RunOptions {
        clusters: points.len() > 1 && points[0].scene.sampling().replicates().is_none(),
        ..opts.clone()
    };
    let started = SystemTime::now();
    let mut runs = Vec::with_capacity(points.len());
    let sweep = !axes.is_empty();
    for (i, p) in points.into_iter().enumerate() {
        let point = sweep.then(|| (i as u32, p.values.iter().map(|v| v.1).collect::<Vec<_>>()));
        let result = match writer.as_mut() {
            None => run_with_samples(&p.scene, opts, None)?,
            Some(Rows::File(w, _)) => {
                w.set_point(point).map_err(|e| sink_error(Box::new(e)))?;
                let mut sink = |rows: SampleRows| w.push(rows).map_err(SinkError::from);
                run_with_samples(&p.scene, opts, Some(&mut sink))?
            }
            Some(Rows::Memory(m)) => {
                m.set_point(point);
                let mut sink = |rows: SampleRows| m.push(rows).map_err(SinkError::from);
                run_with_samples(&p.scene, opts, Some(&mut sink))?
            }
        };
        runs.push(PointRun::new(p.values, p.scene, result));
    }
    pair_points(&mut runs, reference);
    let (per_sample, samples) = match writer {
        Some(Rows::File(w, precision)) => (
            Some(PerSample {
                rows: w.finish().map_err(|e| sink_error(Box::new(e)))?,
                floats: precision.name(),
                float_encoding: crate::output::parquet::FLOAT_ENCODING,
                compression: compression.name(),
                level: compression.level(),
                row_group_rows: crate::output::parquet::ROW_GROUP,
            }),
            None,
        ),
        Some(Rows::Memory(m)) => (None, Some(m.finish())),
        None => (None, None),
    };
    Ok(Study {
        raw,
        axes,
        points: runs,
        started,
        finished: SystemTime::now(),
        per_sample,
        shard: opts.shard,
        merge: None,
        samples,
        folder: dir.map(Path::to_path_buf),
        staging,
    })
}

/// Merges shard folders into a study with the outputs of a single run (see
/// [`crate::output::shard`]). The scene is the shards' own `scene.toml`.
/// A `watch` counts the shards read and can stop the merge between them.
pub fn merge_study(
    dirs: &[PathBuf],
    allow_partial: bool,
    dir: &Path,
    watch: Option<&Watch>,
) -> Result<Study, StudyError> {
    let started = SystemTime::now();
    let checked = check(dirs, allow_partial)?;
    let first = &checked.shards[0];
    let src = SceneText::read(&first.dir.join("scene.toml"))?;
    let mut raw = src.raw(&Overrides::default())?;
    // A merge writes summaries only; per-sample rows stay in the shards.
    if let Some(o) = raw.output.as_mut() {
        o.per_sample = false;
    }
    let Plan {
        axes,
        points,
        reference,
    } = plan_text(&src, &Overrides::default())?;
    if points.len() != first.info.points {
        return Err(MergeError::State {
            path: first.dir.join("shard.json").display().to_string(),
            message: format!(
                "points is {}, but scene.toml has {} grid points",
                first.info.points,
                points.len()
            ),
        }
        .into());
    }
    let mut nodes: Vec<Vec<_>> = points.iter().map(|_| Vec::new()).collect();
    let mut clusters: Vec<BatchClusters> = points.iter().map(|_| BatchClusters::new()).collect();
    let mut wall = vec![0.0; points.len()];
    let mut cpu: Vec<Option<f64>> = vec![Some(0.0); points.len()];
    let shapes: Vec<Shape> = points.iter().map(|p| Shape::of(&p.scene)).collect();
    if let Some(w) = watch {
        w.set_total(checked.shards.len() as u64);
    }
    for s in &checked.shards {
        if watch.is_some_and(|w| w.cancelled()) {
            return Err(RunError::Cancelled.into());
        }
        let per_point = read_nodes(&s.dir, &shapes)?;
        for (k, c) in read_clusters(&s.dir, points.len())?.into_iter().enumerate() {
            clusters[k].extend(c);
        }
        if let Some(w) = watch {
            w.advance(1);
        }
        for (k, n) in per_point.into_iter().enumerate() {
            nodes[k].extend(n);
            wall[k] += s.info.wall_seconds.get(k).copied().unwrap_or(0.0);
            cpu[k] = match (cpu[k], s.info.cpu_seconds.get(k).copied().flatten()) {
                (Some(a), Some(b)) => Some(a + b),
                _ => None,
            };
        }
    }
    let threads = first.info.threads;
    let mut runs = Vec::with_capacity(points.len());
    for (k, ((p, n), c)) in points.into_iter().zip(nodes).zip(clusters).enumerate() {
        let mut result = merge_point(
            n,
            first.info.batches,
            Shape::of(&p.scene),
            p.scene.sampling().replicate_level(p.scene.batch_size()),
            wall[k],
            cpu[k],
            threads,
        );
        result.clusters = merge_clusters(
            c,
            p.scene.samples(),
            p.scene.batch_size(),
            first.info.batches,
            &result.acc.laws,
        )
        .map_err(|message| MergeError::State {
            path: "state_clusters.parquet".into(),
            message,
        })?;
        runs.push(PointRun::new(p.values, p.scene, result));
    }
    pair_points(&mut runs, reference);
    let merge = MergeInfo {
        shard_count: checked.count,
        shards_merged: checked.shards.iter().map(|s| s.info.shard_index).collect(),
        missing_shards: checked.missing.clone(),
        duplicate_shards_ignored: checked.duplicates.clone(),
        partial: !checked.missing.is_empty(),
        shard_dirs: checked
            .shards
            .iter()
            .map(|s| s.dir.display().to_string())
            .collect(),
    };
    Ok(Study {
        raw,
        axes,
        points: runs,
        started,
        finished: SystemTime::now(),
        per_sample: None,
        shard: None,
        merge: Some(merge),
        samples: None,
        folder: Some(dir.to_path_buf()),
        staging: Some(Staging::new(dir)),
    })
}

impl Study {
    /// Whether the scene has a sweep.
    pub fn is_sweep(&self) -> bool {
        !self.axes.is_empty()
    }

    /// The JSON printed by `run --format json` and saved as `summary.json`:
    /// the [`Summary`] itself for a plain run; for a sweep, the axes and one
    /// summary per point.
    pub fn summary_json(&self) -> serde_json::Value {
        if !self.is_sweep() {
            return serde_json::to_value(&self.points[0].summary).expect("serialisable");
        }
        let wall: f64 = self.points.iter().map(|p| p.result.wall_seconds).sum();
        let samples: u64 = self.points.iter().map(|p| p.scene.samples()).sum();
        json!({
            "scene": self.raw.name,
            "samples": self.raw.samples,
            "seed": self.raw.seed,
            "throughput": {"samples_per_second": samples as f64 / wall, "wall_seconds": wall},
            "sweep": {"axes": self.axes.iter().map(|a| json!({"path": a.path, "values": a.values, "dimension": a.dimension})).collect::<Vec<_>>()},
            "target": self.points[0].summary.target,
            "points": self.points.iter().map(|p| json!({
                "values": p.values.iter().map(|(k, v)| (k.clone(), json!(v))).collect::<serde_json::Map<_, _>>(),
                "summary": p.summary,
            })).collect::<Vec<_>>(),
        })
    }

    /// A shard's extra files: shard.json, scene.toml and the state tables.
    fn write_shard_state(
        &self,
        staging: &mut Staging,
        shard: Shard,
    ) -> Result<Vec<String>, OutputError> {
        let dir = staging.dir().to_path_buf();
        let results: Vec<&RunResult> = self.points.iter().map(|p| &p.result).collect();
        let info = info_of(
            &self.raw.name,
            self.raw.seed,
            self.raw.samples,
            shard,
            &results,
        );
        staging.write_json("shard.json", &info)?;
        let scene = toml::to_string(&self.raw).map_err(|e| OutputError::Io {
            path: dir.join("scene.toml").display().to_string(),
            source: std::io::Error::other(e.to_string()),
        })?;
        staging.write("scene.toml", |f| {
            use std::io::Write;
            f.write_all(scene.as_bytes())
                .map_err(|source| OutputError::Io {
                    path: dir.join("scene.toml").display().to_string(),
                    source,
                })
        })?;
        let nodes: Vec<&[_]> = self.points.iter().map(|p| &p.result.nodes[..]).collect();
        let names = [
            "state_counts.parquet",
            "state_moments.parquet",
            "state_histograms.parquet",
        ];
        let frames = state_frames(&nodes).map_err(|source| OutputError::Parquet {
            path: dir.join(names[0]).display().to_string(),
            source,
        })?;
        let sums: Vec<_> = self
            .points
            .iter()
            .map(|p| p.result.clusters.as_ref())
            .collect();
        let clusters = "state_clusters.parquet";
        let cluster_df = cluster_frame(&sums).map_err(|source| OutputError::Parquet {
            path: dir.join(clusters).display().to_string(),
            source,
        })?;
        for (name, mut df) in names
            .into_iter()
            .zip(frames)
            .chain([(clusters, cluster_df)])
        {
            write_parquet(
                staging,
                name,
                &mut df,
                crate::output::table_metadata(&self.points[0].summary),
            )?;
        }
        let mut files = vec!["shard.json".to_string(), "scene.toml".into()];
        files.extend(names.iter().chain([&clusters]).map(|s| s.to_string()));
        Ok(files)
    }

    /// The terminal summary.
    pub fn text(&self) -> String {
        (0..self.points.len()).map(|i| self.point_text(i)).collect()
    }

    /// The terminal summary of grid point `i` (headed by its swept values
    /// in a sweep).
    pub fn point_text(&self, i: usize) -> String {
        let p = &self.points[i];
        let mut s = String::new();
        if !p.values.is_empty() {
            let v: Vec<String> = p.values.iter().map(|(k, x)| format!("{k} = {x}")).collect();
            s.push_str(&format!("\n=== sweep point: {} ===\n", v.join(", ")));
        }
        s.push_str(&p.summary.to_text());
        s
    }

    /// The run folder, if the study has one.
    pub fn dir(&self) -> Option<&Path> {
        self.folder.as_deref()
    }

    /// The run's tables, as the run folder's Parquet files hold them, by
    /// file name: `summary.parquet`, `histograms.parquet` and, for a drop
    /// scene, its bounce and ending tables. The error names the table.
    pub fn tables(&self) -> Result<Vec<(&'static str, DataFrame)>, (&'static str, PolarsError)> {
        let summaries: Vec<(Vec<(String, f64)>, &Summary)> = self
            .points
            .iter()
            .map(|p| (p.values.clone(), &p.summary))
            .collect();
        let mut tables = vec![(
            "summary.parquet",
            summary_frame(&summaries).map_err(|e| ("summary.parquet", e))?,
        )];
        let hists: Vec<_> = self
            .points
            .iter()
            .map(|p| {
                let laws = p
                    .scene
                    .laws()
                    .iter()
                    .zip(&p.result.acc.laws)
                    .map(|(l, a)| (l.name(), p.summary.contacts.clone(), a))
                    .collect::<Vec<_>>();
                (p.values.clone(), laws)
            })
            .collect();
        tables.push((
            "histograms.parquet",
            histograms_frame(&hists).map_err(|e| ("histograms.parquet", e))?,
        ));
        let drops: Vec<(PointValues, DropAccs)> = self
            .points
            .iter()
            .map(|p| {
                let laws = p.scene.laws().iter().map(|l| l.name());
                let resolved_from = p.scene.effects().toi_tolerance;
                let accs = laws.zip(&p.result.acc.drops).collect();
                (p.values.clone(), (accs, resolved_from))
            })
            .collect();
        let contacts = &self.points[0].summary.contacts;
        tables.extend(drop_frames(&drops, contacts).map_err(|e| ("bounces.parquet", e))?);
        Ok(tables)
    }

    /// Writes the run folder: summary.parquet, histograms.parquet,
    /// summary.json, samples.parquet (already streamed) and manifest.json
    /// (last), all renamed together. A study kept in memory has no folder.
    pub fn write(&mut self) -> Result<Vec<PathBuf>, OutputError> {
        let mut staging = self.staging.take().ok_or(OutputError::NoFolder)?;
        let dir = staging.dir().to_path_buf();
        let dir = dir.as_path();
        let first = &self.points[0].summary;
        let tables = self
            .tables()
            .map_err(|(name, source)| OutputError::Parquet {
                path: dir.join(name).display().to_string(),
                source,
            })?;
        let mut files = Vec::new();
        for (name, mut df) in tables {
            write_parquet(
                &mut staging,
                name,
                &mut df,
                crate::output::table_metadata(first),
            )?;
            files.push(name.to_string());
        }
        staging.write_json("summary.json", &self.summary_json())?;
        files.push("summary.json".into());
        // The run's figures, per sweep point.
        let sweep = self.points.len() > 1;
        for (i, p) in self.points.iter().enumerate() {
            let suffix = if sweep {
                format!("-point{i}")
            } else {
                String::new()
            };
            let plots = run_plots(&p.scene, &p.summary.contacts, &p.result.acc, &suffix).map_err(
                |message| OutputError::Plot {
                    path: dir.join("plots").display().to_string(),
                    message,
                },
            )?;
            for (name, svg) in plots {
                let name = format!("plots/{name}");
                let path = dir.join(&name);
                staging.write(&name, |f| {
                    f.write_all(svg.as_bytes())
                        .map_err(|source| OutputError::Io {
                            path: path.display().to_string(),
                            source,
                        })
                })?;
                files.push(name);
            }
        }
        let mut shard_ref = None;
        if let Some(shard) = self.shard {
            files.extend(self.write_shard_state(&mut staging, shard)?);
            let range = shard.batches(self.points[0].result.batches);
            shard_ref = Some(ShardRef {
                index: shard.index,
                count: shard.count,
                batch_start: range.start,
                batch_end: range.end,
            });
        }
        if self.per_sample.is_some() {
            files.push("samples.parquet".into());
        }
        let timing = Timing {
            started: self.started,
            finished: self.finished,
            wall_seconds: self.points.iter().map(|p| p.result.wall_seconds).sum(),
            cpu_seconds: self.points.iter().map(|p| p.result.cpu_seconds).sum(),
            threads: self.points[0].result.threads,
        };
        let scene = &self.points[0].scene;
        let mut manifest = Manifest::new(&self.raw, scene.effects(), self.points.len(), timing);
        manifest.files = files;
        manifest.per_sample = self.per_sample.clone();
        manifest.shard = shard_ref;
        manifest.merge = self.merge.clone();
        staging.write_json("manifest.json", &manifest)?;
        staging.commit()
    }
}

/// What a scene will run, known before any work: for the command line to
/// print first and to name the output folder.
pub struct Prepared {
    pub name: String,
    /// The effect set (`effects: …`).
    pub effects_line: String,
    /// The kernel instantiation (`kernel: …`).
    pub kernel_line: String,
}

/// Validates a scene (every sweep point) with its overrides and the run's
/// options, and says what it will run.
pub fn prepare(
    src: &SceneText,
    overrides: &Overrides,
    opts: &RunOptions,
) -> Result<Prepared, StudyError> {
    let points = plan_text(src, overrides)?.points;
    let scene = &points[0].scene;
    Ok(Prepared {
        name: scene.name().to_string(),
        effects_line: scene.effects().line(),
        kernel_line: crate::engine::describe(scene, opts.keep),
    })
}
