//! Run outputs: one folder per run, every file written under a temporary
//! name and renamed when complete, so a file is either whole or absent
//! (cryo's export pattern).

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use polars::prelude::*;

use crate::summary::{StatSummary, Summary};

/// Why outputs could not be written.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("output folder {path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("output folder {0} already holds a run; pass --force to overwrite it")]
    Exists(String),
    #[error("writing {path}: {source}")]
    Parquet {
        path: String,
        #[source]
        source: PolarsError,
    },
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> OutputError + '_ {
    move |source| OutputError::Io {
        path: path.display().to_string(),
        source,
    }
}

/// Prepares the output folder: creates it, refuses one that already holds a
/// run unless `force`, and checks that it is writable before any work.
pub fn prepare_dir(dir: &Path, force: bool) -> Result<(), OutputError> {
    fs::create_dir_all(dir).map_err(io(dir))?;
    if !force && dir.join("manifest.json").exists() {
        return Err(OutputError::Exists(dir.display().to_string()));
    }
    let probe = dir.join(".impactmc-write-probe");
    fs::write(&probe, b"").map_err(io(dir))?;
    fs::remove_file(&probe).map_err(io(dir))?;
    Ok(())
}

/// Writes `name` in `dir` through `write`, via a temporary file renamed at
/// the end.
pub fn write_atomic(
    dir: &Path,
    name: &str,
    write: impl FnOnce(&mut fs::File) -> Result<(), OutputError>,
) -> Result<PathBuf, OutputError> {
    let final_path = dir.join(name);
    let tmp = dir.join(format!(".{name}.partial-{}", std::process::id()));
    let mut f = fs::File::create(&tmp).map_err(io(&tmp))?;
    let result = write(&mut f).and_then(|_| f.sync_all().map_err(io(&tmp)));
    drop(f);
    if let Err(e) = result {
        let _ = fs::remove_file(&tmp);
        return Err(e);
    }
    fs::rename(&tmp, &final_path).map_err(io(&final_path))?;
    Ok(final_path)
}

/// Writes JSON atomically.
pub fn write_json<T: serde::Serialize>(
    dir: &Path,
    name: &str,
    value: &T,
) -> Result<PathBuf, OutputError> {
    write_atomic(dir, name, |f| {
        let text = serde_json::to_string_pretty(value).expect("serialisable");
        f.write_all(text.as_bytes()).map_err(io(Path::new(name)))?;
        f.write_all(b"\n").map_err(io(Path::new(name)))
    })
}

/// The statistic columns of the summary table, with their units.
fn stat_units(name: &str) -> &'static str {
    if name.starts_with("impulse_") {
        "N*s"
    } else if name.starts_with("omega") {
        "rad/s"
    } else if name.starts_with("velocity") {
        "m/s"
    } else {
        "1"
    }
}

/// One (law, group) row: its statistics, fractions and their CIs.
type Row = (
    std::collections::HashMap<String, StatSummary>,
    serde_json::Map<String, serde_json::Value>,
    serde_json::Map<String, serde_json::Value>,
);

const STAT_FIELDS: [&str; 9] = [
    "n", "mean", "ci95", "sd", "min", "p01", "median", "p99", "max",
];

