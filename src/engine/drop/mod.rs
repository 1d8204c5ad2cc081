//! Drop studies, per sample: each sample is released from the scene's drop
//! box with its drawn orientation and velocities, flies under gravity with
//! torque-free rotation, hits the planes (time of impact by conservative
//! advancement), and bounces up to `effects.bounces` times or until its
//! kinetic energy after an impact falls below `effects.energy_floor` of the
//! kinetic energy it brought to its first impact.
//!
//! The engine runs drop batches like contact batches (same counter-based
//! draws, pool and merge tree, so the same shards, merges and thread
//! independence); this module is what one batch does: a wavefront of walks
//! (per sample and law) in lanes of the scene's precision (`wave.rs`:
//! flights, times of impact and impacts), the f64 reference
//! ([`crate::physics`]) for what the lanes leave, every bounce recorded in
//! [`DropAcc`](crate::stats::drops::DropAcc) and, when asked for, one per-sample row per impact. The first impacts of a block of samples are written into lanes
//! by the contact fallback's writer ([`write_outcome`](crate::kernel::write_outcome)) and recorded by the
//! contact scenes' block statistics, so both kinds of scene share one
//! recorder.

use glam::DVec3;

use crate::config::Scene;
use crate::kernel::{LawOut, Strike};
use crate::lanes::dispatch::BLOCK;
use crate::output::samples::SampleRows;
use crate::physics::{kinetic_energy, Law, Motion, Rotation};
use crate::stats::accumulators::RunAcc;
use crate::stats::block::{block_stats, record_friction, Before, Scratch};
use crate::stats::clusters::Recorder;
use crate::stats::drops::Ending;

mod ctx;
mod flight;
mod impact;
mod walk;

use flight::Stop;
use walk::{How, Log, Walk};

mod wave;

pub use ctx::DropCtx;
pub(crate) use ctx::Firsts;
pub use flight::{start_of, Flight};

enum Lanes<const N: usize> {
    F32(Box<wave::Wave<f32, N>>),
    F64(Box<wave::Wave<f64, N>>),
}

impl<const N: usize> Lanes<N> {
    fn new(ctx: &DropCtx) -> Self {
        match ctx.scene.precision() {
            crate::config::Precision::F32 => Self::F32(Box::new(wave::Wave::new(ctx))),
            crate::config::Precision::F64 => Self::F64(Box::new(wave::Wave::new(ctx))),
        }
    }
}

/// Samples per chunk of a batch: the walks of a chunk are computed (in any
/// order), then replayed in sample order, a block at a time.
/// A default drop batch (4,096 samples) is one chunk: the wavefront's lanes
/// run dry once per batch.
const CHUNK: usize = 32 * BLOCK;

