//! `manifest.json`: everything needed to reproduce and audit a run. It is
//! written last, so its presence marks a complete run folder.

use std::time::{SystemTime, UNIX_EPOCH};

use serde::{Deserialize, Serialize};

use crate::config::{Effects, RawScene};

#[derive(Debug, Clone, Serialize)]
pub struct Machine {
    pub hostname: String,
    pub cpu: String,
    pub logical_cores: usize,
    pub os: String,
}

impl Machine {
    pub fn current() -> Self {
        let cpu = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find(|l| l.starts_with("model name"))
                    .and_then(|l| l.split(':').nth(1))
                    .map(|s| s.trim().to_string())
            })
            .unwrap_or_else(|| "unknown".into());
        let hostname = std::fs::read_to_string("/etc/hostname")
            .map(|s| s.trim().to_string())
            .unwrap_or_else(|_| "unknown".into());
        Self {
            hostname,
            cpu,
            logical_cores: std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1),
            os: format!("{} {}", std::env::consts::OS, std::env::consts::ARCH),
        }
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct Manifest {
    pub schema_version: u32,
    pub impactmc_version: &'static str,
    pub git_commit: &'static str,
    /// The validated scene with every default explicit (and overrides applied).
    pub scene: RawScene,
    pub seed: u64,
    /// Samples per grid point.
    pub samples: u64,
    /// Grid points (1 without a sweep).
    pub points: usize,
    pub started_utc: String,
    pub finished_utc: String,
    pub wall_seconds: f64,
    pub cpu_seconds: Option<f64>,
    pub threads: usize,
    pub machine: Machine,
    pub files: Vec<String>,
    /// What `samples.parquet` holds, when written.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub per_sample: Option<PerSample>,
    /// The effects simulated, declared and derived ([`crate::config::Effects`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub effects: Option<crate::config::Effects>,
    /// A shard run (`--shard I/N`): its index and count.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shard: Option<ShardRef>,
    /// A merge of shards (`impactmc merge`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub merge: Option<MergeInfo>,
}

/// When and how a run ran, for its manifest.
#[derive(Debug, Clone, Copy)]
pub struct Timing {
    pub started: SystemTime,
    pub finished: SystemTime,
    pub wall_seconds: f64,
    pub cpu_seconds: Option<f64>,
    pub threads: usize,
}

impl Manifest {
    /// The manifest of every kind of run folder: this build, this machine,
    /// the scene with every default explicit and its effects. `files`,
    /// `shard` and `merge` are the caller's to fill in.
    pub fn new(raw: &RawScene, effects: &Effects, points: usize, timing: Timing) -> Self {
        Self {
            schema_version: crate::SCHEMA_VERSION,
            impactmc_version: env!("CARGO_PKG_VERSION"),
            git_commit: env!("IMPACTMC_GIT_COMMIT"),
            scene: raw.clone(),
            seed: raw.seed,
            samples: raw.samples,
            points,
            started_utc: utc_string(timing.started),
            finished_utc: utc_string(timing.finished),
            wall_seconds: timing.wall_seconds,
            cpu_seconds: timing.cpu_seconds,
            threads: timing.threads,
            machine: Machine::current(),
            files: Vec::new(),
            per_sample: None,
            effects: Some(effects.clone()),
            shard: None,
            merge: None,
        }
    }
}

/// How `samples.parquet` was written.
#[derive(Debug, Clone, Serialize)]
pub struct PerSample {
    pub rows: u64,
    /// The float columns' type: the run's precision ("f32" or "f64").
    pub floats: &'static str,
    /// The float columns' Parquet encoding.
    pub float_encoding: &'static str,
    pub compression: &'static str,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub level: Option<i32>,
    pub row_group_rows: usize,
}

#[derive(Debug, Clone, Serialize)]
pub struct ShardRef {
    pub index: u64,
    pub count: u64,
    pub batch_start: u64,
    pub batch_end: u64,
}

/// What a merge combined. `partial` is true when shards were missing: the
/// statistics then cover only the merged shards' samples.
#[derive(Debug, Clone, Serialize)]
pub struct MergeInfo {
    pub shard_count: u64,
    pub shards_merged: Vec<u64>,
    pub missing_shards: Vec<u64>,
    pub duplicate_shards_ignored: Vec<u64>,
    pub partial: bool,
    pub shard_dirs: Vec<String>,
}

