//! `samples.parquet`, written at the speed of the disk: rows are gathered
//! into row groups of [`ROW_GROUP`] rows; each row group's columns are
//! encoded in parallel on a pool of their own (one thread per run thread)
//! while the run goes on, and one writer thread appends the encoded row
//! groups to the file in order. Encoding is per column and the order is
//! fixed, so the file is the same byte for byte whatever the thread count;
//! at most [`IN_FLIGHT_PER_THREAD`] row groups per thread are held at once,
//! so memory stays bounded whatever the sample count.
//!
//! Float columns are written at the run's precision with the
//! `BYTE_STREAM_SPLIT` encoding (the bytes of each position together, which
//! a fast codec compresses well), `sample` delta-encoded, the small integer
//! columns plain, and `point` and `law` dictionary-encoded. Statistics are kept
//! per row group and page, so readers can prune on `sample`, `bounce` and
//! the like. The file is written around the page cache where it can be
//! (`DirectFile`).
//!
//! The arrow-rs writer is used rather than polars': it offers
//! `BYTE_STREAM_SPLIT` (files 10 % smaller at LZ4 for the same encoding
//! speed) and hands out column writers per row group, so row groups encode
//! on other threads while one thread writes; polars' batched writer encodes
//! and writes in the calling thread (docs/performance.md has the
//! measurements).

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::mpsc;
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;

use arrow_array::{
    ArrayRef, BooleanArray, Float32Array, Float64Array, StringArray, UInt16Array, UInt32Array,
    UInt64Array, UInt8Array,
};
use arrow_schema::{DataType, Field, Schema, SchemaRef};
use parquet::arrow::arrow_writer::{compute_leaves, ArrowColumnChunk, ArrowRowGroupWriterFactory};
use parquet::arrow::ArrowSchemaConverter;
use parquet::basic::{Compression as Codec, Encoding, ZstdLevel};
use parquet::errors::ParquetError;
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;
use parquet::file::writer::SerializedFileWriter;
use parquet::schema::types::ColumnPath;
use rayon::prelude::*;

use super::columns::Kind;
use super::direct::DirectFile;
use super::samples::{Floats, SampleRows, Selection};
use crate::config::Precision;

/// Rows per Parquet row group.
pub const ROW_GROUP: usize = 1 << 17;

/// Row groups held (being encoded or written) per encoding thread.
pub const IN_FLIGHT_PER_THREAD: usize = 2;

/// Bytes written between two syncs of a file written through the page
/// cache. Without them the kernel would hold the whole file in its cache
/// and write it only at the final sync, after the encoding, instead of
/// during it.
const SYNC_EVERY: usize = 64 << 20;

/// The codec of `samples.parquet` (`[output] compression` and `level`).
/// Every reader we test (pyarrow, DuckDB, polars) reads all three.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Compression {
    /// Zstandard at a level in 1..=22.
    Zstd {
        level: i32,
    },
    /// LZ4 (Parquet's LZ4_RAW).
    Lz4,
    None,
}

impl Compression {
    /// The default, chosen by measurement (docs/performance.md): it keeps
    /// up with the disk on two cores, and its files are about 5 % larger
    /// than zstd's at level 1.
    pub const DEFAULT: Compression = Compression::Lz4;

    /// From the scene's `compression` name and `level`. An error names the
    /// field and the value.
    pub fn new(name: Option<&str>, level: Option<i32>) -> Result<Self, (&'static str, String)> {
        let c = match name {
            None => Self::DEFAULT,
            Some("zstd") => {
                let level = level.unwrap_or(1);
                if !(1..=22).contains(&level) {
                    return Err(("level", format!("zstd levels are 1..=22, got {level}")));
                }
                return Ok(Compression::Zstd { level });
            }
            Some("lz4") => Compression::Lz4,
            Some("none") => Compression::None,
            Some(other) => {
                return Err((
                    "compression",
                    format!("{other:?} is not one of \"lz4\", \"zstd\", \"none\""),
                ))
            }
        };
        match level {
            Some(l) => Err((
                "level",
                format!("a level applies to zstd only, got {l} with {}", c.name()),
            )),
            None => Ok(c),
        }
    }