impl DropCtx<'_> {
    /// Samples `first..first + count` under every law, into `acc` (and one
    /// row per impact into `rows`).
    pub fn run(&self, first: u64, count: u64, acc: &mut RunAcc, rows: Option<&mut SampleRows>) {
        self.run_recorded(first, count, acc, rows, None);
    }

    /// [`Self::run`], cutting a cluster ([`crate::stats::clusters`]) after
    /// each block if `clusters` records them.
    pub(crate) fn run_recorded(
        &self,
        first: u64,
        count: u64,
        acc: &mut RunAcc,
        rows: Option<&mut SampleRows>,
        clusters: Option<&mut Recorder>,
    ) {
        match self.scene.planes().len() {
            1 => self.run_n::<1>(first, count, acc, rows, clusters),
            2 => self.run_n::<2>(first, count, acc, rows, clusters),
            3 => self.run_n::<3>(first, count, acc, rows, clusters),
            4 => self.run_n::<4>(first, count, acc, rows, clusters),
            5 => self.run_n::<5>(first, count, acc, rows, clusters),
            n => {
                debug_assert_eq!(n, crate::config::MAX_DROP_PLANES);
                self.run_n::<6>(first, count, acc, rows, clusters)
            }
        }
    }

    /// [`Self::run`] for `N` planes: per chunk of samples, every walk
    /// (sample and law), then per block of the chunk the walks replayed in
    /// sample order and the first impacts' statistics by the block
    /// recorder of contact scenes (and the clusters' cuts, if recorded).
    fn run_n<const N: usize>(
        &self,
        first: u64,
        count: u64,
        acc: &mut RunAcc,
        mut rows: Option<&mut SampleRows>,
        mut clusters: Option<&mut Recorder>,
    ) {
        let laws = self.scene.laws();
        let body = self.scene.body();
        let mut energy = vec![[0.0; BLOCK]; laws.len()];
        let mut vn = vec![[[0.0; BLOCK]; N]; laws.len()];
        let mut outs: Vec<Box<LawOut<f64, N>>> = (0..laws.len()).map(|_| LawOut::new()).collect();
        let mut scratch = Scratch::<f64, N>::new();
        let mut logs: Vec<Log> = Vec::new();
        let mut kept = self
            .lanes
            .take(|| Box::new(Box::new(Lanes::<N>::new(self))));
        let lanes: &mut Lanes<N> = kept
            .downcast_mut::<Box<Lanes<N>>>()
            .expect("lanes of N planes");
        let end = first + count;
        let mut lo = first;
        while lo < end {
            let chunk = ((end - lo) as usize).min(CHUNK);
            logs.resize_with(chunk * laws.len(), || Log::new(rows.is_some()));
            let logs = &mut logs[..chunk * laws.len()];
            match lanes {
                _ if self.reference => self.walks(lo, logs),
                Lanes::F32(w) => self.walks_in_lanes(lo, logs, w),
                Lanes::F64(w) => self.walks_in_lanes(lo, logs, w),
            }
            for (b, block) in logs.chunks(BLOCK * laws.len()).enumerate() {
                let n = block.len() / laws.len();
                for s in 0..n {
                    let i = lo + (b * BLOCK + s) as u64;
                    for (l, log) in block[s * laws.len()..][..laws.len()].iter().enumerate() {
                        let mut first = Firsts {
                            energy: &mut energy[l],
                            vn: &mut vn[l],
                            out: &mut outs[l],
                        };
                        let (la, drops) = (&mut acc.laws[l], &mut acc.drops[l]);
                        let r = rows.as_deref_mut();
                        log.replay((i, l as u32), s, &mut first, body, la, drops, r);
                    }
                }
                let before: Vec<Before<f64, N>> = energy
                    .iter()
                    .zip(&vn)
                    .map(|(energy, vn)| Before { energy, vn })
                    .collect();
                block_stats(&before, &outs, n, self.plan, &mut scratch, acc);
                for (la, out) in acc.laws.iter_mut().zip(&outs) {
                    if let Some(fr) = la.friction.as_mut() {
                        record_friction(out, n, fr);
                    }
                }
                if let Some(r) = clusters.as_deref_mut() {
                    r.block_done(acc);
                }
            }
            lo += chunk as u64;
        }
        self.lanes.give(kept);
    }

    /// The walks of samples `first..` (one per log, sample-major, then by
    /// law) into `logs`.
    fn walks(&self, first: u64, logs: &mut [Log]) {
        let laws = self.scene.laws();
        for (k, log) in logs.iter_mut().enumerate() {
            let (i, law) = (first + (k / laws.len()) as u64, laws[k % laws.len()]);
            log.clear();
            let mut walk = self.walk_of(i);
            let ending = loop {
                if let Some(e) = walk.fly(self.scene.effects().bounces as usize) {
                    break e;
                }
                if let Some(e) = self.reference_flight(law, &mut walk, log) {
                    break e;
                }
            };
            walk.finish(ending, log);
        }
    }

    /// Sample `i`'s walk, at its release.
    pub(super) fn walk_of(&self, i: u64) -> Walk {
        let start = start_of(&self.start, &self.sampler, i);
        let energy = kinetic_energy(self.scene.body(), start.velocity, start.omega);
        Walk::new(start, energy, self.scene.effects().settle)
    }

    /// One flight of `walk` and its impact by the f64 reference: the
    /// ending if the walk is over.
    fn reference_flight(&self, law: Law, walk: &mut Walk, log: &mut Log) -> Option<Ending> {
        let fx = self.scene.effects();
        match self.flight.next(self.scene.body(), &walk.motion, law) {
            Ok((hit, o, coupled)) => {
                let strike = Strike::of(&o, &hit.distances);
                let how = How {
                    coupled_fallback: coupled,
                    recomputed: false,
                };
                walk.struck(hit.time, hit.motion, &strike, how, fx.energy_floor, log)
            }
            Err(Stop::FlewAway) => Some(Ending::FlewAway),
            Err(Stop::Unsolved) => Some(walk.unsolved(log)),
        }
    }
}

/// A sample's first impact with the given rotation in flight and
/// time-of-impact tolerance (for the accuracy ladder): the time from release and the post-impact velocities and energy
/// ratio. Planes within the larger of the contact and time-of-impact
/// tolerances take part. `None` if nothing is hit within the horizon, the
/// impact cannot be solved, or no plane takes an impulse.
pub fn first_impact(
    scene: &Scene,
    law: Law,
    start: &Motion,
    rotation: Rotation,
    toi_tolerance: f64,
) -> Option<(f64, DVec3, DVec3, f64)> {
    let (hit, o, _) = Flight::new(scene, rotation, toi_tolerance)
        .next(scene.body(), start, law)
        .ok()?;
    if o.contacts.iter().all(|c| c.impulse <= 0.0) {
        return None;
    }
    Some((
        hit.time,
        o.after.velocity,
        o.after.omega,
        o.energy_after / o.energy_before,
    ))
}
