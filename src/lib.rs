//! impactmc: Monte Carlo statistics of frictionless impacts of a rigid
//! ellipsoid on one or several planes.
//!
//! Data flows one way: config → scene → sampler → kernel → statistics →
//! output. [`physics`] is the pure f64 reference every fast path is tested
//! against.

#![deny(unsafe_code)]

pub mod accuracy;
pub mod case;
pub mod config;
pub mod drop;
pub mod engine;
pub mod kernel;
pub mod lanes;
pub mod manifest;
pub mod output;
pub mod physics;
pub mod sampler;
pub mod samples;
pub mod scene;
pub mod shard;
pub mod stats;
pub mod stress;
pub mod study;
pub mod summary;
pub mod sweep;

/// Version of the output schema (Parquet columns, JSON keys, manifest).
pub const SCHEMA_VERSION: u32 = 1;
