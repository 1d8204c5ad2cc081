//! `samples.parquet`: one row per sample, streamed in row groups of
//! [`ROW_GROUP`] rows (zstd) while the run goes on, so memory stays bounded
//! whatever the sample count.

use std::fs::File;

use glam::{DMat3, DQuat};
use polars::prelude::*;

use crate::config::Scene;
use crate::kernel::{Geometry, LawOut, ACTIVE_SHIFT};
use crate::lanes::Real;
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
        })
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
    pub floats: Vec<Vec<f64>>,
    pub ints: Vec<Vec<u32>>,
}

impl SampleRows {
    pub fn new(floats: usize, ints: usize) -> Self {
        Self {
            index: Vec::new(),
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
