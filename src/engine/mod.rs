//! The Monte Carlo run: batches of samples in parallel (rayon), each batch a
//! sequence of SoA blocks through sampler → kernel → accumulators; batch
//! results are merged along a fixed tree over batch indices ([`Node`]), so
//! the answer depends neither on the thread count and scheduling nor on how
//! the batches are split into shards.

// Lane code indexes SoA arrays by lane and contact on purpose: the index
// form is what the loop vectoriser sees through.
#![allow(clippy::needless_range_loop, clippy::manual_memcpy)]

mod batch;
pub mod drop;
mod evaluate;
pub(crate) mod pool;

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Instant;

use rayon::prelude::*;

pub use batch::{kernel_block, sample_block};
pub use evaluate::{evaluate_samples, evaluate_samples_with, SampleOutcome};

use crate::config::{DropBox, Keep, Placement, Scene};
use crate::engine::batch::{run_block, Ctx, Work};
use crate::engine::pool::Pool;
use crate::kernel::{Consts, KernelVariant};
use crate::lanes::dispatch::BLOCK;
use crate::lanes::Real;
use crate::output::samples::SampleRows;
use crate::sampler::{Sampler, ALL_ROWS};
use crate::stats::accumulators::{RunAcc, Shape};
use crate::stats::block::StatsPlan;
use crate::stats::clusters::ClusterLog;
use crate::stats::tree::{aligned_nodes, reduce_tree, Node, Shard, TreeStack};
use crate::stats::RunResult;

/// Calls `f::<T, N, ROT, CPL, FR>(args)` for a scene's precision, contact
/// count and kernel variant: the one place where the variant becomes types.
/// The frictional variant has the lever arms and the coupling (`ROT` and
/// `CPL` true).
macro_rules! with_kernel {
    ($scene:expr, $variant:expr, $f:ident($($arg:expr),*)) => {{
        use $crate::kernel::KernelVariant as V;
        let v: V = $variant;
        macro_rules! by_variant {
            ($t:ty, $n:literal) => {
                match v {
                    V::Frictional => $f::<$t, $n, true, true, true>($($arg),*),
                    V::Frictionless { rotational_coupling, coupled_contacts } => {
                        match (rotational_coupling, coupled_contacts) {
                            (true, true) => $f::<$t, $n, true, true, false>($($arg),*),
                            (true, false) => $f::<$t, $n, true, false, false>($($arg),*),
                            (false, true) => $f::<$t, $n, false, true, false>($($arg),*),
                            (false, false) => $f::<$t, $n, false, false, false>($($arg),*),
                        }
                    }
                }
            };
        }
        match ($scene.precision(), $scene.touching().len()) {
            ($crate::config::Precision::F32, 1) => by_variant!(f32, 1),
            ($crate::config::Precision::F32, 2) => by_variant!(f32, 2),
            ($crate::config::Precision::F32, _) => by_variant!(f32, 3),
            ($crate::config::Precision::F64, 1) => by_variant!(f64, 1),
            ($crate::config::Precision::F64, 2) => by_variant!(f64, 2),
            ($crate::config::Precision::F64, _) => by_variant!(f64, 3),
        }
    }};
}
pub(crate) use with_kernel;

/// What a run of `scene` will run, as the line the CLI prints first: the
/// batch body its placement chooses and, at contact, the kernel variant.
pub fn describe(scene: &Scene, keep: Keep) -> String {
    match scene.placement() {
        Placement::Drop(_) => {
            format!(
                "kernel: drop in {} lanes (a wavefront of flights, times of impact and impacts; the f64 reference for what lanes leave)",
                scene.precision().name()
            )
        }
        Placement::Contact(_) => {
            let kept = if keep == Keep::NONE {
                String::new()
            } else {
                format!(" (kept although not needed: {keep:?})")
            };
            format!("kernel: {}{kept}", KernelVariant::of(scene, keep).name())
        }
    }
}

