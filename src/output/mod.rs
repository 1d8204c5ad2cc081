//! Run outputs: one folder per run, every file written under a temporary
//! name and renamed when complete, so a file is either whole or absent
//! (cryo's export pattern). The manifest is built in one place for every
//! kind of run; summaries are typed; per-sample rows stream to Parquet.

pub mod arrow;
pub mod columns;
mod direct;
pub mod manifest;
pub mod named;
pub mod paired;
pub mod parquet;
pub mod plots;
mod replicated;
pub mod samples;
pub mod shard;
mod staging;
mod stat_summary;
pub mod summary;
mod tables;
mod text;

pub use staging::{prepare_dir, OutputError, Staging};
pub use tables::{
    drop_frames, histograms_frame, schema_metadata, summary_frame, sweep_column, table_metadata,
    write_parquet, DropAccs, LawAccs, PointValues,
};
