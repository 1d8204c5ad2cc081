//! Cluster sums: what paired differences between sweep points take under
//! Monte Carlo sampling.
//!
//! Every grid point of a sweep runs the same samples (common random
//! numbers), so an estimate's difference between two points has the
//! variance of a mean of paired differences, which is smaller than the two
//! points' variances added when the points are correlated. Each point is a
//! run of its own, so no run holds both points' values of a sample. A run
//! asked for them ([`crate::engine::RunOptions::clusters`]) records instead,
//! per cluster of consecutive samples, the two sums `A_c` and `B_c` of every
//! estimate of each law (the estimate is `c + ΣA/ΣB` with `c` a run
//! constant: a restitution's pilot, else 0). A cluster is a fixed run of
//! whole blocks inside one batch, a drop's is its batch: set by the scene,
//! not by the threads, so the sums are the same for any thread count.
//!
//! The samples are independent, so the clusters are. The delta method gives
//! a difference's variance from the clusters' linearised terms
//! `u_c = (A_c − R′·B_c) / B̄` (`R′ = ΣA/ΣB`, `B̄` the mean of the `B_c`):
//! `D − δ ≈ mean_c(u_c − u⁰_c)`, so `ci95 = t_{n−1} · s(u − u⁰) / √n` over
//! the `n` clusters. With thousands of clusters this is the per-sample
//! paired interval up to the noise of its variance estimate (about
//! `1/√(2n)` relative).

use std::sync::Mutex;

use crate::config::Scene;
use crate::lanes::dispatch::BLOCK;
use crate::stats::accumulators::{LawAcc, RunAcc};
use crate::stats::student::t975;
use crate::stats::Moments;

/// At most this many clusters per run (more blocks per cluster beyond
/// it): the variance of the paired difference is then estimated to about
/// 1 % relative, and the sums take `clusters × estimates × 16` bytes.
pub const MAX_CLUSTERS: u64 = 4096;