/// Seconds since the epoch as `YYYY-MM-DDTHH:MM:SSZ`.
pub fn utc_string(t: SystemTime) -> String {
    let secs = t
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0) as i64;
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + (m <= 2) as i64;
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// What `impactmc inspect` reads back from a finished run folder's
/// `manifest.json`.
#[derive(Debug, Clone, Deserialize)]
pub struct ManifestHead {
    pub scene: SceneName,
    pub seed: u64,
    pub samples: u64,
    pub points: usize,
    pub impactmc_version: String,
    pub git_commit: String,
    pub schema_version: u32,
    pub started_utc: String,
    pub finished_utc: String,
    pub wall_seconds: f64,
    pub threads: usize,
    pub machine: MachineHead,
    pub files: Vec<String>,
}

#[derive(Debug, Clone, Deserialize)]
pub struct SceneName {
    pub name: String,
}

#[derive(Debug, Clone, Deserialize)]
pub struct MachineHead {
    pub cpu: String,
    pub hostname: String,
}

impl ManifestHead {
    /// The header `impactmc inspect` prints for the folder `dir`.
    pub fn text(&self, dir: &std::path::Path) -> String {
        let plots: Vec<&str> = self
            .files
            .iter()
            .map(String::as_str)
            .filter(|f| f.starts_with("plots/"))
            .collect();
        let tables: Vec<&str> = self
            .files
            .iter()
            .map(String::as_str)
            .filter(|f| !f.starts_with("plots/"))
            .collect();
        let mut text = format!(
            "run folder {}\n  scene {} (seed {}, {} samples per point, {} point(s))\n  impactmc {} ({}), schema {}\n  started {}, finished {}, wall {:.3} s, {} threads on {} ({})\n  files: {}\n",
            dir.display(),
            self.scene.name,
            self.seed,
            self.samples,
            self.points,
            self.impactmc_version,
            self.git_commit,
            self.schema_version,
            self.started_utc,
            self.finished_utc,
            self.wall_seconds,
            self.threads,
            self.machine.cpu,
            self.machine.hostname,
            tables.join(", "),
        );
        if !plots.is_empty() {
            text += &format!("  plots: {}\n", plots.join(", "));
        }
        text
    }
}

/// A finished run folder read back: its manifest and summary (as JSON) and
/// the text `impactmc inspect` prints.
#[derive(Debug, Clone)]
pub struct Inspection {
    pub manifest: serde_json::Value,
    pub summary: serde_json::Value,
    pub text: String,
}

/// Reads a finished run folder (`impactmc inspect`); the error names the
/// file and says what is wrong with it.
pub fn inspect(dir: &std::path::Path) -> Result<Inspection, String> {
    use crate::output::summary::Summary;
    let read = |name: &str| -> Result<serde_json::Value, String> {
        let path = dir.join(name);
        let text = std::fs::read_to_string(&path).map_err(|e| {
            format!(
                "{}: {e} (not a finished impactmc run folder: manifest.json is written last)",
                path.display()
            )
        })?;
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))
    };
    let manifest = read("manifest.json")?;
    let summary = read("summary.json")?;
    let head: ManifestHead = serde_json::from_value(manifest.clone())
        .map_err(|e| format!("{}: {e}", dir.join("manifest.json").display()))?;
    let mut text = head.text(dir);
    let bad_summary = |e: serde_json::Error| format!("summary.json: {e}");
    let summaries: Vec<(String, Summary)> = match summary.get("points").and_then(|p| p.as_array()) {
        Some(points) => points
            .iter()
            .map(|p| {
                let s = serde_json::from_value(p["summary"].clone()).map_err(bad_summary)?;
                Ok((format!("\n=== sweep point {} ===\n", p["values"]), s))
            })
            .collect::<Result<_, String>>()?,
        None => vec![(
            String::from("\n"),
            serde_json::from_value(summary.clone()).map_err(bad_summary)?,
        )],
    };
    for (head, s) in summaries {
        text.push_str(&head);
        text.push_str(&s.to_text());
    }
    Ok(Inspection {
        manifest,
        summary,
        text,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utc_formatting() {
        let t = UNIX_EPOCH + std::time::Duration::from_secs(1_795_000_000);
        assert_eq!(utc_string(t), "2026-11-18T11:06:40Z");
        assert_eq!(utc_string(UNIX_EPOCH), "1970-01-01T00:00:00Z");
    }
}
