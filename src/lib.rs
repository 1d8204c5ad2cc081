//! impactmc: Monte Carlo statistics of impacts of a rigid ellipsoid on one
//! or several planes, each with its own restitution and Coulomb friction.
//!
//! The library's front door is what this page lists:
//!
//! - a scene: [`SceneText`] (a TOML file or string), [`Overrides`] (what
//!   the command line can change), [`load_scene`] and the validated
//!   [`Scene`];
//! - a run: [`run`] takes a scene through every grid point into a run
//!   folder or memory ([`Study`], with a [`Summary`] per point and the
//!   per-sample rows as an [`ArrowTable`]), under [`RunOptions`] (threads,
//!   a shard, a [`Watch`] for progress and cancellation); [`merge_study`]
//!   merges the shards of a run;
//! - one impact: [`solve_text`] solves a case ([`CaseInput`] →
//!   [`CaseOutput`]) with the f64 reference;
//! - the errors: [`SceneError`], [`StudyError`], [`RunError`],
//!   [`OutputError`], [`CaseError`].
//!
//! ```no_run
//! use impactmc::{run, Overrides, RunOptions, SceneText};
//!
//! let scene = SceneText::read("configs/corner3.toml".as_ref())?;
//! let overrides = Overrides { samples: Some(1_000_000), ..Overrides::default() };
//! let study = run(&scene, &overrides, &RunOptions::default(), None)?;
//! println!("{}", study.points[0].summary.to_text());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Inside, data flows one way, and the modules follow it: `config` (raw
//! TOML → validated scene) → `sampler` (counter-based draws in SoA blocks)
//! → `kernel` (contacts and impulses in lanes) → `stats` (mergeable
//! accumulators) → `output` (summaries, Parquet, run folders). `engine`
//! runs the batches of that flow in parallel, for contact and drop scenes
//! alike; `study` runs every grid point of a scene file through it and
//! writes the run folder. `physics` is the pure f64 reference every fast
//! path is tested against (`docs/spec/physics.md`,
//! `docs/spec/friction.md`); `lanes` holds the lane types and their SIMD
//! dispatch. Those modules are public for the command line, the Python
//! package and the tests, and hidden from these pages: their items may
//! change without notice (`docs/design.md` describes them).

#![deny(unsafe_code)]
#![warn(missing_docs)]

#[doc(hidden)]
pub mod accuracy;
#[doc(hidden)]
pub mod config;
#[doc(hidden)]
pub mod engine;
#[doc(hidden)]
pub mod kernel;
#[doc(hidden)]
pub mod lanes;
#[doc(hidden)]
pub mod output;
#[doc(hidden)]
pub mod physics;
#[doc(hidden)]
pub mod sampler;
#[doc(hidden)]
pub mod stats;
#[doc(hidden)]
pub mod stress;
#[doc(hidden)]
pub mod study;

pub use config::case::{solve_text, CaseError, CaseInput, CaseOutput};
pub use config::{load_scene, Overrides, Precision, Scene, SceneError, SceneText};
pub use engine::{RunError, RunOptions, Watch};
pub use output::arrow::ArrowTable;
pub use output::summary::Summary;
pub use output::OutputError;
pub use physics::Law;
pub use stats::tree::Shard;
pub use study::{merge_study, run, PointRun, Study, StudyError};

/// Version of the output schema (Parquet columns, JSON keys, manifest).
pub const SCHEMA_VERSION: u32 = 2;
