//! Per-sample rows in memory, as Arrow: a run without an output folder
//! keeps its rows as record batches with the schema `samples.parquet`
//! would have ([`MemoryRows`]), and the Python package hands them out as
//! an [`ArrowTable`] (also read back from a file or a polars frame).

use std::path::Path;
use std::sync::Arc;

use arrow_array::{RecordBatch, RecordBatchReader, UInt32Array};
use arrow_schema::SchemaRef;
use parquet::errors::ParquetError;

use super::parquet::{arrays, schema_of, GridPoint};
use super::samples::{SampleRows, Selection};
/// Per-sample rows kept in memory as Arrow record batches, with the
/// columns and schema `samples.parquet` would have: a run without an
/// output folder. Each engine batch's rows become one record batch; the
/// columns are moved, not copied.
pub struct MemoryRows {
    selection: Selection,
    schema: SchemaRef,
    point: Option<GridPoint>,
    sweep: bool,
    batches: Vec<RecordBatch>,
}

impl MemoryRows {
    /// No rows yet, for the selected columns (`sweep`: the axes' paths,
    /// for the `point` key and the swept values' columns).
    pub fn new(selection: Selection, sweep: &[String]) -> Self {
        let schema = Arc::new(schema_of(&selection, sweep));
        Self {
            selection,
            schema,
            point: None,
            sweep: !sweep.is_empty(),
            batches: Vec::new(),
        }
    }

    /// Per float column of the scene, whether the rows keep it.
    pub fn float_mask(&self) -> &[bool] {
        self.selection.float_mask()
    }

    /// Sets the grid point of the following rows (a sweep).
    pub fn set_point(&mut self, point: Option<GridPoint>) {
        self.point = point;
    }

    /// Takes a batch of rows (in sample order).
    pub fn push(&mut self, rows: SampleRows) -> Result<(), arrow_schema::ArrowError> {
        if rows.is_empty() {
            return Ok(());
        }
        let point = self.sweep.then(|| {
            let (i, v) = self.point.as_ref().expect("a sweep sets its point");
            (*i, v.as_slice())
        });
        let columns = arrays(&self.selection, point, rows);
        self.batches
            .push(RecordBatch::try_new(self.schema.clone(), columns)?);
        Ok(())
    }

    /// The schema and every record batch, in sample order.
    pub fn finish(self) -> ArrowTable {
        ArrowTable {
            schema: self.schema,
            batches: self.batches,
        }
    }
}

/// A table in memory as Arrow record batches: per-sample rows (with
/// `samples.parquet`'s schema, in sample order) or a summary table.
#[derive(Debug, Clone)]
pub struct ArrowTable {
    /// The columns' names and types.
    pub schema: SchemaRef,
    /// The rows, batch by batch.
    pub batches: Vec<RecordBatch>,
}

impl ArrowTable {
    /// Rows in all batches.
    pub fn rows(&self) -> usize {
        self.batches.iter().map(|b| b.num_rows()).sum()
    }

    /// A polars table (the summary tables are built with polars) as Arrow
    /// record batches, through Parquet in memory: the columns, types and
    /// values its Parquet file holds.
    pub fn of_frame(df: &mut polars::prelude::DataFrame) -> Result<Self, ParquetError> {
        let mut buffer = Vec::new();
        polars::prelude::ParquetWriter::new(&mut buffer)
            .finish(df)
            .map_err(|e| ParquetError::External(Box::new(e)))?;
        Self::of_parquet(bytes::Bytes::from(buffer))
    }

    /// A Parquet file's rows (`samples.parquet` of a run folder).
    pub fn read(path: &Path) -> Result<Self, ParquetError> {
        let file = std::fs::File::open(path).map_err(|e| ParquetError::External(Box::new(e)))?;
        Self::of_parquet(file)
    }

    /// The rows of one grid point, by the `point` column (a table without
    /// one is a single point, 0): slices of the batches, not copies. The
    /// rows of a point need not be contiguous.
    pub fn point(&self, point: u32) -> Self {
        let mut batches = Vec::new();
        for b in &self.batches {
            let Some(col) = b.column_by_name("point") else {
                if point == 0 {
                    batches.push(b.clone());
                }
                continue;
            };
            let col = col
                .as_any()
                .downcast_ref::<UInt32Array>()
                .expect("point is UInt32");
            let mut start = None;
            for (i, &p) in col.values().iter().enumerate() {
                match (p == point, start) {
                    (true, None) => start = Some(i),
                    (false, Some(s)) => {
                        batches.push(b.slice(s, i - s));
                        start = None;
                    }
                    _ => {}
                }
            }
            if let Some(s) = start {
                batches.push(b.slice(s, b.num_rows() - s));
            }
        }
        Self {
            schema: self.schema.clone(),
            batches,
        }
    }

    /// Every row of Parquet data, as record batches.
    fn of_parquet<R: parquet::file::reader::ChunkReader + 'static>(
        data: R,
    ) -> Result<Self, ParquetError> {
        let reader = parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(data)?
            .build()?;
        let schema = reader.schema();
        let batches = reader
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| ParquetError::External(Box::new(e)))?;
        Ok(Self { schema, batches })
    }
}
