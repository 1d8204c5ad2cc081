//! The integration tests: one crate, so polars and the rest link once.
//! Each module is one concern; `support` holds what they share (the
//! binary, scratch folders, shipped and rough scenes, the golden data,
//! proptest strategies, Parquet reading, `assert_close!`).

#[macro_use]
mod support;

mod accuracy_ladder;
mod compliant_convergence;
mod compliant_friction;
mod derived_columns;
mod docs_columns;
mod drop_lanes;
mod drop_runs;
mod effects;
mod engine_runs;
mod flight;
mod flight_lanes;
mod friction_certificate;
mod friction_invariants;
mod friction_kernel;
mod friction_scenes;
mod frozen_summaries;
mod fuzz_inputs;
mod golden;
mod golden_friction;
mod kernel_vs_reference;
mod kubernetes;
mod layering;
mod paired_points;
mod physics_invariants;
mod plots;
mod proportions;
mod python;
mod ratios;
mod readers;
mod rqmc;
mod run_cli;
mod shards;
mod slurm;
mod solve_cli;
mod stability;
mod target;
mod targets_round_alike;
mod time_of_impact;
