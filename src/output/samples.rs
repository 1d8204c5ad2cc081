//! `samples.parquet`: one row per sample (a drop scene: one row per sample,
//! law and impact), streamed in row groups of [`ROW_GROUP`] rows (zstd)
//! while the run goes on, so memory stays bounded whatever the sample count.

use std::fs::File;

use glam::{DMat3, DQuat};
use polars::prelude::*;

use crate::config::Scene;
use crate::kernel::{Geometry, LawOut, ACTIVE_SHIFT, DEGENERATE, ENERGY_GAIN, JAMMED, UNSOLVED};
use crate::lanes::Real;
use crate::physics::{ImpactOutcome, Motion};
use crate::sampler::Inputs;

/// Rows per Parquet row group.
pub const ROW_GROUP: usize = 1 << 18;

/// Which per-sample columns to write.
#[derive(Debug, Clone, PartialEq)]
pub struct Selection {
    /// All f64 column names and all u32 column names, in engine order.
    floats: Vec<String>,
    ints: Vec<String>,
    keep_float: Vec<bool>,
    keep_int: Vec<bool>,
    /// A drop scene's law names, for its `law` column.
    laws: Vec<String>,
}

impl Selection {
    /// `wanted = None` keeps every column; otherwise only the named ones
    /// (`sample`, the key, is always kept). Unknown names are an error that
    /// lists the available columns.
    pub fn new(
        floats: Vec<String>,
        ints: Vec<String>,
        wanted: Option<&[String]>,
    ) -> Result<Self, String> {
        let keep = |names: &[String]| -> Vec<bool> {
            names
                .iter()
                .map(|n| wanted.is_none_or(|w| w.iter().any(|x| x == n)))
                .collect()
        };
        if let Some(w) = wanted {
            for name in w {
                if name != "sample" && !floats.contains(name) && !ints.contains(name) {
                    let mut all = vec!["sample".to_string()];
                    all.extend(floats.iter().cloned());
                    all.extend(ints.iter().cloned());
                    return Err(format!(
                        "unknown per-sample column {name:?}; available: {}",
                        all.join(", ")
                    ));
                }
            }
        }
        Ok(Self {
            keep_float: keep(&floats),
            keep_int: keep(&ints),
            floats,
            ints,
            laws: Vec::new(),
        })
    }

    /// The per-sample selection of a scene: [`sample_columns`], and a drop
    /// scene's `law` column.
    pub fn of_scene(scene: &Scene, wanted: Option<&[String]>) -> Result<Self, String> {
        let (floats, ints) = sample_columns(scene);
        let drop = scene.drop_box().is_some();
        // `law`, like `sample`, is a key of a drop scene's rows: always kept.
        let wanted: Option<Vec<String>> = wanted.map(|w| {
            w.iter()
                .filter(|c| !(drop && *c == "law"))
                .cloned()
                .collect()
        });
        let mut s = Self::new(floats, ints, wanted.as_deref())?;
        if drop {
            s.laws = scene.laws().iter().map(|l| l.name()).collect();
        }
        Ok(s)
    }
}

/// Streams rows into a Parquet file.
pub struct SamplesWriter {
    file: Option<File>,
    writer: Option<BatchedWriter<File>>,
    buffer: SampleRows,
    selection: Selection,
    /// Grid point of a sweep, written as a `point` column.
    point: Option<u32>,
    pub rows_written: u64,
}

impl SamplesWriter {
    pub fn new(file: File, selection: Selection) -> Self {
        Self {
            file: Some(file),
            writer: None,
            buffer: SampleRows::default(),
            selection,
            point: None,
            rows_written: 0,
        }
    }

    /// Sets the grid point written with the following rows.
    pub fn set_point(&mut self, point: Option<u32>) -> PolarsResult<()> {
        self.flush()?;
        self.point = point;
        Ok(())
    }

    pub fn push(&mut self, rows: SampleRows) -> PolarsResult<()> {
        if self.buffer.floats.is_empty() && self.buffer.ints.is_empty() {
            self.buffer = rows;
        } else {
            self.buffer.append(&rows);
        }
        if self.buffer.len() >= ROW_GROUP {
            self.flush()?;
        }
        Ok(())
    }

    fn frame(&mut self) -> PolarsResult<DataFrame> {
        let b = std::mem::take(&mut self.buffer);
        let n = b.index.len();
        let mut cols = Vec::new();
        if let Some(p) = self.point {
            cols.push(Column::new("point".into(), vec![p; n]));
        }
        cols.push(Column::new("sample".into(), b.index));
        if !self.selection.laws.is_empty() {
            let names = &self.selection.laws;
            let law: Vec<&str> = b.law.iter().map(|&l| names[l as usize].as_str()).collect();
            cols.push(Column::new("law".into(), law));
        }
        for ((name, keep), v) in self
            .selection
            .floats
            .iter()
            .zip(&self.selection.keep_float)
            .zip(b.floats)
        {
            if *keep {
                cols.push(Column::new(name.into(), v));
            }
        }
        for ((name, keep), v) in self
            .selection
            .ints
            .iter()
            .zip(&self.selection.keep_int)
            .zip(b.ints)
        {
            if *keep {
                cols.push(Column::new(name.into(), v));
            }
        }
        DataFrame::new(n, cols)
    }

