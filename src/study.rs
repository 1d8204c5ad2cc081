//! A study: every grid point of a scene file run in turn, summarised, and
//! written as one run folder (summary, histograms, manifest; staged and
//! renamed together at the end).

use std::path::{Path, PathBuf};
use std::time::SystemTime;

use serde_json::json;

use crate::config::RawScene;
use crate::engine::{
    run_with_samples, sample_columns, RunError, RunOptions, RunResult, SampleRows,
};
use crate::manifest::{utc_string, Machine, Manifest};
use crate::output::{histograms_frame, summary_frame, write_parquet, OutputError, Staging};
use crate::samples::{SamplesWriter, Selection};
use crate::scene::{Overrides, Scene, SceneError};
use crate::summary::Summary;
use crate::sweep::{plan, Axis};

/// One grid point's run.
pub struct PointRun {
    pub values: Vec<(String, f64)>,
    pub scene: Scene,
    pub result: RunResult,
    pub summary: Summary,
}

pub struct Study {
    /// The scene as given (overrides applied, sweep included).
    pub raw: RawScene,
    pub axes: Vec<Axis>,
    pub points: Vec<PointRun>,
    pub started: SystemTime,
    pub finished: SystemTime,
    /// Rows written to samples.parquet, when asked for.
    pub sample_rows: Option<u64>,
    staging: Staging,
}

#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Run(#[from] RunError),
    #[error(transparent)]
    Output(#[from] OutputError),
}

/// Validates every grid point and the per-sample columns first (so bad
/// input fails before any work), then runs the points in order, streaming
/// per-sample rows into the staging area of `dir` when the scene asks for
/// them.
pub fn run_study(
    path: &Path,
    overrides: &Overrides,
    opts: &RunOptions,
    dir: &Path,
) -> Result<Study, StudyError> {
    let (axes, points) = plan(path, overrides)?;
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let mut raw = Scene::parse(&file, &text)?;
    overrides.apply(&mut raw);
    let mut staging = Staging::new(dir);
    // Every default explicit in the manifest.
    let output = raw.output.get_or_insert_with(Default::default).clone();
    let mut writer = if output.per_sample {
        let (floats, ints) = sample_columns(&points[0].scene);
        let selection =
            Selection::new(floats, ints, output.columns.as_deref()).map_err(|m| SceneError {
                file: file.clone(),
                line: crate::config::line_of(&text, &["output", "columns"]),
                field: "output.columns".into(),
                message: m,
            })?;
        Some(SamplesWriter::new(
            staging.create("samples.parquet")?,
            selection,
        ))
    } else {
        None
    };
    let started = SystemTime::now();
    let mut runs = Vec::with_capacity(points.len());
    let sweep = !axes.is_empty();
    for (i, p) in points.into_iter().enumerate() {
        let result = match writer.as_mut() {
            None => run_with_samples(&p.scene, opts, None)?,
            Some(w) => {
                let parquet = |e: polars::prelude::PolarsError| RunError::Sink(e.to_string());
                w.set_point(sweep.then_some(i as u32)).map_err(parquet)?;
                let mut sink = |rows: SampleRows| w.push(rows).map_err(|e| e.to_string());
                run_with_samples(&p.scene, opts, Some(&mut sink))?
            }
        };
        let summary = Summary::new(&p.scene, &result);
        runs.push(PointRun {
            values: p.values,
            scene: p.scene,
            result,
            summary,
        });
    }
    let sample_rows = match writer {
        Some(w) => Some(w.finish().map_err(|e| RunError::Sink(e.to_string()))?),
        None => None,
    };
    Ok(Study {
        raw,
        axes,
        points: runs,
        started,
        finished: SystemTime::now(),
        sample_rows,
        staging,
    })
}

impl Study {
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
            "sweep": {"axes": self.axes.iter().map(|a| json!({"path": a.path, "values": a.values})).collect::<Vec<_>>()},
            "points": self.points.iter().map(|p| json!({
                "values": p.values.iter().map(|(k, v)| (k.clone(), json!(v))).collect::<serde_json::Map<_, _>>(),
                "summary": p.summary,
            })).collect::<Vec<_>>(),
        })
    }

    /// The terminal summary.
    pub fn text(&self) -> String {
        let mut s = String::new();
        for p in &self.points {
            if !p.values.is_empty() {
                let v: Vec<String> = p.values.iter().map(|(k, x)| format!("{k} = {x}")).collect();
                s.push_str(&format!("\n=== sweep point: {} ===\n", v.join(", ")));
            }
            s.push_str(&p.summary.to_text());
        }
        s
    }

    /// Writes the run folder: summary.parquet, histograms.parquet,
    /// summary.json, samples.parquet (already streamed) and manifest.json
    /// (last), all renamed together.
    pub fn write(mut self) -> Result<Vec<PathBuf>, OutputError> {
        let dir = self.staging.dir().to_path_buf();
        let mut staging = std::mem::replace(&mut self.staging, Staging::new(&dir));
        let dir = dir.as_path();
        let first = &self.points[0].summary;
        let summaries: Vec<(Vec<(String, f64)>, &Summary)> = self
            .points
            .iter()
            .map(|p| (p.values.clone(), &p.summary))
            .collect();
        let err = |path: &str| {
            let path = dir.join(path).display().to_string();
            move |source| OutputError::Parquet { path, source }
        };
        let mut df = summary_frame(&summaries).map_err(err("summary.parquet"))?;
        write_parquet(
            &mut staging,
            "summary.parquet",
            &mut df,
            crate::output::table_metadata(first),
        )?;
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
        let mut df = histograms_frame(&hists).map_err(err("histograms.parquet"))?;
        write_parquet(
            &mut staging,
            "histograms.parquet",
            &mut df,
            crate::output::table_metadata(first),
        )?;
        staging.write_json("summary.json", &self.summary_json())?;
        let mut files = vec![
            "summary.parquet".to_string(),
            "histograms.parquet".into(),
            "summary.json".into(),
        ];
        if self.sample_rows.is_some() {
            files.push("samples.parquet".into());
        }
        let manifest = Manifest {
            schema_version: crate::SCHEMA_VERSION,
            impactmc_version: env!("CARGO_PKG_VERSION"),
            git_commit: env!("IMPACTMC_GIT_COMMIT"),
            scene: self.raw.clone(),
            seed: self.raw.seed,
            samples: self.raw.samples,
            points: self.points.len(),
            started_utc: utc_string(self.started),
            finished_utc: utc_string(self.finished),
            wall_seconds: self.points.iter().map(|p| p.result.wall_seconds).sum(),
            cpu_seconds: self.points.iter().map(|p| p.result.cpu_seconds).sum(),
            threads: self.points[0].result.threads,
            machine: Machine::current(),
            files,
        };
        staging.write_json("manifest.json", &manifest)?;
        staging.commit()
    }
}