    /// "zstd", "lz4" or "none".
    pub fn name(self) -> &'static str {
        match self {
            Compression::Zstd { .. } => "zstd",
            Compression::Lz4 => "lz4",
            Compression::None => "none",
        }
    }

    /// The zstd level (none for the other codecs).
    pub fn level(self) -> Option<i32> {
        match self {
            Compression::Zstd { level } => Some(level),
            _ => None,
        }
    }

    fn codec(self) -> Codec {
        match self {
            Compression::Zstd { level } => {
                Codec::ZSTD(ZstdLevel::try_new(level).expect("level checked by Compression::new"))
            }
            Compression::Lz4 => Codec::LZ4_RAW,
            Compression::None => Codec::UNCOMPRESSED,
        }
    }
}

/// How `samples.parquet` is written.
#[derive(Debug, Clone)]
pub struct WriteOptions {
    pub compression: Compression,
    /// Encoding threads (at least one).
    pub threads: usize,
    /// A sweep's axes (their paths; empty without a sweep): rows carry
    /// their grid point in a `point` column and each axis's value in a
    /// `sweep_PATH` column ([`crate::output::sweep_column`]).
    pub sweep: Vec<String>,
}

/// A sweep's grid point: its index and its values, one per axis.
pub type GridPoint = (u32, Vec<f64>);

/// The float columns' encoding.
pub const FLOAT_ENCODING: &str = "BYTE_STREAM_SPLIT";

type Encoded = Result<Vec<ArrowColumnChunk>, ParquetError>;

/// Row groups submitted and not yet written, and whether writing failed.
#[derive(Default)]
struct Slots {
    state: Mutex<(usize, bool)>,
    changed: Condvar,
}

impl Slots {
    /// Waits for a free slot and takes it; false if writing failed.
    fn take(&self, most: usize) -> bool {
        let mut s = self.state.lock().expect("slots");
        while s.0 >= most && !s.1 {
            s = self.changed.wait(s).expect("slots");
        }
        s.0 += 1;
        !s.1
    }

    fn give(&self, failed: bool) {
        let mut s = self.state.lock().expect("slots");
        s.0 -= 1;
        s.1 |= failed;
        self.changed.notify_all();
    }
}

/// Streams per-sample rows into `samples.parquet`.
pub struct SamplesWriter {
    selection: Arc<Selection>,
    schema: SchemaRef,
    factory: Arc<ArrowRowGroupWriterFactory>,
    /// Batches of the row group being filled, and their rows.
    buffer: Vec<SampleRows>,
    buffered: usize,
    point: Option<GridPoint>,
    sweep: bool,
    encoders: rayon::ThreadPool,
    in_flight: usize,
    slots: Arc<Slots>,
    encoded: Option<mpsc::Sender<(usize, Encoded)>>,
    writer: Option<JoinHandle<Result<(), ParquetError>>>,
    groups: usize,
    rows: u64,
}

impl SamplesWriter {
    /// Writes to `path` (an existing, empty file).
    pub fn new(
        path: &Path,
        selection: Selection,
        opts: WriteOptions,
    ) -> Result<Self, ParquetError> {
        let schema = Arc::new(schema_of(&selection, &opts.sweep));
        let props = Arc::new(properties(&schema, &selection, opts.compression));
        let parquet = ArrowSchemaConverter::new()
            .with_coerce_types(props.coerce_types())
            .convert(&schema)?;
        let out =
            SerializedFileWriter::new(DirectFile::open(path)?, parquet.root_schema_ptr(), props)?;
        let factory = Arc::new(ArrowRowGroupWriterFactory::new(&out, schema.clone()));
        let threads = opts.threads.max(1);
        let encoders = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .thread_name(|i| format!("impactmc-parquet-{i}"))
            .build()
            .map_err(|e| ParquetError::External(Box::new(e)))?;
        let slots = Arc::new(Slots::default());
        let (tx, rx) = mpsc::channel();
        let writer = {
            let slots = slots.clone();
            std::thread::Builder::new()
                .name("impactmc-parquet-writer".into())
                .spawn(move || write_in_order(out, rx, &slots))
                .map_err(|e| ParquetError::External(Box::new(e)))?
        };
        Ok(Self {
            selection: Arc::new(selection),
            schema,
            factory,
            buffer: Vec::new(),
            buffered: 0,
            point: None,
            sweep: !opts.sweep.is_empty(),
            encoders,
            in_flight: IN_FLIGHT_PER_THREAD * threads,
            slots,
            encoded: Some(tx),
            writer: Some(writer),
            groups: 0,
            rows: 0,
        })
    }