    fn flush(&mut self) -> PolarsResult<()> {
        if self.buffer.is_empty() {
            return Ok(());
        }
        let df = self.frame()?;
        if self.writer.is_none() {
            let file = self.file.take().expect("file until the first row group");
            self.writer = Some(
                ParquetWriter::new(file)
                    // Encoding, not compression, dominates the cost here:
                    // uncompressed is only about 20 % faster.
                    .with_compression(ParquetCompression::Zstd(None))
                    .batched(df.schema())?,
            );
        }
        self.writer.as_mut().expect("writer").write_batch(&df)?;
        self.rows_written += df.height() as u64;
        Ok(())
    }

    /// Writes the last rows and the footer.
    pub fn finish(mut self) -> PolarsResult<u64> {
        self.flush()?;
        if let Some(w) = self.writer.take() {
            w.finish()?;
        }
        Ok(self.rows_written)
    }
}

/// Per-sample rows of one batch, column-major, in sample order (the columns
/// of [`sample_columns`]).
#[derive(Debug, Clone, Default)]
pub struct SampleRows {
    pub index: Vec<u64>,
    /// A drop scene's law per row (index into the scene's laws); empty for
    /// a contact scene.
    pub law: Vec<u32>,
    pub floats: Vec<Vec<f64>>,
    pub ints: Vec<Vec<u32>>,
}

impl SampleRows {
    pub fn new(floats: usize, ints: usize) -> Self {
        Self {
            index: Vec::new(),
            law: Vec::new(),
            floats: vec![Vec::new(); floats],
            ints: vec![Vec::new(); ints],
        }
    }

    pub fn len(&self) -> usize {
        self.index.len()
    }

    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }

    /// Appends `other`'s rows.
    pub fn append(&mut self, other: &SampleRows) {
        self.index.extend_from_slice(&other.index);
        self.law.extend_from_slice(&other.law);
        for (a, b) in self.floats.iter_mut().zip(&other.floats) {
            a.extend_from_slice(b);
        }
        for (a, b) in self.ints.iter_mut().zip(&other.ints) {
            a.extend_from_slice(b);
        }
    }
}