/// Options of a run that do not change its results.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Worker threads; 0 means all cores.
    pub threads: usize,
    /// Show a progress bar on a terminal.
    pub progress: bool,
    /// Run only this shard's batches.
    pub shard: Option<Shard>,
    /// Effects computed although the scene does not need them (same
    /// answers; a benchmark's knob, for measuring what the specialisation
    /// saves).
    #[doc(hidden)]
    pub keep: Keep,
    /// The per-sample float columns a sink takes (one flag per column of
    /// `RowLayout`); the others are not computed. None: all. Set by
    /// [`crate::run`] from the scene's column selection.
    #[doc(hidden)]
    pub sample_floats: Option<Vec<bool>>,
    /// Progress and cancellation for a caller on another thread.
    pub watch: Option<Arc<Watch>>,
    /// Record cluster sums ([`crate::stats::clusters`]) for paired
    /// differences with another run of the same samples (an MC sweep's
    /// points); a shard records its own batches' for the merge.
    pub clusters: bool,
}

impl RunOptions {
    /// The worker threads a run uses: `threads`, or every core for 0.
    pub fn worker_threads(&self) -> usize {
        match self.threads {
            0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
            n => n,
        }
    }
}

/// Work seen from another thread: how much is done of how much, and a
/// flag that stops it at its next check ([`RunError::Cancelled`] for a
/// run, between batches). The unit is the work's own: samples for a run or
/// a study (every grid point), shards for a merge, steps for an accuracy
/// ladder.
#[derive(Debug, Default)]
pub struct Watch {
    done: AtomicU64,
    total: AtomicU64,
    cancel: AtomicBool,
}

impl Watch {
    /// A watch with nothing done, to share with a run.
    #[must_use]
    pub fn new() -> Arc<Self> {
        Arc::new(Self::default())
    }

    /// Work finished so far (for a study, in its grid points so far).
    pub fn done(&self) -> u64 {
        self.done.load(Ordering::Relaxed)
    }

    /// The whole work, once the watched work has said it; 0 before.
    pub fn total(&self) -> u64 {
        self.total.load(Ordering::Relaxed)
    }

    pub(crate) fn set_total(&self, total: u64) {
        self.total.store(total, Ordering::Relaxed);
    }

    pub(crate) fn advance(&self, n: u64) {
        self.done.fetch_add(n, Ordering::Relaxed);
    }

    /// Asks the work to stop: a run skips the batches not started yet and
    /// returns [`RunError::Cancelled`]; a merge or a ladder stops before
    /// its next shard or step.
    pub fn cancel(&self) {
        self.cancel.store(true, Ordering::Relaxed);
    }

    /// Whether [`Watch::cancel`] was called.
    pub fn cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }
}

/// The samples a run of `scene` takes: all, or one shard's batches.
pub fn samples_run(scene: &Scene, shard: Option<Shard>) -> u64 {
    let (n, batch) = (scene.samples(), scene.batch_size());
    let range = match shard {
        Some(s) => s.batches(n.div_ceil(batch)),
        None => 0..n.div_ceil(batch),
    };
    (range.end * batch).min(n) - (range.start * batch).min(n)
}

/// The terminal's progress bar and the caller's [`Watch`].
struct Progress<'a> {
    bar: indicatif::ProgressBar,
    watch: Option<&'a Watch>,
}

impl Progress<'_> {
    fn inc(&self, samples: u64) {
        self.bar.inc(samples);
        if let Some(w) = self.watch {
            w.advance(samples);
        }
    }

    fn stopped(&self) -> bool {
        self.watch.is_some_and(|w| w.cancelled())
    }
}

/// Batches run per step when per-sample rows are written (rows are
/// delivered in sample order, so memory is bounded by the step).
const BATCHES_IN_FLIGHT_WITH_ROWS: u64 = 2;

/// Receives per-sample rows in sample order.
pub type SampleSink<'a> = dyn FnMut(SampleRows) -> Result<(), SinkError> + Send + 'a;

/// Why a [`SampleSink`] refused rows (kept as the source of [`RunError::Sink`]).
pub type SinkError = Box<dyn std::error::Error + Send + Sync>;

