//! The run folder's tables: `summary.parquet` and `histograms.parquet` as
//! frames, their metadata, and Parquet writing into the staging area.

use polars::prelude::*;

use crate::output::staging::{OutputError, Staging};
use crate::output::summary::{StatSummary, Summary};
use crate::stats::accumulators::LawAcc;

/// Column name of a swept field: `sweep_` and the path with every run of
/// other characters than letters and digits turned into `_`
/// (`body.semi_axes[2]` → `sweep_body_semi_axes_2`).
pub fn sweep_column(path: &str) -> String {
    let mut out = String::from("sweep_");
    let mut last_us = true;
    for ch in path.chars() {
        if ch.is_ascii_alphanumeric() {
            out.push(ch);
            last_us = false;
        } else if !last_us {
            out.push('_');
            last_us = true;
        }
    }
    out.trim_end_matches('_').to_string()
}

/// Adds `point` and the swept values as leading columns repeated per row.
fn with_point_columns(
    df: DataFrame,
    point: usize,
    values: &[(String, f64)],
) -> Result<DataFrame, PolarsError> {
    let h = df.height();
    let mut cols = vec![Column::new("point".into(), vec![point as u32; h])];
    for (path, x) in values {
        cols.push(Column::new(sweep_column(path).into(), vec![*x; h]));
    }
    cols.extend(df.columns().iter().cloned());
    DataFrame::new(h, cols)
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

/// One (law, contact set) row: its statistics, fractions and their CIs.
type Row = (
    std::collections::HashMap<String, StatSummary>,
    serde_json::Map<String, serde_json::Value>,
    serde_json::Map<String, serde_json::Value>,
);

const STAT_FIELDS: [&str; 9] = [
    "n", "mean", "ci95", "sd", "min", "p01", "median", "p99", "max",
];

/// `summary.parquet`: one row per (law, contact set). Columns `law`,
/// `contact_set` (`all`, `(none)` or the `+`-joined active planes),
/// `samples`, `impacts`, then `STAT_FIELD` for every statistic (null where a
/// group keeps no quantiles), and `fraction_FLAG` / `fraction_FLAG_ci95` on
/// the "all" rows. Units are in the file's key-value metadata (`units`).
fn summary_frame_one(summary: &Summary) -> Result<DataFrame, PolarsError> {
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
            let g: crate::output::summary::GroupSummary = serde_json::from_value(gv.clone())
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
        Column::new("contact_set".into(), group_col),
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

/// The swept values of a grid point, `(path, value)` in axis order.
pub type PointValues = Vec<(String, f64)>;

/// A grid point's accumulators per law: (law name, touching plane names,
/// accumulators).
pub type LawAccs<'a> = Vec<(String, Vec<String>, &'a LawAcc)>;

/// The summary table of a study: [`summary_frame_one`] per grid point, with
/// `point` and the `sweep_*` columns in front.
pub fn summary_frame(points: &[(Vec<(String, f64)>, &Summary)]) -> Result<DataFrame, PolarsError> {
    stack_points(
        points.iter().enumerate().map(|(i, (values, summary))| {
            with_point_columns(summary_frame_one(summary)?, i, values)
        }),
    )
}

/// Stacks the frames of the grid points, in point order.
fn stack_points(
    frames: impl Iterator<Item = Result<DataFrame, PolarsError>>,
) -> Result<DataFrame, PolarsError> {
    let mut out: Option<DataFrame> = None;
    for df in frames {
        let df = df?;
        out = Some(match out {
            None => df,
            Some(mut acc) => {
                acc.vstack_mut(&df)?;
                acc
            }
        });
    }
    out.ok_or_else(|| PolarsError::ComputeError("a study has at least one point".into()))
}

/// `histograms.parquet`: the non-empty log-linear bins of every histogram
/// kept (every statistic over all samples; the three headline statistics
/// per contact set), one row per bin: `point`, `sweep_*`, `law`, `contact_set`, `statistic`, `bin_lo`, `bin_hi`,
/// `count`. Bins are [bin_lo, bin_hi); an exact zero is the bin [0, 0].
pub fn histograms_frame(points: &[(PointValues, LawAccs<'_>)]) -> Result<DataFrame, PolarsError> {
    stack_points(points.iter().enumerate().map(|(i, (values, laws))| {
        let (mut law, mut set, mut stat, mut lo, mut hi, mut count) =
            (vec![], vec![], vec![], vec![], vec![], vec![]);
        for (name, contacts, acc) in laws {
            let mut hists: Vec<(String, String, &crate::stats::LogHistogram)> = vec![
                ("all".into(), "energy_ratio".into(), &acc.energy_ratio.hist),
                (
                    "all".into(),
                    "omega_after_norm".into(),
                    &acc.omega_after_norm.hist,
                ),
                (
                    "all".into(),
                    "velocity_after_norm".into(),
                    &acc.velocity_after_norm.hist,
                ),
            ];
            for (i, plane) in contacts.iter().enumerate() {
                hists.push((
                    "all".into(),
                    format!("impulse_{plane}"),
                    &acc.impulse[i].hist,
                ));
                hists.push((
                    "all".into(),
                    format!("rebound_{plane}"),
                    &acc.rebound[i].hist,
                ));
            }
            for (mask, g) in acc.groups.iter().enumerate() {
                let set_name = crate::output::summary::active_set_name(mask, contacts);
                let set_name = if set_name.is_empty() {
                    "(none)".to_string()
                } else {
                    set_name
                };
                hists.push((
                    set_name.clone(),
                    "energy_ratio".into(),
                    &g.energy_ratio.hist,
                ));
                hists.push((
                    set_name.clone(),
                    "omega_after_norm".into(),
                    &g.omega_after_norm.hist,
                ));
                hists.push((
                    set_name,
                    "velocity_after_norm".into(),
                    &g.velocity_after_norm.hist,
                ));
            }
            for (set_name, stat_name, h) in hists {
                for (l, hb, c) in h.bins() {
                    law.push(name.clone());
                    set.push(set_name.clone());
                    stat.push(stat_name.clone());
                    lo.push(l);
                    hi.push(hb);
                    count.push(c);
                }
            }
        }
        let n = law.len();
        let df = DataFrame::new(
            n,
            vec![
                Column::new("law".into(), law),
                Column::new("contact_set".into(), set),
                Column::new("statistic".into(), stat),
                Column::new("bin_lo".into(), lo),
                Column::new("bin_hi".into(), hi),
                Column::new("count".into(), count),
            ],
        )?;
        with_point_columns(df, i, values)
    }))
}

/// Key-value metadata with the schema version only (tables without units).
pub fn schema_metadata() -> KeyValueMetadata {
    KeyValueMetadata::from_static(vec![(
        "impactmc.schema_version".into(),
        crate::SCHEMA_VERSION.to_string(),
    )])
}

/// Key-value metadata: units of every statistic and the schema version.
pub fn table_metadata(summary: &Summary) -> KeyValueMetadata {
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

/// Writes a frame as zstd Parquet into the staging area.
pub fn write_parquet(
    staging: &mut Staging,
    name: &str,
    df: &mut DataFrame,
    metadata: KeyValueMetadata,
) -> Result<(), OutputError> {
    let path = staging.dir().join(name).display().to_string();
    staging.write(name, |f| {
        ParquetWriter::new(f)
            .with_compression(ParquetCompression::Zstd(None))
            .with_key_value_metadata(Some(metadata))
            .finish(df)
            .map(|_| ())
            .map_err(|source| OutputError::Parquet { path, source })
    })
}
