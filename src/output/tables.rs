//! The run folder's tables: `summary.parquet` and `histograms.parquet` as
//! frames, their metadata, and Parquet writing into the staging area.

use polars::prelude::*;

use crate::output::staging::{OutputError, Staging};
use crate::output::summary::{proportion, Interval, Named, PointDifference, StatSummary, Summary};
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
    if name.starts_with("impulse_") || name.starts_with("tangential_impulse_") {
        "N*s"
    } else if name.starts_with("omega") {
        "rad/s"
    } else if name.starts_with("velocity") || name.starts_with("sliding_speed_") {
        "m/s"
    } else {
        "1"
    }
}

/// One (law, contact set) row: its statistics (those with every moment
/// defined), fractions, their intervals and (RQMC) gains.
type Row<'a> = (
    std::collections::HashMap<&'a str, &'a StatSummary>,
    Named<f64>,
    Named<Interval>,
    Named<f64>,
);

const STAT_FIELDS: [&str; 10] = [
    "n", "mean", "ci95", "gain", "sd", "min", "p01", "median", "p99", "max",
];

/// `summary.parquet`: one row per (law, contact set), and for a drop scene
/// (whose contact-set rows are each sample's first impact) one row per
/// (law, bounce) with the bounce statistics. Columns `law`, `contact_set`
/// (`all`, `(none)` or the `+`-joined active planes), `bounce` (drop
/// scenes only; null on the first-impact rows), `samples`, `impacts`, then `STAT_FIELD` for every statistic (null where a
/// group keeps no quantiles), and on the "all" rows `fraction_FLAG` with
/// its 95 % interval `fraction_FLAG_low` / `fraction_FLAG_high`, the same
/// for every active set (`fraction_active_set_SET`); an RQMC run adds
/// `STAT_gain` and `fraction_FLAG_gain`. Units are in the file's key-value
/// metadata (`units`).
fn summary_frame_one(summary: &Summary) -> Result<DataFrame, PolarsError> {
    let mut law_col = Vec::new();
    let mut group_col = Vec::new();
    let mut samples = Vec::new();
    let mut impacts = Vec::new();
    let mut stat_names: Vec<String> = Vec::new();
    let mut fraction_names: Vec<String> = Vec::new();
    let mut rows: Vec<Row> = Vec::new();
    let mut bounce_col: Vec<Option<u32>> = Vec::new();
    for (law, ls) in summary.laws.iter() {
        for (group, g) in ls.groups.iter() {
            law_col.push(law.clone());
            group_col.push(group.clone());
            samples.push(g.samples);
            impacts.push(g.impacts);
            let mut stats = std::collections::HashMap::new();
            for (name, st) in g.stats.iter() {
                if !stat_names.contains(name) {
                    stat_names.push(name.clone());
                }
                if st.is_defined() {
                    stats.insert(name.as_str(), st);
                }
            }
            let (mut fractions, mut cis, mut gains) = (
                g.fractions.clone(),
                g.fractions_ci95.clone(),
                g.fractions_gain.clone(),
            );
            for (set, &p) in g.active_sets.iter() {
                let name = format!("active_set_{set}");
                fractions.insert(name.clone(), p);
                if let Some(&ci) = g.active_sets_ci95.get(set) {
                    cis.insert(name.clone(), ci);
                }
                if let Some(&gain) = g.active_sets_gain.get(set) {
                    gains.insert(name, gain);
                }
            }
            for name in fractions.keys() {
                if !fraction_names.contains(name) {
                    fraction_names.push(name.clone());
                }
            }
            rows.push((stats, fractions, cis, gains));
            bounce_col.push(None);
        }
        // A drop scene's bounces: one row each, over the samples reaching it.
        let bounces = summary.drops.get(law).map(|d| d.bounces.as_slice());
        for b in bounces.into_iter().flatten() {
            law_col.push(law.clone());
            group_col.push("all".into());
            samples.push(b.reached);
            impacts.push(b.reached);
            bounce_col.push(Some(b.bounce as u32));
            let mut stats = std::collections::HashMap::new();
            for (name, st) in [
                ("energy_ratio", &b.energy_ratio),
                ("interval_seconds", &b.interval_seconds),
                ("speed_before", &b.speed_before),
            ] {
                if !stat_names.iter().any(|n| n == name) {
                    stat_names.push(name.into());
                }
                if st.is_defined() {
                    stats.insert(name, st);
                }
            }
            let (mut fractions, mut cis) = (Named::default(), Named::default());
            for (name, k) in [("energy_gain", b.energy_gain), ("degenerate", b.degenerate)] {
                let (p, ci) = proportion(k, b.reached);
                fractions.insert(name, p);
                cis.insert(name, ci);
            }
            rows.push((stats, fractions, cis, Named::default()));
        }
    }
    // Each row's paired differences: a law's `all` row (not a bounce's).
    let paired_at: Vec<Option<&Named<PointDifference>>> = law_col
        .iter()
        .zip(&group_col)
        .zip(&bounce_col)
        .map(|((law, group), bounce)| {
            let pp = summary.paired_points.as_ref()?;
            (group == "all" && bounce.is_none())
                .then(|| pp.laws.get(law))
                .flatten()
        })
        .collect();
    let height = rows.len();
    let mut cols = vec![
        Column::new("law".into(), law_col),
        Column::new("contact_set".into(), group_col),
    ];
    if !summary.drops.is_empty() {
        // Null on the first-impact rows.
        cols.push(Column::new("bounce".into(), bounce_col));
    }
    cols.extend([
        Column::new("samples".into(), samples),
        Column::new("impacts".into(), impacts),
    ]);
    // RQMC runs have gains; an MC run's table is as it was.
    let rqmc = summary.sampling.is_some();
    for name in &stat_names {
        for field in STAT_FIELDS.into_iter().filter(|f| rqmc || *f != "gain") {
            let col = format!("{name}_{field}");
            if field == "n" {
                let v: Vec<Option<u64>> = rows
                    .iter()
                    .map(|r| r.0.get(name.as_str()).map(|s| s.n))
                    .collect();
                cols.push(Column::new(col.into(), v));
                continue;
            }
            let v: Vec<Option<f64>> = rows
                .iter()
                .map(|r| {
                    r.0.get(name.as_str()).and_then(|s| match field {
                        "mean" => Some(s.mean),
                        "ci95" => Some(s.ci95),
                        "gain" => s.gain.filter(|g| g.is_finite()),
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
            .map(|r| r.1.get(name).copied().filter(|x| x.is_finite()))
            .collect();
        cols.push(Column::new(format!("fraction_{name}").into(), v));
        for (end, k) in [("low", 0), ("high", 1)] {
            let v: Vec<Option<f64>> = rows
                .iter()
                .map(|r| r.2.get(name).map(|ci| ci.0[k]).filter(|x| x.is_finite()))
                .collect();
            cols.push(Column::new(format!("fraction_{name}_{end}").into(), v));
        }
        if rqmc {
            let v: Vec<Option<f64>> = rows
                .iter()
                .map(|r| r.3.get(name).copied().filter(|x| x.is_finite()))
                .collect();
            cols.push(Column::new(format!("fraction_{name}_gain").into(), v));
        }
    }
    // A sweep point's paired differences against the reference point, on
    // each law's `all` row (of a drop: its first impact's).
    if let Some(pp) = &summary.paired_points {
        let at = &paired_at;
        let reference: Vec<Option<u32>> = at
            .iter()
            .map(|d| d.map(|_| pp.reference_point as u32))
            .collect();
        cols.push(Column::new("paired_reference_point".into(), reference));
        let mut names: Vec<&String> = Vec::new();
        for d in pp.laws.iter().flat_map(|(_, d)| d.keys()) {
            if !names.contains(&d) {
                names.push(d);
            }
        }
        for name in names {
            for field in ["difference", "ci95"] {
                let v: Vec<Option<f64>> = at
                    .iter()
                    .map(|d| {
                        let d = (*d)?.get(name)?;
                        let x = if field == "ci95" {
                            d.ci95
                        } else {
                            d.difference
                        };
                        x.is_finite().then_some(x)
                    })
                    .collect();
                cols.push(Column::new(format!("paired_{name}_{field}").into(), v));
            }
        }
    }
    DataFrame::new(height, cols)
}

/// The swept values of a grid point, `(path, value)` in axis order.
pub type PointValues = Vec<(String, f64)>;

/// A grid point's accumulators per law: (law name, touching plane names,
/// accumulators).
pub type LawAccs<'a> = Vec<(String, Vec<String>, &'a LawAcc)>;

/// The summary table of a study: `summary_frame_one` per grid point, with
/// `point` and the `sweep_*` columns in front.
pub fn summary_frame(points: &[(Vec<(String, f64)>, &Summary)]) -> Result<DataFrame, PolarsError> {
    stack_points(
        points.iter().enumerate().map(|(i, (values, summary))| {
            with_point_columns(summary_frame_one(summary)?, i, values)
        }),
    )
}

/// Stacks the frames of the grid points, in point order. Points may differ
/// in their columns (a sweep over friction from 0: only the points with
/// friction have its statistics): every frame gets the union of the
/// columns, in order of first appearance, nulls where it has none.
fn stack_points(
    frames: impl Iterator<Item = Result<DataFrame, PolarsError>>,
) -> Result<DataFrame, PolarsError> {
    let frames = frames.collect::<Result<Vec<_>, _>>()?;
    let mut columns: Vec<(PlSmallStr, DataType)> = Vec::new();
    for df in &frames {
        for c in df.columns() {
            if !columns.iter().any(|(n, _)| n == c.name()) {
                columns.push((c.name().clone(), c.dtype().clone()));
            }
        }
    }
    let mut out: Option<DataFrame> = None;
    for mut df in frames {
        for (name, dtype) in &columns {
            if df.column(name).is_err() {
                let nulls = Column::full_null(name.clone(), df.height(), dtype);
                df.with_column(nulls)?;
            }
        }
        let df = df.select(columns.iter().map(|(n, _)| n.clone()))?;
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
    if let Some((_, first)) = summary.laws.iter().next() {
        if let Some(all) = first.groups.get("all") {
            for name in all.stats.keys() {
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

/// One point's drop accumulators by law, and the smallest simultaneity
/// tolerance it resolves ([`crate::stats::drops::resolved`]).
pub type DropAccs<'a> = (Vec<(String, &'a crate::stats::drops::DropAcc)>, f64);

/// The tables of a drop study, each with `point` and the `sweep_*` columns
/// in front: `bounces.parquet` (law, bounce, reached, fraction_of_samples,
/// the energy ratio's mean, ci95 and sd, interval_seconds' mean and ci95,
/// speed_before's mean), `planes_hit.parquet` (law, bounce, planes, count,
/// fraction of the samples reaching the bounce), `simultaneity.parquet`
/// (law, bounce, tolerance, fraction of its impacts whose second-closest
/// plane was within it: null where the point does not resolve the
/// tolerance) and `sequences.parquet` (law, sequence of the
/// planes hit over the first impacts, count, fraction of samples).
pub fn drop_frames(
    points: &[(PointValues, DropAccs<'_>)],
    planes: &[String],
) -> PolarsResult<Vec<(&'static str, DataFrame)>> {
    use crate::output::summary::{active_set_name, sequence_name};
    // Bounce tables exist where bounce accumulators do (drop scenes).
    if points.iter().all(|(_, (laws, _))| laws.is_empty()) {
        return Ok(Vec::new());
    }
    use crate::stats::drops::{resolved, SIMULTANEITY_TOLERANCES};
    // One end of each row's interval, null where undefined.
    let ends = |name: &str, cis: &[Interval], k: usize| {
        let v: Vec<Option<f64>> = cis
            .iter()
            .map(|ci| Some(ci.0[k]).filter(|x| x.is_finite()))
            .collect();
        Column::new(name.into(), v)
    };
    let mut out: [Vec<DataFrame>; 4] = Default::default();
    for (i, (values, (laws, resolved_from))) in points.iter().enumerate() {
        let (mut law, mut bounce, mut reached, mut frac) = (vec![], vec![], vec![], vec![]);
        let mut cols: Vec<Vec<Option<f64>>> = vec![Vec::new(); 6];
        let (mut p_law, mut p_bounce, mut p_set, mut p_count, mut p_frac) =
            (vec![], vec![], vec![], vec![], vec![]);
        let (mut s_law, mut s_bounce, mut s_tol, mut s_frac) = (vec![], vec![], vec![], vec![]);
        let (mut q_law, mut q_seq, mut q_count, mut q_frac) = (vec![], vec![], vec![], vec![]);
        // Wilson's 95 % intervals of each table's fractions.
        let (mut p_ci, mut s_ci, mut q_ci) = (vec![], vec![], vec![]);
        for (l, a) in laws {
            for (k, b) in a.bounces.iter().enumerate() {
                law.push(l.clone());
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
                        p_law.push(l.clone());
                        p_bounce.push(k as u32 + 1);
                        p_set.push(active_set_name(mask, planes));
                        p_count.push(c);
                        p_frac.push(c as f64 / b.reached as f64);
                        p_ci.push(Interval::wilson(c, b.reached));
                    }
                }
                for (&tol, &c) in SIMULTANEITY_TOLERANCES.iter().zip(&b.within) {
                    s_law.push(l.clone());
                    s_bounce.push(k as u32 + 1);
                    s_tol.push(tol);
                    let on = b.reached > 0 && resolved(tol, *resolved_from);
                    s_frac.push(on.then(|| c as f64 / b.reached as f64));
                    s_ci.push(if on {
                        Interval::wilson(c, b.reached)
                    } else {
                        Interval([f64::NAN; 2])
                    });
                }
            }
            for (cell, &c) in a.sequences.iter().enumerate() {
                if c > 0 {
                    q_law.push(l.clone());
                    q_seq.push(sequence_name(&a.sequence_masks(cell), planes));
                    q_count.push(c);
                    q_frac.push(c as f64 / a.samples.max(1) as f64);
                    q_ci.push(Interval::wilson(c, a.samples));
                }
            }
        }
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
        let frames = [
            DataFrame::new(columns[0].len(), columns)?,
            DataFrame::new(
                p_law.len(),
                vec![
                    Column::new("law".into(), p_law),
                    Column::new("bounce".into(), p_bounce),
                    Column::new("planes".into(), p_set),
                    Column::new("count".into(), p_count),
                    Column::new("fraction".into(), p_frac),
                    ends("low", &p_ci, 0),
                    ends("high", &p_ci, 1),
                ],
            )?,
            DataFrame::new(
                s_law.len(),
                vec![
                    Column::new("law".into(), s_law),
                    Column::new("bounce".into(), s_bounce),
                    Column::new("tolerance".into(), s_tol),
                    Column::new("fraction".into(), s_frac),
                    ends("low", &s_ci, 0),
                    ends("high", &s_ci, 1),
                ],
            )?,
            DataFrame::new(
                q_law.len(),
                vec![
                    Column::new("law".into(), q_law),
                    Column::new("sequence".into(), q_seq),
                    Column::new("count".into(), q_count),
                    Column::new("fraction".into(), q_frac),
                    ends("low", &q_ci, 0),
                    ends("high", &q_ci, 1),
                ],
            )?,
        ];
        for (o, df) in out.iter_mut().zip(frames) {
            o.push(with_point_columns(df, i, values)?);
        }
    }
    let names = [
        "bounces.parquet",
        "planes_hit.parquet",
        "simultaneity.parquet",
        "sequences.parquet",
    ];
    let mut frames = out
        .into_iter()
        .map(|dfs| stack_points(dfs.into_iter().map(Ok)));
    let mut next = || frames.next().expect("four tables");
    Ok(vec![
        (names[0], next()?),
        (names[1], next()?),
        (names[2], next()?),
        (names[3], next()?),
    ])
}