#[allow(clippy::too_many_arguments)]
fn run_typed<T: Real, const N: usize, const ROT: bool, const CPL: bool, const FR: bool>(
    scene: &Scene,
    plan: StatsPlan,
    batch_range: std::ops::Range<u64>,
    progress: &Progress,
    clusters: Option<&ClusterLog>,
    sink: Option<&mut SampleSink>,
    empty_rows: SampleRows,
) -> Result<Vec<(Node, RunAcc)>, SinkError> {
    let consts = Consts::<T, N>::new(scene);
    // Orientations feed the rotational terms and the per-sample rows only,
    // and the kernel reads only the rows of A its planes need; per-sample
    // rows and planes outside the placement read the whole matrix.
    // The frictional kernel's contact frames read the whole orientation
    // (a sphere's ω turns by friction too).
    let whole = sink.is_some() || scene.planes().len() > N || FR;
    let sampler = Sampler::new(scene)
        .with_orientation(ROT || sink.is_some() || FR)
        .with_matrix_rows(if whole {
            ALL_ROWS
        } else {
            consts.matrix_rows()
        });
    let laws = scene.laws().len();
    let batch = scene.batch_size();
    let total = scene.samples();
    let want_rows = sink.is_some();
    let ctx = Ctx {
        scene,
        consts: &consts,
        sampler: &sampler,
        plan,
    };
    let pool = Pool::<Work<T, N>>::new();
    // Holds cleared accumulators only.
    let accs = Pool::<RunAcc>::new();
    let run_batch = |b: u64| -> (RunAcc, Option<SampleRows>) {
        let mut part = accs.take(|| RunAcc::shaped(Shape::of(scene)));
        if progress.stopped() {
            return (part, None);
        }
        let mut work = pool.take(|| Work::new(laws));
        let lo = b * batch;
        let hi = (lo + batch).min(total);
        let mut rows = want_rows.then(|| {
            let mut r = empty_rows.clone();
            r.reserve((hi - lo) as usize);
            r
        });
        let mut recorder = clusters.map(ClusterLog::recorder);
        let mut first = lo;
        while first < hi {
            let count = ((hi - first) as usize).min(BLOCK);
            run_block::<T, N, ROT, CPL, FR>(
                &ctx,
                first,
                count,
                &mut work,
                &mut part,
                rows.as_mut(),
            );
            if let Some(r) = recorder.as_mut() {
                r.block_done(&part);
            }
            first += BLOCK as u64;
        }
        if let (Some(log), Some(r)) = (clusters, recorder) {
            log.keep(b, r, &part);
        }
        part.flush();
        pool.give(work);
        progress.inc(hi - lo);
        (part, rows)
    };
    run_tree(scene, batch_range, &run_batch, &accs, sink)
}

/// A drop scene's batches: the walks of [`crate::engine::drop`] in lanes
/// (the f64 reference for what lanes leave), through the same tree as
/// contact batches.
#[allow(clippy::too_many_arguments)]
fn run_drops(
    scene: &Scene,
    start: DropBox,
    keep: Keep,
    batch_range: std::ops::Range<u64>,
    progress: &Progress,
    clusters: Option<&ClusterLog>,
    sink: Option<&mut SampleSink>,
    empty_rows: SampleRows,
) -> Result<Vec<(Node, RunAcc)>, SinkError> {
    let ctx = crate::engine::drop::DropCtx::new(scene, start, keep);
    let shape = Shape::of(scene);
    let batch = scene.batch_size();
    let total = scene.samples();
    let want_rows = sink.is_some();
    let accs = Pool::<RunAcc>::new();
    let run_batch = |b: u64| -> (RunAcc, Option<SampleRows>) {
        let mut part = accs.take(|| RunAcc::shaped(shape));
        if progress.stopped() {
            return (part, None);
        }
        let mut rows = want_rows.then(|| empty_rows.clone());
        let lo = b * batch;
        let hi = (lo + batch).min(total);
        let mut recorder = clusters.map(ClusterLog::recorder);
        ctx.run_recorded(lo, hi - lo, &mut part, rows.as_mut(), recorder.as_mut());
        if let (Some(log), Some(r)) = (clusters, recorder) {
            log.keep(b, r, &part);
        }
        part.flush();
        progress.inc(hi - lo);
        (part, rows)
    };
    run_tree(scene, batch_range, &run_batch, &accs, sink)
}