/// Names of the per-sample columns after `sample` (u64): the f64 columns,
/// then the u32 columns. Units: m/s, rad/s, J, N·s; `active_LAW` is the
/// active-set bitmask over the touching planes in scene order, `flags_LAW`
/// the kernel status bits (see README).
pub fn sample_columns(scene: &Scene) -> (Vec<String>, Vec<String>) {
    if scene.drop_box().is_some() {
        return drop_columns(scene);
    }
    let planes: Vec<&str> = scene
        .touching()
        .iter()
        .map(|&i| scene.planes()[i].name.as_str())
        .collect();
    let mut f: Vec<String> = [
        "q_w",
        "q_x",
        "q_y",
        "q_z",
        "v_x",
        "v_y",
        "v_z",
        "omega_x",
        "omega_y",
        "omega_z",
        "energy_before",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    f.extend(planes.iter().map(|p| format!("vn_before_{p}")));
    let mut ints = Vec::new();
    for law in scene.laws() {
        let l = law.name();
        f.push(format!("energy_after_{l}"));
        f.push(format!("energy_ratio_{l}"));
        for c in ["x", "y", "z"] {
            f.push(format!("v_after_{c}_{l}"));
        }
        for c in ["x", "y", "z"] {
            f.push(format!("omega_after_{c}_{l}"));
        }
        f.extend(planes.iter().map(|p| format!("impulse_{l}_{p}")));
        f.extend(planes.iter().map(|p| format!("vn_after_{l}_{p}")));
        ints.push(format!("active_{l}"));
        ints.push(format!("flags_{l}"));
    }
    (f, ints)
}

/// Appends a block's rows (after recomputation) in the order of
/// [`sample_columns`].
pub fn push_rows<T: Real, const N: usize>(
    x: &Inputs<T>,
    geo: &Geometry<T, N>,
    outs: &[Box<LawOut<T, N>>],
    first: u64,
    count: usize,
    rows: &mut SampleRows,
) {
    for s in 0..count {
        rows.index.push(first + s as u64);
        let a = DMat3::from_cols_array(&std::array::from_fn(|k| x.a[k][s].to_f64())).transpose();
        let q = DQuat::from_mat3(&a);
        let q = if q.w < 0.0 { -q } else { q };
        let mut f = rows.floats.iter_mut();
        let mut put = |v: f64| f.next().expect("column count").push(v);
        for v in [q.w, q.x, q.y, q.z] {
            put(v);
        }
        for k in 0..3 {
            put(x.v[k][s].to_f64());
        }
        for k in 0..3 {
            put(x.w[k][s].to_f64());
        }
        let t0 = geo.t_before[s].to_f64();
        put(t0);
        for i in 0..N {
            put(geo.vn[i][s].to_f64());
        }
        for out in outs {
            let t1 = out.t_after[s].to_f64();
            put(t1);
            put(t1 / t0);
            for k in 0..3 {
                put(out.v_after[k][s].to_f64());
            }
            for k in 0..3 {
                put(out.w_after[k][s].to_f64());
            }
            for i in 0..N {
                put(out.lambda[i][s].to_f64());
            }
            for i in 0..N {
                put(out.vn_after[i][s].to_f64());
            }
        }
        let mut ints = rows.ints.iter_mut();
        for out in outs {
            let st = out.status[s];
            ints.next()
                .expect("column count")
                .push((st >> ACTIVE_SHIFT) & ((1 << N) - 1));
            ints.next().expect("column count").push(st);
        }
    }
}

/// A drop scene's per-impact columns after `sample` (u64) and `law` (str):
/// the f64 columns, then the u32 columns. At the moment of impact: `time`
/// since release and `interval` since the previous impact (s), the centre
/// (m), the orientation (unit quaternion body → world, w ≥ 0), v (world,
/// m/s) and ω (body, rad/s) before and after, the energies (J), and per
/// plane its distance (m), normal velocity before and after (m/s) and
/// impulse (N·s). `bounce` counts impacts from 1, `planes` is the bitmask of
/// the planes that took an impulse (scene order), `flags` the kernel's
/// status bits for energy_gain, degenerate, jammed and unsolved.
pub fn drop_columns(scene: &Scene) -> (Vec<String>, Vec<String>) {
    let mut f: Vec<String> = [
        "time",
        "interval",
        "centre_x",
        "centre_y",
        "centre_z",
        "q_w",
        "q_x",
        "q_y",
        "q_z",
        "v_x",
        "v_y",
        "v_z",
        "omega_x",
        "omega_y",
        "omega_z",
        "energy_before",
        "energy_after",
        "energy_ratio",
        "v_after_x",
        "v_after_y",
        "v_after_z",
        "omega_after_x",
        "omega_after_y",
        "omega_after_z",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    for p in scene.planes() {
        for c in ["distance", "vn_before", "vn_after", "impulse"] {
            f.push(format!("{c}_{}", p.name));
        }
    }
    let ints = ["bounce", "planes", "flags"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    (f, ints)
}

/// One impact of a drop sample, as [`SampleRows::push_drop`] writes it.
pub struct DropRow<'a> {
    pub sample: u64,
    pub law: u32,
    pub bounce: u32,
    pub planes: u32,
    pub time: f64,
    pub interval: f64,
    /// At the moment of impact, before it.
    pub motion: &'a Motion,
    pub outcome: &'a ImpactOutcome,
    pub distances: &'a [f64],
}

impl SampleRows {
    /// Appends one impact in the order of [`drop_columns`].
    pub fn push_drop(&mut self, r: &DropRow) {
        self.index.push(r.sample);
        self.law.push(r.law);
        let m = r.motion;
        let o = r.outcome;
        let q = DQuat::from_mat3(&m.rotation);
        let q = if q.w < 0.0 { -q } else { q };
        let mut f = self.floats.iter_mut();
        let mut put = |v: f64| f.next().expect("column count").push(v);
        for v in [r.time, r.interval] {
            put(v);
        }
        for v in m.centre.to_array() {
            put(v);
        }
        for v in [q.w, q.x, q.y, q.z] {
            put(v);
        }
        for v in m.velocity.to_array().into_iter().chain(m.omega.to_array()) {
            put(v);
        }
        for v in [
            o.energy_before,
            o.energy_after,
            o.energy_after / o.energy_before,
        ] {
            put(v);
        }
        for v in o
            .after
            .velocity
            .to_array()
            .into_iter()
            .chain(o.after.omega.to_array())
        {
            put(v);
        }
        for (c, &d) in o.contacts.iter().zip(r.distances) {
            for v in [
                d,
                c.normal_velocity_before,
                c.normal_velocity_after,
                c.impulse,
            ] {
                put(v);
            }
        }
        let flags = [
            (o.flags.energy_gain, ENERGY_GAIN),
            (o.flags.degenerate, DEGENERATE),
            (o.flags.jammed, JAMMED),
            (o.flags.unsolved, UNSOLVED),
        ]
        .iter()
        .fold(0, |s, &(on, bit)| if on { s | bit } else { s });
        for (col, v) in self.ints.iter_mut().zip([r.bounce, r.planes, flags]) {
            col.push(v);
        }
    }
}
