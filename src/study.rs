//! A study: every grid point of a scene file run in turn, summarised, and
//! written as one run folder (summary, histograms, manifest; staged and
//! renamed together at the end).

use std::path::{Path, PathBuf};
use std::time::SystemTime;

use serde_json::json;

use crate::config::RawScene;
use crate::engine::{run, RunOptions, RunResult};
use crate::manifest::{utc_string, Machine, Manifest};
use crate::output::{histograms_frame, summary_frame, write_parquet, OutputError, Staging};
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
}

#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error("thread pool: {0}")]
    Pool(#[from] rayon::ThreadPoolBuildError),
}

/// Validates every grid point first (so a bad point fails before any work),
/// then runs them in order.
pub fn run_study(
    path: &Path,
    overrides: &Overrides,
    opts: &RunOptions,
) -> Result<Study, StudyError> {
    let (axes, points) = plan(path, overrides)?;
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let mut raw = Scene::parse(&file, &text)?;
    overrides.apply(&mut raw);
    let started = SystemTime::now();
    let mut runs = Vec::with_capacity(points.len());
    for p in points {
        let result = run(&p.scene, opts)?;
        let summary = Summary::new(&p.scene, &result);
        runs.push(PointRun {
            values: p.values,
            scene: p.scene,
            result,
            summary,
        });
    }
    Ok(Study {
        raw,
        axes,
        points: runs,
        started,
        finished: SystemTime::now(),
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
    /// summary.json and manifest.json (last), all renamed together.
    pub fn write(&self, dir: &Path, extra: Option<PathBuf>) -> Result<Vec<PathBuf>, OutputError> {
        let mut staging = Staging::new(dir);
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
                    .map(|(l, a)| (l.name(), a))
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
        if let Some(extra) = extra {
            files.push(extra.display().to_string());
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