/// Runs the batches of `batch_range` with `run_batch` and merges their
/// accumulators along the fixed merge tree: the maximal tree nodes inside
/// the range, in batch order, none above an RQMC replicate (so that the
/// final reduction, of this run or of merged shards, sees every
/// replicate). Per-sample rows go to `sink` in batch order.
fn run_tree(
    scene: &Scene,
    batch_range: std::ops::Range<u64>,
    run_batch: &(dyn Fn(u64) -> (RunAcc, Option<SampleRows>) + Sync),
    accs: &Pool<RunAcc>,
    mut sink: Option<&mut SampleSink>,
) -> Result<Vec<(Node, RunAcc)>, SinkError> {
    let max_level = scene
        .sampling()
        .replicate_level(scene.batch_size())
        .unwrap_or(u32::MAX);
    let mut tree = TreeStack::new(max_level);
    if sink.is_none() {
        // Summary only: each maximal tree node is run as a parallel
        // recursion that merges its two halves as soon as both are done,
        // on whichever thread finished last. Merges overlap with other
        // batches' work (no serial merge step, no barrier), and the tree's
        // shape is fixed by the batch indices, so results are bit-identical
        // for any thread count.
        // A merged right half's accumulator is cleared and reused by a
        // later batch.
        fn subtree(
            node: Node,
            leaf: &(dyn Fn(u64) -> RunAcc + Sync),
            accs: &Pool<RunAcc>,
        ) -> RunAcc {
            if node.level == 0 {
                return leaf(node.index);
            }
            let child = |i| Node {
                level: node.level - 1,
                index: i,
            };
            let (mut left, mut right) = rayon::join(
                || subtree(child(2 * node.index), leaf, accs),
                || subtree(child(2 * node.index + 1), leaf, accs),
            );
            left.merge(&mut right);
            right.clear();
            accs.give(right);
            left
        }
        let leaf = |b: u64| run_batch(b).0;
        let nodes = aligned_nodes(batch_range, max_level);
        let merged: Vec<RunAcc> = nodes
            .par_iter()
            .map(|&node| subtree(node, &leaf, accs))
            .collect();
        for (node, acc) in nodes.into_iter().zip(merged) {
            tree.push_node(node, acc);
        }
        return Ok(tree.nodes);
    }
    let in_flight = BATCHES_IN_FLIGHT_WITH_ROWS * rayon::current_num_threads() as u64;
    let mut start = batch_range.start;
    while start < batch_range.end {
        let end = (start + in_flight).min(batch_range.end);
        let parts: Vec<(RunAcc, Option<SampleRows>)> =
            (start..end).into_par_iter().map(run_batch).collect();
        for (b, (p, rows)) in (start..end).zip(parts) {
            tree.push(b, p);
            if let (Some(sink), Some(rows)) = (sink.as_mut(), rows) {
                sink(rows)?;
            }
        }
        start = end;
    }
    Ok(tree.nodes)
}