    /// Per float column of the scene, whether the file keeps it.
    pub fn float_mask(&self) -> &[bool] {
        self.selection.float_mask()
    }

    /// Sets the grid point written with the following rows (a sweep).
    pub fn set_point(&mut self, point: Option<GridPoint>) -> Result<(), ParquetError> {
        self.flush()?;
        self.point = point;
        Ok(())
    }

    /// Takes a batch of rows (in sample order).
    pub fn push(&mut self, rows: SampleRows) -> Result<(), ParquetError> {
        self.buffered += rows.len();
        self.buffer.push(rows);
        if self.buffered >= ROW_GROUP {
            self.flush()?;
        }
        Ok(())
    }

    /// Hands the buffered batches to the encoders as one row group (each
    /// column written batch by batch: nothing is copied into one buffer).
    fn flush(&mut self) -> Result<(), ParquetError> {
        let batches = std::mem::take(&mut self.buffer);
        let rows = std::mem::take(&mut self.buffered);
        if rows == 0 {
            return Ok(());
        }
        if !self.slots.take(self.in_flight) {
            self.slots.give(false);
            return Err(self.failure());
        }
        self.rows += rows as u64;
        let index = self.groups;
        let (factory, schema) = (self.factory.clone(), self.schema.clone());
        let selection = self.selection.clone();
        let point = self
            .sweep
            .then(|| self.point.clone().expect("a sweep sets its point"));
        let tx = self.encoded.clone().expect("open until finish");
        self.encoders.spawn(move || {
            let point = point.as_ref().map(|(i, v)| (*i, v.as_slice()));
            let columns = transpose(
                batches
                    .into_iter()
                    .map(|b| arrays(&selection, point, b))
                    .collect(),
            );
            let _ = tx.send((index, encode(&factory, &schema, index, columns)));
        });
        self.groups += 1;
        Ok(())
    }

    /// The writer thread's error (it stopped writing).
    fn failure(&mut self) -> ParquetError {
        self.encoded = None;
        match self.writer.take().map(|w| w.join()) {
            Some(Ok(Err(e))) => e,
            Some(Err(_)) => ParquetError::General("the Parquet writer thread panicked".into()),
            _ => ParquetError::General("the Parquet writer stopped".into()),
        }
    }

    /// Writes the last rows, waits for every row group, writes the footer
    /// and syncs the file. Returns the rows written.
    pub fn finish(mut self) -> Result<u64, ParquetError> {
        self.flush()?;
        // The writer thread ends when every encoding job has sent its row
        // group and this last sender is gone.
        self.encoded = None;
        match self.writer.take().expect("finished once").join() {
            Ok(r) => r?,
            Err(_) => {
                return Err(ParquetError::General(
                    "the Parquet writer thread panicked".into(),
                ))
            }
        }
        Ok(self.rows)
    }
}

