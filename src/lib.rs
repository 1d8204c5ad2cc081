//! impactmc: Monte Carlo statistics of impacts of a rigid ellipsoid on one
//! or several planes, each with its own restitution and Coulomb friction.
//!
//! Data flows one way, and the modules follow it: [`config`] (raw TOML →
//! validated scene) → [`sampler`] (counter-based draws in SoA blocks) →
//! [`kernel`] (contacts and impulses in lanes) → [`stats`] (mergeable
//! accumulators) → [`output`] (summaries, Parquet, run folders). [`engine`]
//! runs the batches of that flow in parallel, for contact and drop scenes
//! alike; [`study`] runs every grid point of a scene file through it and
//! writes the run folder. [`physics`] is the pure f64
//! reference every fast path is tested against (its definitions are
//! `docs/spec/physics.md` and `docs/spec/friction.md`); [`lanes`] holds the
//! lane types and their SIMD dispatch.

#![deny(unsafe_code)]

pub mod accuracy;
pub mod config;
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