/// Why a run stopped.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The worker threads could not be started.
    #[error("thread pool: {0}")]
    Pool(#[from] rayon::ThreadPoolBuildError),
    /// The per-sample rows could not be taken (a full disk, say).
    #[error("per-sample output: {0}")]
    Sink(#[source] SinkError),
    /// [`Watch::cancel`] stopped the run.
    #[error("the run was cancelled")]
    Cancelled,
}

/// Runs a scene (summary statistics only).
pub fn run(scene: &Scene, opts: &RunOptions) -> Result<RunResult, RunError> {
    run_with_samples(scene, opts, None)
}

/// Runs a scene and hands every sample's row, in sample order, to `sink`.
pub fn run_with_samples(
    scene: &Scene,
    opts: &RunOptions,
    sink: Option<&mut SampleSink>,
) -> Result<RunResult, RunError> {
    let threads = opts.worker_threads();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let batches = scene.samples().div_ceil(scene.batch_size());
    let range = match opts.shard {
        Some(shard) => shard.batches(batches),
        None => 0..batches,
    };
    let samples_run = samples_run(scene, opts.shard);
    let bar = if opts.progress && samples_run >= 20_000_000 {
        let b = indicatif::ProgressBar::new(samples_run);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:40} {percent:>3}% {human_pos}/{human_len} samples, eta {eta}",
            )
            .expect("static template"),
        );
        b
    } else {
        indicatif::ProgressBar::hidden()
    };
    let progress = Progress {
        bar,
        watch: opts.watch.as_deref(),
    };
    let cpu0 = process_cpu_seconds();
    let t0 = Instant::now();
    let r = range.clone();
    let variant = KernelVariant::of(scene, opts.keep);
    let plan = StatsPlan::of(scene, opts.keep);
    // What a batch's per-sample rows start from: the scene's columns, those
    // the sink takes filled.
    let mut rows = SampleRows::of_scene(scene);
    if let Some(mask) = &opts.sample_floats {
        rows.fill_only(mask);
    }
    let log = opts
        .clusters
        .then(|| ClusterLog::new(crate::stats::clusters::blocks_per_cluster(scene)));
    let nodes = pool
        .install(|| {
            // The one choice of a batch body by the kind of scene.
            match scene.placement() {
                Placement::Drop(start) => run_drops(
                    scene,
                    *start,
                    opts.keep,
                    r,
                    &progress,
                    log.as_ref(),
                    sink,
                    rows,
                ),
                Placement::Contact(_) => {
                    with_kernel!(
                        scene,
                        variant,
                        run_typed(scene, plan, r, &progress, log.as_ref(), sink, rows)
                    )
                }
            }
        })
        .map_err(RunError::Sink)?;
    if progress.stopped() {
        progress.bar.finish_and_clear();
        return Err(RunError::Cancelled);
    }
    let kept = if opts.shard.is_some() {
        nodes.clone()
    } else {
        Vec::new()
    };
    let reduced = reduce_tree(
        nodes,
        batches,
        Shape::of(scene),
        scene.sampling().replicate_level(scene.batch_size()),
    );
    let (mut acc, mut replicates) = (reduced.acc, reduced.replicates);
    acc.finish();
    replicates.iter_mut().for_each(RunAcc::finish);
    let wall_seconds = t0.elapsed().as_secs_f64();
    progress.bar.finish_and_clear();
    let cpu_seconds = match (cpu0, process_cpu_seconds()) {
        (Some(a), Some(b)) => Some(b - a),
        _ => None,
    };
    let clusters = log.map(|l| l.finish(scene, &acc.laws));
    Ok(RunResult {
        acc,
        replicates,
        clusters,
        nodes: kept,
        batches,
        batches_run: range.end - range.start,
        wall_seconds,
        cpu_seconds,
        threads,
    })
}

/// CPU time (user + system) of this process so far, from
/// `/proc/self/stat`; `None` where that is not available.
pub fn process_cpu_seconds() -> Option<f64> {
    // /proc/self/stat fields 14 and 15: user and system time in clock ticks.
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let after = stat.rsplit_once(')')?.1;
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::Slot;

    /// Every accumulator field by path, as comparable text.
    fn slots(acc: &mut RunAcc) -> Vec<(String, String)> {
        let mut out = Vec::new();
        acc.visit(&mut |path, slot| {
            let value = match slot {
                Slot::Count(c) => format!("count {c}"),
                Slot::Moments(m) => format!("moments {:?}", m.state()),
                Slot::Histogram(h) => format!("hist {:?}", h.entries()),
            };
            out.push((path.to_string(), value));
        });
        out
    }

    /// A run's accumulator, cleared for reuse, is a new one in every field
    /// (and the run had filled fields of every kind).
    #[test]
    fn a_cleared_accumulator_is_a_new_one() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/configs/corner3.toml");
        let scene = crate::config::load_scene(
            std::path::Path::new(path),
            &crate::config::Overrides {
                samples: Some(4096),
                laws: Some(vec!["newton".into(), "poisson".into()]),
                ..Default::default()
            },
        )
        .expect("shipped scene");
        let opts = RunOptions {
            threads: 1,
            keep: Keep::ALL,
            ..Default::default()
        };
        let mut used = run(&scene, &opts).expect("run").acc;
        let mut fresh = RunAcc::new(2, 3);
        let (before, want) = (slots(&mut used), slots(&mut fresh));
        assert_eq!(before.len(), want.len());
        for kind in ["count", "moments", "hist"] {
            let changed = before
                .iter()
                .zip(&want)
                .any(|(b, w)| b.1.starts_with(kind) && b != w);
            assert!(changed, "the run filled no {kind} field");
        }
        used.clear();
        assert_eq!(slots(&mut used), want);
    }
}