/// A batch's selected columns, in the schema's order (`point` and the
/// swept values for a sweep).
pub(super) fn arrays(
    selection: &Selection,
    point: Option<(u32, &[f64])>,
    mut b: SampleRows,
) -> Vec<ArrayRef> {
    let n = b.len();
    let mut cols: Vec<ArrayRef> = Vec::new();
    if let Some((p, values)) = point {
        cols.push(Arc::new(UInt32Array::from(vec![p; n])));
        for &x in values {
            cols.push(Arc::new(Float64Array::from(vec![x; n])));
        }
    }
    if let Some(log2) = selection.replicate_log2() {
        cols.push(Arc::new(UInt32Array::from_iter_values(
            b.index.iter().map(|&i| (i >> log2) as u32),
        )));
    }
    cols.push(Arc::new(UInt64Array::from(std::mem::take(&mut b.index))));
    let laws = selection.laws();
    if !laws.is_empty() {
        cols.push(Arc::new(StringArray::from_iter_values(
            b.law.iter().map(|&l| laws[l as usize].as_str()),
        )));
    }
    for (i, _) in selection.floats() {
        cols.push(match &mut b.floats {
            Floats::F32(c) => Arc::new(Float32Array::from(std::mem::take(&mut c[i]))),
            Floats::F64(c) => Arc::new(Float64Array::from(std::mem::take(&mut c[i]))),
        });
    }
    for (i, c) in selection.ints() {
        let v = std::mem::take(&mut b.ints[i]);
        cols.push(match c.kind {
            Kind::U8 => Arc::new(UInt8Array::from_iter_values(v.iter().map(|&x| x as u8))),
            Kind::U16 => Arc::new(UInt16Array::from(v)),
            Kind::Bool => Arc::new(BooleanArray::from_iter(v.iter().map(|&x| Some(x != 0)))),
            Kind::Float => unreachable!("an integer column"),
        });
    }
    cols
}

/// Per batch, per column → per column, per batch.
fn transpose(batches: Vec<Vec<ArrayRef>>) -> Vec<Vec<ArrayRef>> {
    let mut columns: Vec<Vec<ArrayRef>> = Vec::new();
    for batch in batches {
        columns.resize_with(batch.len(), Vec::new);
        for (c, a) in columns.iter_mut().zip(batch) {
            c.push(a);
        }
    }
    columns
}

/// Encodes a row group's columns in parallel.
fn encode(
    factory: &ArrowRowGroupWriterFactory,
    schema: &Schema,
    index: usize,
    columns: Vec<Vec<ArrayRef>>,
) -> Encoded {
    let writers = factory.create_column_writers(index)?;
    writers
        .into_par_iter()
        .zip(columns)
        .zip(schema.fields().to_vec())
        .map(|((mut w, parts), field)| {
            for array in &parts {
                for leaf in compute_leaves(&field, array)? {
                    w.write(&leaf)?;
                }
            }
            w.close()
        })
        .collect()
}

/// The writer thread: appends encoded row groups in index order, then the
/// footer, and syncs the file. After an error it keeps taking row groups
/// (and freeing their slots) without writing them, so nothing waits on it.
fn write_in_order(
    mut out: SerializedFileWriter<DirectFile>,
    encoded: mpsc::Receiver<(usize, Encoded)>,
    slots: &Slots,
) -> Result<(), ParquetError> {
    let mut pending = BTreeMap::new();
    let mut next = 0;
    let mut failure = None;
    let mut synced = 0;
    for (index, group) in encoded {
        pending.insert(index, group);
        while let Some(group) = pending.remove(&next) {
            next += 1;
            if failure.is_none() {
                let written = group.and_then(|chunks| {
                    let mut rg = out.next_row_group()?;
                    for chunk in chunks {
                        chunk.append_to_row_group(&mut rg)?;
                    }
                    rg.close()?;
                    // Through the page cache, the disk writes while the next
                    // row groups are encoded, not all at the end.
                    if !out.inner_mut().is_direct() && out.bytes_written() - synced >= SYNC_EVERY {
                        synced = out.bytes_written();
                        out.inner_mut().sync_written()?;
                    }
                    Ok(())
                });
                failure = written.err();
            }
            slots.give(failure.is_some());
        }
    }
    if let Some(e) = failure {
        return Err(e);
    }
    out.into_inner()?.finish()?;
    Ok(())
}

/// The Arrow schema of the selected columns.
pub(super) fn schema_of(selection: &Selection, sweep: &[String]) -> Schema {
    let mut fields = Vec::new();
    if !sweep.is_empty() {
        fields.push(Field::new("point", DataType::UInt32, false));
        for path in sweep {
            fields.push(Field::new(
                crate::output::sweep_column(path),
                DataType::Float64,
                false,
            ));
        }
    }
    if selection.replicate_log2().is_some() {
        fields.push(Field::new("replicate", DataType::UInt32, false));
    }
    fields.push(Field::new("sample", DataType::UInt64, false));
    if !selection.laws().is_empty() {
        fields.push(Field::new("law", DataType::Utf8, false));
    }
    let float = match selection.precision() {
        Precision::F32 => DataType::Float32,
        Precision::F64 => DataType::Float64,
    };
    for (_, c) in selection.floats() {
        fields.push(Field::new(&c.name, float.clone(), false));
    }
    for (_, c) in selection.ints() {
        let t = match c.kind {
            Kind::U8 => DataType::UInt8,
            Kind::U16 => DataType::UInt16,
            Kind::Bool => DataType::Boolean,
            Kind::Float => unreachable!("an integer column"),
        };
        fields.push(Field::new(&c.name, t, false));
    }
    Schema::new(fields)
}

