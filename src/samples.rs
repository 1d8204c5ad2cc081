//! `samples.parquet`: one row per sample, streamed in row groups of
//! [`ROW_GROUP`] rows (zstd) while the run goes on, so memory stays bounded
//! whatever the sample count.

use std::fs::File;

use polars::prelude::*;

use crate::engine::SampleRows;

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