/// Which estimate of a law's `all` group a pair of sums is; the summary
/// names it (`output::summary`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Key {
    /// A mean statistic: `energy_ratio`, `omega_after_norm`, ….
    Stat(&'static str),
    /// A mean statistic of one recorded plane (`impulse`, `rebound`,
    /// `restitution`, …), by the plane's index among the recorded planes.
    PlaneStat(&'static str, usize),
    /// A fraction of the samples (`impacting`, `energy_gain`, …).
    Fraction(&'static str),
    /// A fraction of one plane's contacts (`sticking`).
    PlaneFraction(&'static str, usize),
    /// The share of an active set, by its mask.
    ActiveSet(usize),
}

/// Every estimate of a law, in the order of the summary's `all` group
/// (statistics, fractions, active sets), as `(key, A, B)`.
pub fn walk_law(acc: &LawAcc, f: &mut dyn FnMut(Key, f64, f64)) {
    fn mean(f: &mut dyn FnMut(Key, f64, f64), key: Key, m: &Moments) {
        f(key, m.sum(), m.count() as f64);
    }
    mean(f, Key::Stat("energy_ratio"), &acc.energy_ratio.moments);
    mean(
        f,
        Key::Stat("omega_after_norm"),
        &acc.omega_after_norm.moments,
    );
    mean(
        f,
        Key::Stat("velocity_after_norm"),
        &acc.velocity_after_norm.moments,
    );
    for i in 0..acc.impulse.len() {
        mean(f, Key::PlaneStat("impulse", i), &acc.impulse[i].moments);
        mean(f, Key::PlaneStat("rebound", i), &acc.rebound[i].moments);
        // Σx/Σy = e₀ + Σr/Σy: the residuals' sum over the pairs'.
        let r = &acc.restitution[i];
        f(Key::PlaneStat("restitution", i), r.resid.sum(), r.y.sum());
        if let Some(fr) = &acc.friction {
            mean(
                f,
                Key::PlaneStat("tangential_impulse", i),
                &fr.tangential_impulse[i].moments,
            );
            mean(
                f,
                Key::PlaneStat("sliding_speed", i),
                &fr.sliding_speed[i].moments,
            );
        }
    }
    let n = acc.samples as f64;
    for (name, k) in [
        ("impacting", acc.impacts),
        ("energy_gain", acc.energy_gain),
        ("degenerate", acc.degenerate),
        ("jammed", acc.jammed),
        ("unsolved", acc.unsolved),
        ("recomputed_f64", acc.recomputed),
        ("penetrating", acc.penetrating),
    ] {
        f(Key::Fraction(name), k as f64, n);
    }
    if let Some(fr) = &acc.friction {
        for (name, k) in [
            ("ambiguous", fr.ambiguous),
            ("unconverged", fr.unconverged),
            ("coupled_fallback", fr.coupled_fallback),
        ] {
            f(Key::Fraction(name), k as f64, n);
        }
        for i in 0..fr.active.len() {
            f(
                Key::PlaneFraction("sticking", i),
                fr.sticking[i] as f64,
                fr.active[i] as f64,
            );
        }
    }
    for (mask, &k) in acc.active_sets.iter().enumerate() {
        f(Key::ActiveSet(mask), k as f64, n);
    }
}

/// Every law's sums, appended to `out` in law order.
fn digest(acc: &RunAcc, out: &mut Vec<f64>) {
    for law in &acc.laws {
        walk_law(law, &mut |_, a, b| out.extend([a, b]));
    }
}

/// The estimates of a law of `laws` (the same for every law), in
/// [`walk_law`]'s order.
pub fn keys(laws: &[LawAcc]) -> Vec<Key> {
    let mut keys = Vec::new();
    if let Some(law) = laws.first() {
        walk_law(law, &mut |k, _, _| keys.push(k));
    }
    keys
}

/// A run's cluster sums, in sample order.
#[derive(Debug, Clone, PartialEq)]
pub struct ClusterSums {
    /// A law's estimates, in [`walk_law`]'s order (the same for every law).
    pub keys: Vec<Key>,
    pub laws: usize,
    /// The run's samples and batch size: two runs' clusters pair only
    /// where both agree (the same samples in the same clusters).
    pub samples: u64,
    pub batch_size: u64,
    /// The batches recorded, in order, each with its number of clusters
    /// (a shard's run records its own batches; a merge joins them).
    pub batches: Vec<(u64, usize)>,
    /// Per cluster, per law, per estimate: `A_c`, then `B_c`.
    pub sums: Vec<f64>,
}

impl ClusterSums {
    /// The sums of `batches` (each batch's index and its clusters' sums,
    /// in any order), put in batch order; `laws` give the estimates' keys.
    pub fn from_batches(
        samples: u64,
        batch_size: u64,
        laws: &[LawAcc],
        mut batches: Vec<(u64, Vec<f64>)>,
    ) -> Self {
        batches.sort_unstable_by_key(|b| b.0);
        let keys = keys(laws);
        let width = (laws.len() * keys.len() * 2).max(1);
        Self {
            keys,
            laws: laws.len(),
            samples,
            batch_size,
            batches: batches.iter().map(|b| (b.0, b.1.len() / width)).collect(),
            sums: batches.into_iter().flat_map(|b| b.1).collect(),
        }
    }

    /// Sums per cluster.
    fn width(&self) -> usize {
        self.laws * self.keys.len() * 2
    }

    /// Each recorded batch's index and its clusters' sums, in batch order.
    pub fn per_batch(&self) -> impl Iterator<Item = (u64, &[f64])> {
        let w = self.width();
        let mut at = 0;
        self.batches.iter().map(move |&(b, n)| {
            let s = &self.sums[at..at + n * w];
            at += n * w;
            (b, s)
        })
    }

    /// The clusters recorded.
    pub fn clusters(&self) -> usize {
        self.sums.len() / self.width().max(1)
    }

    /// Law `law`'s sums `(A_c, B_c)` of `key`, per cluster (None if the run
    /// has no such estimate).
    pub fn column(&self, law: usize, key: Key) -> Option<Vec<(f64, f64)>> {
        let k = self.keys.iter().position(|&x| x == key)?;
        if law >= self.laws {
            return None;
        }
        let at = 2 * (law * self.keys.len() + k);
        Some(
            self.sums
                .chunks_exact(self.width())
                .map(|c| (c[at], c[at + 1]))
                .collect(),
        )
    }

    /// The 95 % half-width of `self`'s estimate of `key` minus
    /// `reference`'s, paired by cluster (module docs); NaN where the two
    /// runs' clusters are not the same samples, an estimate is undefined
    /// in either, or there are fewer than two clusters.
    pub fn paired_ci95(&self, reference: &ClusterSums, law: usize, key: Key) -> f64 {
        if (self.samples, self.batch_size, &self.batches)
            != (reference.samples, reference.batch_size, &reference.batches)
        {
            return f64::NAN;
        }
        let (Some(a), Some(b)) = (self.column(law, key), reference.column(law, key)) else {
            return f64::NAN;
        };
        paired_half_width(&a, &b)
    }
}

/// The linearised terms `u_c = (A_c − R′·B_c) / B̄` of a ratio of sums over
/// clusters; None if `ΣB = 0`.
fn linearised(c: &[(f64, f64)]) -> Option<Vec<f64>> {
    let (sa, sb) = c
        .iter()
        .fold((0.0, 0.0), |(sa, sb), &(a, b)| (sa + a, sb + b));
    if sb == 0.0 {
        return None;
    }
    let (r, mean_b) = (sa / sb, sb / c.len() as f64);
    Some(c.iter().map(|&(a, b)| (a - r * b) / mean_b).collect())
}

/// The 95 % half-width of `R_a − R_b`, two ratios of sums over the same
/// clusters: Student t over the clusters' paired linearised differences.
pub fn paired_half_width(a: &[(f64, f64)], b: &[(f64, f64)]) -> f64 {
    let n = a.len();
    if n < 2 || b.len() != n {
        return f64::NAN;
    }
    let (Some(ua), Some(ub)) = (linearised(a), linearised(b)) else {
        return f64::NAN;
    };
    let d: Vec<f64> = ua.iter().zip(&ub).map(|(x, y)| x - y).collect();
    let mean = d.iter().sum::<f64>() / n as f64;
    let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    t975(n as u64 - 1) * (var / n as f64).sqrt()
}

/// Blocks per cluster for a scene: one, or more so that a run has at most
/// about [`MAX_CLUSTERS`].
pub fn blocks_per_cluster(scene: &Scene) -> u64 {
    let batch = scene.batch_size();
    let full = scene.samples() / batch;
    let rest = scene.samples() % batch;
    let blocks = full * batch.div_ceil(BLOCK as u64) + rest.div_ceil(BLOCK as u64);
    blocks.div_ceil(MAX_CLUSTERS).max(1)
}

/// The clusters of a run being recorded: each batch's, collected from the
/// threads that ran them and put in batch order by [`ClusterLog::finish`].
#[derive(Debug)]
pub(crate) struct ClusterLog {
    blocks: u64,
    batches: Mutex<Vec<(u64, Vec<f64>)>>,
}

impl ClusterLog {
    /// A log cutting a cluster every `blocks` blocks.
    pub(crate) fn new(blocks: u64) -> Self {
        Self {
            blocks: blocks.max(1),
            batches: Mutex::new(Vec::new()),
        }
    }

    /// A recorder for one batch (its accumulator starts empty).
    pub(crate) fn recorder(&self) -> Recorder {
        Recorder {
            blocks: self.blocks,
            since: 0,
            prev: Vec::new(),
            cur: Vec::new(),
            out: Vec::new(),
        }
    }

    /// Keeps batch `batch`'s clusters, its last cut at the batch's end.
    pub(crate) fn keep(&self, batch: u64, mut r: Recorder, acc: &RunAcc) {
        if r.since > 0 || r.out.is_empty() {
            r.cut(acc);
        }
        self.batches
            .lock()
            .expect("a thread recording clusters panicked")
            .push((batch, r.out));
    }

    /// The clusters in sample order.
    pub(crate) fn finish(self, scene: &Scene, laws: &[LawAcc]) -> ClusterSums {
        let batches = self
            .batches
            .into_inner()
            .expect("a thread recording clusters panicked");
        ClusterSums::from_batches(scene.samples(), scene.batch_size(), laws, batches)
    }
}

/// One batch's clusters: the sums of its accumulator at each cut, minus
/// those at the cut before.
#[derive(Debug)]
pub(crate) struct Recorder {
    blocks: u64,
    since: u64,
    prev: Vec<f64>,
    cur: Vec<f64>,
    out: Vec<f64>,
}

impl Recorder {
    /// After a block was added to `acc`: a cut every `blocks` blocks.
    #[inline]
    pub(crate) fn block_done(&mut self, acc: &RunAcc) {
        self.since += 1;
        if self.since == self.blocks {
            self.cut(acc);
        }
    }

    fn cut(&mut self, acc: &RunAcc) {
        self.cur.clear();
        digest(acc, &mut self.cur);
        if self.prev.is_empty() {
            self.prev.resize(self.cur.len(), 0.0);
        }
        self.out
            .extend(self.cur.iter().zip(&self.prev).map(|(c, p)| c - p));
        std::mem::swap(&mut self.prev, &mut self.cur);
        self.since = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With one sample per cluster the half-width is the textbook paired
    /// one: t · s(x − y)/√n for means (B = 1).
    #[test]
    fn one_sample_clusters_give_the_paired_t_interval() {
        let x = [1.0, 2.0, 4.0, 3.0, 5.0, 7.0];
        let y = [0.5, 2.5, 3.0, 3.5, 4.0, 6.0];
        let a: Vec<(f64, f64)> = x.iter().map(|&v| (v, 1.0)).collect();
        let b: Vec<(f64, f64)> = y.iter().map(|&v| (v, 1.0)).collect();
        let d: Vec<f64> = x.iter().zip(&y).map(|(p, q)| p - q).collect();
        let m = d.iter().sum::<f64>() / 6.0;
        let s = (d.iter().map(|v| (v - m).powi(2)).sum::<f64>() / 5.0).sqrt();
        // scipy.stats.t.ppf(0.975, 5)
        let want = 2.570_581_835_636_314 * s / 6f64.sqrt();
        let got = paired_half_width(&a, &b);
        assert!((got - want).abs() < 1e-12 * want, "{got} vs {want}");
        assert!(paired_half_width(&a[..1], &b[..1]).is_nan());
        let none: Vec<(f64, f64)> = vec![(0.0, 0.0); 6];
        assert!(paired_half_width(&a, &none).is_nan());
    }
}