/// Writer properties: the codec, per column its encoding, and key-value
/// metadata: the schema version and the float columns' units.
fn properties(
    schema: &Schema,
    selection: &Selection,
    compression: Compression,
) -> WriterProperties {
    let units: serde_json::Map<String, serde_json::Value> = selection
        .floats()
        .map(|(_, c)| (c.name.clone(), c.unit.into()))
        .collect();
    let mut b = WriterProperties::builder()
        .set_compression(compression.codec())
        .set_created_by(format!("impactmc {}", env!("CARGO_PKG_VERSION")))
        .set_key_value_metadata(Some(vec![
            KeyValue::new(
                "impactmc.schema_version".into(),
                crate::SCHEMA_VERSION.to_string(),
            ),
            KeyValue::new(
                "impactmc.units".into(),
                serde_json::Value::Object(units).to_string(),
            ),
        ]));
    for f in schema.fields() {
        // A swept value is one number per grid point: the dictionary.
        if f.name().starts_with("sweep_") {
            continue;
        }
        let path = ColumnPath::from(f.name().as_str());
        let encoding = match f.data_type() {
            DataType::Float32 | DataType::Float64 => Encoding::BYTE_STREAM_SPLIT,
            // Consecutive sample numbers: deltas of 1 pack to almost nothing.
            DataType::UInt64 => Encoding::DELTA_BINARY_PACKED,
            // Bit sets and counts: plain, left to the codec. A dictionary
            // made the files 1.5 % smaller and cost 12 % more CPU.
            DataType::UInt8 | DataType::UInt16 | DataType::Boolean => Encoding::PLAIN,
            // `point` (one value per row group) and `law` (a few names):
            // the dictionary (RLE) encoding.
            _ => continue,
        };
        b = b
            .set_column_dictionary_enabled(path.clone(), false)
            .set_column_encoding(path, encoding);
    }
    b.build()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::columns::{Column, Field, RowLayout};

    fn layout() -> RowLayout {
        let column = |name: &str, kind, field| Column {
            name: name.into(),
            kind,
            unit: "",
            field,
        };
        RowLayout {
            floats: vec![
                column("a", Kind::Float, Field::Time),
                column("b", Kind::Float, Field::Interval),
            ],
            ints: vec![column("flags", Kind::U16, Field::Bounce)],
            precision: Precision::F32,
            laws: Vec::new(),
        }
    }

    fn selection() -> Selection {
        let l = layout();
        Selection::new(l.floats, l.ints, Precision::F32, None).unwrap()
    }

    fn rows(first: u64, n: usize) -> SampleRows {
        let mut r = SampleRows::of_layout(&layout());
        r.index.extend(first..first + n as u64);
        r.push_test_columns(n);
        r
    }

    /// A disk that fills up mid-file (`/dev/full`) is an error from the
    /// writer, reported by `push` or `finish`, not a hang or a panic.
    #[test]
    fn a_full_disk_is_an_error_not_a_hang() {
        let full = Path::new("/dev/full");
        if !full.exists() {
            return;
        }
        let opts = WriteOptions {
            compression: Compression::None,
            threads: 2,
            sweep: Vec::new(),
        };
        let run = || -> Result<u64, ParquetError> {
            let mut w = SamplesWriter::new(full, selection(), opts)?;
            for b in 0..40 {
                w.push(rows(b * 65_536, 65_536))?;
            }
            w.finish()
        };
        let err = run().expect_err("written to a full disk");
        assert!(err.to_string().contains("No space left"), "{err}");
    }
}
