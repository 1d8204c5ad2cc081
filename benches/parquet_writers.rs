//! The per-sample file's library choice, measured: one row group of
//! `configs/corner3.toml`'s per-sample rows (Newton and paper, 2¹⁷ rows,
//! 47 columns, f32, as the engine makes them) encoded into memory on one
//! thread by polars' writer and by the arrow-rs writer, each with its codecs
//! (the file sizes are printed first). No disk: this is the encoding alone.
//!
//! `cargo bench --bench parquet_writers`

use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use arrow_array::{ArrayRef, Float32Array, RecordBatch, UInt16Array, UInt64Array};
use arrow_schema::{DataType, Field, Schema};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use impactmc::config::{load_scene, Overrides};
use impactmc::engine::{run_with_samples, RunOptions};
use impactmc::output::columns::RowLayout;
use impactmc::output::samples::{Floats, SampleRows};
use parquet::arrow::ArrowWriter;
use parquet::basic::{Compression, Encoding, ZstdLevel};
use parquet::file::properties::WriterProperties;
use parquet::schema::types::ColumnPath;
use polars::prelude::*;

const ROWS: u64 = 1 << 17;

/// The engine's rows, gathered into whole columns.
struct Rows {
    float_names: Vec<String>,
    floats: Vec<Vec<f32>>,
    int_names: Vec<String>,
    ints: Vec<Vec<u16>>,
    index: Vec<u64>,
}

fn rows() -> Rows {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/corner3.toml");
    let scene = load_scene(
        &path,
        &Overrides {
            samples: Some(ROWS),
            precision: Some("f32".parse().expect("f32")),
            ..Overrides::default()
        },
    )
    .expect("shipped scene");
    let mut got: Vec<SampleRows> = Vec::new();
    let mut sink = |r: SampleRows| -> Result<(), impactmc::engine::SinkError> {
        got.push(r);
        Ok(())
    };
    let opts = RunOptions {
        threads: 1,
        ..Default::default()
    };
    run_with_samples(&scene, &opts, Some(&mut sink)).expect("run");
    let RowLayout {
        floats: fnames,
        ints: inames,
        ..
    } = RowLayout::of(&scene);
    let mut floats = vec![Vec::new(); fnames.len()];
    let mut ints = vec![Vec::new(); inames.len()];
    let mut index = Vec::new();
    for r in got {
        index.extend(r.index);
        let Floats::F32(f) = r.floats else {
            panic!("an f32 run")
        };
        for (a, b) in floats.iter_mut().zip(f) {
            a.extend(b);
        }
        for (a, b) in ints.iter_mut().zip(r.ints) {
            a.extend(b);
        }
    }
    Rows {
        float_names: fnames.into_iter().map(|c| c.name).collect(),
        floats,
        int_names: inames.into_iter().map(|c| c.name).collect(),
        ints,
        index,
    }
}

fn writers(c: &mut Criterion) {
    let Rows {
        float_names: fnames,
        floats,
        int_names: inames,
        ints,
        index,
    } = rows();
    let mut g = c.benchmark_group("parquet_writers");
    g.throughput(Throughput::Elements(ROWS));
    g.sample_size(10)
        .measurement_time(Duration::from_secs(4))
        .warm_up_time(Duration::from_millis(500));

    // polars: its writer's own choices (dictionary, then plain).
    let mut cols = vec![Column::new("sample".into(), index.clone())];
    for (n, v) in fnames.iter().zip(&floats) {
        cols.push(Column::new(n.into(), v.clone()));
    }
    for (n, v) in inames.iter().zip(&ints) {
        let v: Vec<u32> = v.iter().map(|&x| x as u32).collect();
        cols.push(Column::new(n.into(), v));
    }
    let df = DataFrame::new(ROWS as usize, cols).expect("frame");
    for (name, codec) in [
        ("zstd", ParquetCompression::Zstd(None)),
        ("lz4", ParquetCompression::Lz4Raw),
        ("none", ParquetCompression::Uncompressed),
    ] {
        let write = || {
            let mut out = Vec::with_capacity(64 << 20);
            let mut df = df.clone();
            ParquetWriter::new(&mut out)
                .with_compression(codec)
                .set_parallel(false)
                .finish(&mut df)
                .expect("polars write");
            out.len()
        };
        eprintln!("polars/{name}: {} bytes", write());
        g.bench_function(BenchmarkId::new("polars", name), |b| b.iter(write));
    }

    // arrow-rs: byte-stream-split floats, delta samples, plain integers.
    let mut fields = vec![Field::new("sample", DataType::UInt64, false)];
    let mut arrays: Vec<ArrayRef> = vec![Arc::new(UInt64Array::from(index))];
    for (n, v) in fnames.iter().zip(floats) {
        fields.push(Field::new(n, DataType::Float32, false));
        arrays.push(Arc::new(Float32Array::from(v)));
    }
    for (n, v) in inames.iter().zip(ints) {
        fields.push(Field::new(n, DataType::UInt16, false));
        arrays.push(Arc::new(UInt16Array::from(v)));
    }
    let schema = Arc::new(Schema::new(fields));
    let batch = RecordBatch::try_new(schema.clone(), arrays).expect("batch");
    for (name, codec) in [
        ("zstd", Compression::ZSTD(ZstdLevel::default())),
        ("lz4", Compression::LZ4_RAW),
        ("none", Compression::UNCOMPRESSED),
    ] {
        let mut p = WriterProperties::builder().set_compression(codec);
        for f in schema.fields() {
            let path = ColumnPath::from(f.name().as_str());
            let e = match f.data_type() {
                DataType::Float32 => Encoding::BYTE_STREAM_SPLIT,
                DataType::UInt64 => Encoding::DELTA_BINARY_PACKED,
                _ => Encoding::PLAIN,
            };
            p = p
                .set_column_dictionary_enabled(path.clone(), false)
                .set_column_encoding(path, e);
        }
        let props = p.build();
        let write = || {
            let mut out = Vec::with_capacity(64 << 20);
            let mut w = ArrowWriter::try_new(&mut out, schema.clone(), Some(props.clone()))
                .expect("writer");
            w.write(&batch).expect("write");
            w.close().expect("close");
            out.len()
        };
        eprintln!("arrow-rs/{name}: {} bytes", write());
        g.bench_function(BenchmarkId::new("arrow-rs", name), |b| b.iter(write));
    }
    g.finish();
}

criterion_group!(benches, writers);
criterion_main!(benches);
