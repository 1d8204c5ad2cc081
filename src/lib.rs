//! impactmc: Monte Carlo statistics of frictionless impacts of a rigid
//! ellipsoid on one or several planes.
//!
//! Data flows one way, and the modules follow it: [`config`] (raw TOML →
//! validated scene) → [`sampler`] (counter-based draws in SoA blocks) →
//! [`kernel`] (contacts and impulses in lanes) → [`stats`] (mergeable
//! accumulators) → [`output`] (summaries, Parquet, run folders). [`engine`]
//! runs the batches of that flow in parallel; [`study`] is the one entry
//! point that chooses the engine for a scene. [`physics`] is the pure f64
//! reference every fast path is tested against; [`lanes`] holds the lane
//! types and their SIMD dispatch.

#![deny(unsafe_code)]

pub mod accuracy;
pub mod config;
pub mod drop;
pub mod engine;
pub mod kernel;
pub mod lanes;
pub mod output;
pub mod physics;
pub mod sampler;
pub mod stats;
pub mod stress;
pub mod study;

/// Version of the output schema (Parquet columns, JSON keys, manifest).
pub const SCHEMA_VERSION: u32 = 2;
