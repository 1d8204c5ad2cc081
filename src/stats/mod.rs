//! Mergeable accumulators: moments (shifted sums per batch, merged with
//! Chan's formula in a fixed order, so results are bit-identical for any
//! thread count), extrema, and log-linear histograms for quantiles.

pub mod accumulators;
pub mod block;
pub mod clusters;
pub mod drops;
mod histogram;
mod moments;
pub mod proportion;
mod slot;
mod stat;
pub mod student;
pub mod tree;

pub use histogram::{bin_edges, scatter, LogHistogram, BINS, MAX_EXP, MIN_EXP, SUB_BITS};
pub use moments::{Moments, RatioOfSums};
pub use slot::Slot;
pub use stat::Stat;

use accumulators::RunAcc;
use tree::Node;

/// Result of a run.
#[derive(Debug, Clone)]
pub struct RunResult {
    /// The finished accumulators of the batches run (all of them unless
    /// sharded).
    pub acc: RunAcc,
    /// An RQMC run's replicates' accumulators, finished, in order (empty
    /// for MC): the spread of their estimates gives the intervals.
    pub replicates: Vec<RunAcc>,
    /// Cluster sums, for paired differences with another run of the same
    /// samples, when asked for ([`crate::engine::RunOptions::clusters`]).
    pub clusters: Option<clusters::ClusterSums>,
    /// A sharded run's merge-tree nodes, unfinished, for `impactmc merge`
    /// (empty otherwise).
    pub nodes: Vec<(Node, RunAcc)>,
    /// Batches in the scene, and how many were run.
    pub batches: u64,
    pub batches_run: u64,
    pub wall_seconds: f64,
    pub cpu_seconds: Option<f64>,
    pub threads: usize,
}