/// `summary.parquet`: one row per (law, group). Columns `law`, `group`,
/// `samples`, `impacts`, then `STAT_FIELD` for every statistic (null where a
/// group keeps no quantiles), and `fraction_FLAG` / `fraction_FLAG_ci95` on
/// the "all" rows. Units are in the file's key-value metadata (`units`).
pub fn summary_frame(summary: &Summary) -> Result<DataFrame, PolarsError> {
    let mut law_col = Vec::new();
    let mut group_col = Vec::new();
    let mut samples = Vec::new();
    let mut impacts = Vec::new();
    let mut stat_names: Vec<String> = Vec::new();
    let mut fraction_names: Vec<String> = Vec::new();
    let mut rows: Vec<Row> = Vec::new();
    for (law, lv) in &summary.laws {
        let Some(groups) = lv.get("groups").and_then(|g| g.as_object()) else {
            continue;
        };
        for (group, gv) in groups {
            let g: crate::summary::GroupSummary = serde_json::from_value(gv.clone())
                .map_err(|e| PolarsError::ComputeError(format!("summary group: {e}").into()))?;
            law_col.push(law.clone());
            group_col.push(group.clone());
            samples.push(g.samples);
            impacts.push(g.impacts);
            let mut stats = std::collections::HashMap::new();
            for (name, v) in &g.stats {
                if !stat_names.contains(name) {
                    stat_names.push(name.clone());
                }
                if let Ok(s) = serde_json::from_value::<StatSummary>(v.clone()) {
                    stats.insert(name.clone(), s);
                }
            }
            for name in g.fractions.keys() {
                if !fraction_names.contains(name) {
                    fraction_names.push(name.clone());
                }
            }
            rows.push((stats, g.fractions, g.fractions_ci95));
        }
    }
    let height = rows.len();
    let mut cols = vec![
        Column::new("law".into(), law_col),
        Column::new("group".into(), group_col),
        Column::new("samples".into(), samples),
        Column::new("impacts".into(), impacts),
    ];
    for name in &stat_names {
        for field in STAT_FIELDS {
            let col = format!("{name}_{field}");
            if field == "n" {
                let v: Vec<Option<u64>> = rows.iter().map(|r| r.0.get(name).map(|s| s.n)).collect();
                cols.push(Column::new(col.into(), v));
                continue;
            }
            let v: Vec<Option<f64>> = rows
                .iter()
                .map(|r| {
                    r.0.get(name).and_then(|s| match field {
                        "mean" => Some(s.mean),
                        "ci95" => Some(s.ci95),
                        "sd" => Some(s.sd),
                        "min" => Some(s.min),
                        "max" => Some(s.max),
                        "p01" => s.p01,
                        "median" => s.median,
                        _ => s.p99,
                    })
                })
                .collect();
            cols.push(Column::new(col.into(), v));
        }
    }
    for name in &fraction_names {
        let v: Vec<Option<f64>> = rows
            .iter()
            .map(|r| r.1.get(name).and_then(|x| x.as_f64()))
            .collect();
        cols.push(Column::new(format!("fraction_{name}").into(), v));
        let v: Vec<Option<f64>> = rows
            .iter()
            .map(|r| r.2.get(name).and_then(|x| x.as_f64()))
            .collect();
        cols.push(Column::new(format!("fraction_{name}_ci95").into(), v));
    }
    DataFrame::new(height, cols)
}

/// Key-value metadata: units of every statistic and the schema version.
fn metadata(summary: &Summary) -> KeyValueMetadata {
    let mut units = serde_json::Map::new();
    if let Some(all) = summary
        .laws
        .values()
        .next()
        .and_then(|l| l.get("groups"))
        .and_then(|g| g.get("all"))
    {
        if let Some(stats) = all.get("stats").and_then(|s| s.as_object()) {
            for name in stats.keys() {
                units.insert(name.clone(), stat_units(name).into());
            }
        }
    }
    KeyValueMetadata::from_static(vec![
        (
            "impactmc.schema_version".into(),
            crate::SCHEMA_VERSION.to_string(),
        ),
        (
            "impactmc.units".into(),
            serde_json::Value::Object(units).to_string(),
        ),
    ])
}

/// Writes `summary.parquet` (zstd) atomically.
pub fn write_summary_parquet(dir: &Path, summary: &Summary) -> Result<PathBuf, OutputError> {
    let name = "summary.parquet";
    let err = |source| OutputError::Parquet {
        path: dir.join(name).display().to_string(),
        source,
    };
    let mut df = summary_frame(summary).map_err(err)?;
    write_atomic(dir, name, |f| {
        ParquetWriter::new(f)
            .with_compression(ParquetCompression::Zstd(None))
            .with_key_value_metadata(Some(metadata(summary)))
            .finish(&mut df)
            .map(|_| ())
            .map_err(err)
    })
}
