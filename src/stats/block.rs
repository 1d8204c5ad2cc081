//! The statistics pass over one SoA block: per-lane values and masks of
//! each law's results, then counts, moments and histograms into a
//! [`RunAcc`], as masked vector passes.

// Lane code indexes SoA arrays by lane and contact on purpose: the index
// form is what the loop vectoriser sees through.
#![allow(clippy::needless_range_loop, clippy::manual_memcpy)]

use crate::config::{Keep, Quantiles, Scene, Statistic, Statistics, MAX_DROP_PLANES};
use crate::kernel::{Geometry, LawOut, Status};
use crate::lanes::dispatch::{multiversioned, BLOCK};
use crate::lanes::{select, Real};
use crate::stats::accumulators::{FrictionAcc, GroupAcc, LawAcc, RunAcc};
use crate::stats::{scatter, LogHistogram, Moments, Stat, BINS};

/// The block statistics' scratch space: a worker's, allocated once per
/// run.
pub(crate) struct Scratch<T, const N: usize> {
    derived: Box<Derived<T, N>>,
    /// laws[0]'s per-lane statistics, for paired differences.
    first: Box<Derived<T, N>>,
    diff: Box<[T; BLOCK]>,
}

impl<T: Real, const N: usize> Scratch<T, N> {
    pub(crate) fn new() -> Self {
        Self {
            derived: Derived::new(),
            first: Derived::new(),
            diff: Box::new([T::ZERO; BLOCK]),
        }
    }
}

/// Per-lane statistics of one law in a block, in the kernel's precision,
/// with their masks (weights 1 or 0, in the same type). Cache-line aligned.
#[repr(C, align(64))]
pub(crate) struct Derived<T, const N: usize> {
    ratio: [T; BLOCK],
    omega: [T; BLOCK],
    speed: [T; BLOCK],
    /// Weights (1 or 0) of impacting lanes; values are finite everywhere.
    impacting: [T; BLOCK],
    lambda: [[T; BLOCK]; N],
    rebound: [[T; BLOCK]; N],
    /// v_n⁺ − e₀|v_n⁻| (the residual against the pilot ratio e₀), |v_n⁻|
    /// and their sum where the contact approached (0 elsewhere).
    vn_resid: [[T; BLOCK]; N],
    vn_in: [[T; BLOCK]; N],
    vn_sum: [[T; BLOCK]; N],
    approaching: [[T; BLOCK]; N],
    active: [u32; BLOCK],
    mask: [T; BLOCK],
}

impl<T: Real, const N: usize> Derived<T, N> {
    pub(crate) fn new() -> Box<Self> {
        Box::new(Self {
            ratio: [T::ZERO; BLOCK],
            omega: [T::ZERO; BLOCK],
            speed: [T::ZERO; BLOCK],
            impacting: [T::ZERO; BLOCK],
            lambda: [[T::ZERO; BLOCK]; N],
            rebound: [[T::ZERO; BLOCK]; N],
            vn_resid: [[T::ZERO; BLOCK]; N],
            vn_in: [[T::ZERO; BLOCK]; N],
            vn_sum: [[T::ZERO; BLOCK]; N],
            approaching: [[T::ZERO; BLOCK]; N],
            active: [0; BLOCK],
            mask: [T::ZERO; BLOCK],
        })
    }
}

/// What the statistics pass computes: the scene's requested statistics
/// (its derived effect set), or everything under `--all-effects`. Chosen
/// once per run; each choice skips whole passes over a block, never a lane.
#[derive(Debug, Clone, Copy)]
pub(crate) struct StatsPlan {
    /// Histograms of energy_ratio, |ω⁺|, |v⁺|, impulse, rebound.
    quantiles: Quantiles,
    by_set: bool,
    /// |ω⁺| when it is the same in every sample: counted, not computed.
    constant_spin: Option<f64>,
    /// Each recorded plane's restitution: the pilot ratio the restitution
    /// statistic's residuals are taken against ([`crate::stats::RatioOfSums`]).
    pilot: [f64; MAX_DROP_PLANES],
}

impl StatsPlan {
    /// |ω⁺| computed per sample even where the scene's start fixes it (a
    /// drop's spin changes in flight and at impacts).
    pub(crate) fn per_sample_spin(self) -> Self {
        Self {
            constant_spin: None,
            ..self
        }
    }

    pub(crate) fn of(scene: &Scene, keep: Keep) -> Self {
        let e = scene.effects();
        let st = if keep.statistics {
            Statistics::ALL
        } else {
            e.statistics
        };
        Self {
            quantiles: st.quantiles,
            by_set: st.by_active_set,
            // With rotation kept, |ω⁺| is computed per sample.
            constant_spin: if keep.rotation { None } else { e.constant_spin },
            pilot: pilots(scene),
        }
    }
}

/// The pilot ratio of each recorded plane's restitution statistic (its
/// restitution; 0 past the planes): up to three touching planes at
/// contact, every plane of a drop.
pub fn pilots(scene: &Scene) -> [f64; MAX_DROP_PLANES] {
    let planes = scene.recorded_planes();
    std::array::from_fn(|i| {
        planes
            .get(i)
            .map_or(0.0, |&p| scene.planes()[p].plane.restitution())
    })
}

/// What the statistics read of a block's state before the impact: the
/// kinetic energy and each contact's normal velocity, per lane.
#[derive(Clone, Copy)]
pub(crate) struct Before<'a, T, const N: usize> {
    pub(crate) energy: &'a [T; BLOCK],
    pub(crate) vn: &'a [[T; BLOCK]; N],
}

impl<'a, T, const N: usize> Before<'a, T, N> {
    /// A contact block's: the same for every law.
    pub(crate) fn of(geo: &'a Geometry<T, N>) -> Self {
        Self {
            energy: &geo.t_before,
            vn: &geo.vn,
        }
    }
}

/// Per-lane statistics of a law's block results. Lanes past `count` and
/// penetrating lanes get weight 0, and every value is made finite (0 where
/// its weight is 0), so masked sums are plain arithmetic. Everything stays
/// in the kernel's precision (the values are no more accurate than that);
/// the accumulators combine blocks in f64.
///
/// Returns the block's counts, taken in the same pass over the statuses.
#[inline(always)]
fn derive<T: Real, const N: usize>(
    geo: Before<T, N>,
    out: &LawOut<T, N>,
    count: usize,
    plan: StatsPlan,
    d: &mut Derived<T, N>,
) -> BlockCounts {
    let w01 = |c: bool| select(c, T::ONE, T::ZERO);
    let mut n = BlockCounts::default();
    // |ω⁺| per lane, unless it is the same in every sample.
    let omega_per_lane = plan.constant_spin.is_none();
    let pilot: [T; N] = std::array::from_fn(|i| T::from_f64(plan.pilot[i]));
    // One loop with non-short-circuit logic, so that it vectorises: the
    // divisions and square roots overlap the rest (in separate loops each
    // waited on the divider: S1 about 2 % slower). Counts are
    // compare-and-sum reductions in lanes (a scatter into one counter per
    // set would chain every sample through memory).
    const { assert!(BLOCK < 256) };
    for s in 0..BLOCK {
        let st = out.status[s];
        let in_batch = s < count;
        let valid = in_batch & (!st.has(Status::PENETRATING));
        let approaching = st.approaching_mask::<N>();
        let impacting = valid & (approaching != 0);
        let active = st.active_mask::<N>();
        d.impacting[s] = w01(impacting);
        d.active[s] = active;
        for k in 0..BlockCounts::FLAGS.len() {
            n.flags[k] += (in_batch & st.has(BlockCounts::FLAGS[k])) as u32;
        }
        n.impacts += impacting as u32;
        // Samples per active set: each valid lane adds 1 to its set's byte
        // of a 64-bit word (fewer than 256 lanes per block, so no byte
        // carries into the next, whatever the partial sums).
        n.per_set += (valid as u64) << (8 * (active & 7));
        let ratio = out.t_after[s] / geo.energy[s];
        d.ratio[s] = select(impacting, ratio, T::ZERO);
        if omega_per_lane {
            let (a, b, c) = (out.w_after[0][s], out.w_after[1][s], out.w_after[2][s]);
            let w = (a * a + b * b + c * c).sqrt();
            d.omega[s] = select(impacting, w, T::ZERO);
        }
        let (a, b, c) = (out.v_after[0][s], out.v_after[1][s], out.v_after[2][s]);
        let v = (a * a + b * b + c * c).sqrt();
        d.speed[s] = select(impacting, v, T::ZERO);
        for i in 0..N {
            let toward = valid & (approaching & (1 << i) != 0);
            d.approaching[i][s] = w01(toward);
            d.lambda[i][s] = select(impacting, out.lambda[i][s], T::ZERO);
            let (after, before) = (out.vn_after[i][s], geo.vn[i][s]);
            let r = -after / before;
            d.rebound[i][s] = select(toward, r, T::ZERO);
            let (x, y) = (
                select(toward, after, T::ZERO),
                select(toward, -before, T::ZERO),
            );
            let resid = x - pilot[i] * y;
            d.vn_resid[i][s] = resid;
            d.vn_in[i][s] = y;
            d.vn_sum[i][s] = resid + y;
        }
    }
    n
}

/// A law's counts over one block (from [`derive`]).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct BlockCounts {
    /// Samples of the batch with each of [`Self::FLAGS`].
    flags: [u32; 6],
    /// Samples with at least one approaching contact (and not penetrating).
    impacts: u32,
    /// Valid samples per active set: set m's count in byte m.
    per_set: u64,
}

impl BlockCounts {
    const FLAGS: [Status; 6] = [
        Status::ENERGY_GAIN,
        Status::DEGENERATE,
        Status::JAMMED,
        Status::UNSOLVED,
        Status::RECOMPUTED,
        Status::PENETRATING,
    ];
}

/// Headline statistic `k` (0 energy ratio, 1 |ω⁺|, 2 |v⁺|) of a contact set.
#[inline(always)]
fn group_stat(g: &mut GroupAcc, k: usize) -> &mut Stat {
    match k {
        0 => &mut g.energy_ratio,
        1 => &mut g.omega_after_norm,
        _ => &mut g.velocity_after_norm,
    }
}

multiversioned! {
    /// Accumulates every law's block results: counters, then moments and
    /// histograms as masked vector passes, for the statistics the plan asks
    /// for. `before` is one state for every law (a contact block) or one
    /// per law (a drop's first impacts). Compiled like `block_lanes`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn block_stats<T: Real, const N: usize>(
        before: &[Before<T, N>],
        outs: &[Box<LawOut<T, N>>],
        count: usize,
        plan: StatsPlan,
        scratch: &mut Scratch<T, N>,
        acc: &mut RunAcc,
    ) {
        let Scratch { derived, first, diff } = scratch;
        block_stats_lanes(before, outs, count, plan, derived, first, diff, acc)
    }
}

/// [`block_stats`]' lane code (inlined into each target's version).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn block_stats_lanes<T: Real, const N: usize>(
    before: &[Before<T, N>],
    outs: &[Box<LawOut<T, N>>],
    count: usize,
    plan: StatsPlan,
    derived: &mut Box<Derived<T, N>>,
    first: &mut Box<Derived<T, N>>,
    diff: &mut [T; BLOCK],
    acc: &mut RunAcc,
) {
    let mut bins = [0u16; BLOCK];
    let spin = plan.constant_spin;
    for li in 0..outs.len() {
        let la = &mut acc.laws[li];
        let out = &outs[li];
        let n = derive(before[li.min(before.len() - 1)], out, count, plan, derived);
        let d = &mut **derived;
        let c = n.flags;
        la.samples += count as u64;
        la.energy_gain += c[0] as u64;
        la.degenerate += c[1] as u64;
        la.jammed += c[2] as u64;
        la.unsolved += c[3] as u64;
        la.recomputed += c[4] as u64;
        la.penetrating += c[5] as u64;
        let impacts = n.impacts;
        la.impacts += impacts as u64;
        for m in 0..la.active_sets.len() {
            let c = (n.per_set >> (8 * m)) & 0xff;
            la.active_sets[m] += c;
            la.groups[m].samples += c;
        }
        // Moments of the statistics weighted by `impacting`, fused into
        // passes of up to three statistics.
        match spin {
            Some(w) => {
                la.omega_after_norm.moments.push_repeated(w, impacts as u64);
                Moments::push_weighted_many(
                    [
                        &mut la.energy_ratio.moments,
                        &mut la.velocity_after_norm.moments,
                    ],
                    [&d.ratio, &d.speed],
                    &d.impacting,
                );
            }
            None => Moments::push_weighted_many(
                [
                    &mut la.energy_ratio.moments,
                    &mut la.omega_after_norm.moments,
                    &mut la.velocity_after_norm.moments,
                ],
                [&d.ratio, &d.omega, &d.speed],
                &d.impacting,
            ),
        }
        {
            let mut impulse = la.impulse.iter_mut().map(|s| &mut s.moments);
            let ms: [&mut Moments; N] = std::array::from_fn(|_| impulse.next().expect("N"));
            Moments::push_weighted_many(ms, std::array::from_fn(|i| &d.lambda[i]), &d.impacting);
        }
        for i in 0..N {
            if plan.quantiles.has(Statistic::Impulse) {
                la.impulse[i].hist.push_weighted(&d.lambda[i], &d.impacting);
            }
            if plan.quantiles.has(Statistic::Rebound) {
                la.rebound[i]
                    .hist
                    .push_weighted(&d.rebound[i], &d.approaching[i]);
            }
            la.rebound[i]
                .moments
                .push_weighted(&d.rebound[i], &d.approaching[i]);
            // The restitution's sums need no extrema (its range is the
            // rebound's).
            let r = &mut la.restitution[i];
            Moments::push_weighted_sums_many(
                [&mut r.resid, &mut r.y, &mut r.sum],
                [&d.vn_resid[i], &d.vn_in[i], &d.vn_sum[i]],
                &d.approaching[i],
            );
        }
        if plan.by_set {
            block_stats_by_set(la, d, count, plan, &mut bins);
        } else {
            // Histograms straight into the "all" statistics.
            if let Some(w) = spin.filter(|_| plan.quantiles.has(Statistic::OmegaAfterNorm)) {
                la.omega_after_norm.hist.push_repeated(w, impacts as u64);
            }
            let headline = plan.quantiles.has(Statistic::EnergyRatio)
                && plan.quantiles.has(Statistic::VelocityAfterNorm)
                && (spin.is_some() || plan.quantiles.has(Statistic::OmegaAfterNorm));
            if impacts > 0 && headline {
                // The usual plan: the headline histograms' increments in one
                // scatter loop.
                let (mut ib, mut is, mut io) = ([0u16; BLOCK], [0u16; BLOCK], [0u16; BLOCK]);
                let kr = la
                    .energy_ratio
                    .hist
                    .bin_pass(&d.ratio, &d.impacting, &mut ib);
                let ks = la
                    .velocity_after_norm
                    .hist
                    .bin_pass(&d.speed, &d.impacting, &mut is);
                if spin.is_none() {
                    let ko = la
                        .omega_after_norm
                        .hist
                        .bin_pass(&d.omega, &d.impacting, &mut io);
                    scatter(
                        [
                            la.energy_ratio.hist.positive_bins(),
                            la.velocity_after_norm.hist.positive_bins(),
                            la.omega_after_norm.hist.positive_bins(),
                        ],
                        [&ib, &is, &io],
                        [kr, ks, ko],
                    );
                } else {
                    scatter(
                        [
                            la.energy_ratio.hist.positive_bins(),
                            la.velocity_after_norm.hist.positive_bins(),
                        ],
                        [&ib, &is],
                        [kr, ks],
                    );
                }
            } else if !headline {
                if plan.quantiles.has(Statistic::EnergyRatio) {
                    la.energy_ratio.hist.push_weighted(&d.ratio, &d.impacting);
                }
                if plan.quantiles.has(Statistic::OmegaAfterNorm) && spin.is_none() {
                    la.omega_after_norm
                        .hist
                        .push_weighted(&d.omega, &d.impacting);
                }
                if plan.quantiles.has(Statistic::VelocityAfterNorm) {
                    la.velocity_after_norm
                        .hist
                        .push_weighted(&d.speed, &d.impacting);
                }
            }
        }
        if li == 0 {
            std::mem::swap(first, derived);
        } else {
            let (f, d) = (&**first, &mut **derived);
            let mut both = 0u32;
            for s in 0..BLOCK {
                d.mask[s] = d.impacting[s] * f.impacting[s];
                both += (d.mask[s] > T::ZERO) as u32;
            }
            let p = &mut acc.pairs[li - 1];
            let gains = |o: &LawOut<T, N>, s: usize| o.status[s].has(Status::ENERGY_GAIN);
            for s in 0..count {
                let (this, base) = (gains(out, s), gains(&outs[0], s));
                p.energy_gain_only += (this && !base) as u64;
                p.first_energy_gain_only += (base && !this) as u64;
            }
            for (k, (target, a, b)) in [
                (&mut p.energy_ratio, &d.ratio, &f.ratio),
                (&mut p.omega_after_norm, &d.omega, &f.omega),
                (&mut p.velocity_after_norm, &d.speed, &f.speed),
            ]
            .into_iter()
            .enumerate()
            {
                if k == 1 && spin.is_some() {
                    target.push_repeated(0.0, both as u64);
                    continue;
                }
                for s in 0..BLOCK {
                    diff[s] = a[s] - b[s];
                }
                target.push_weighted(diff, &d.mask);
            }
        }
    }
}

/// The per-active-set statistics of one law's block (`by_active_set`):
/// moments of the post-impact statistics per set present, and their
/// histograms per set (the "all" histograms are their sums, made by
/// [`RunAcc::finish`]).
#[inline(always)]
fn block_stats_by_set<T: Real, const N: usize>(
    la: &mut LawAcc,
    d: &mut Derived<T, N>,
    count: usize,
    plan: StatsPlan,
    bins: &mut [u16; BLOCK],
) {
    let spin = plan.constant_spin;
    let mut present = [false; 8];
    for s in 0..BLOCK {
        present[d.active[s] as usize & 7] = true;
    }
    for (m, g) in la.groups.iter_mut().enumerate() {
        // Integer counting keeps this loop vectorisable.
        let mut hits = 0u32;
        for s in 0..BLOCK {
            let on = (d.active[s] == m as u32) as u32 & (d.impacting[s] > T::ZERO) as u32;
            d.mask[s] = select(on != 0, T::ONE, T::ZERO);
            hits += on;
        }
        if hits > 0 {
            g.impacts += hits as u64;
            g.energy_ratio.moments.push_weighted(&d.ratio, &d.mask);
            match spin {
                Some(w) => {
                    g.omega_after_norm.moments.push_repeated(w, hits as u64);
                    if plan.quantiles.has(Statistic::OmegaAfterNorm) {
                        g.omega_after_norm.hist.push_repeated(w, hits as u64);
                    }
                }
                None => g.omega_after_norm.moments.push_weighted(&d.omega, &d.mask),
            }
            g.velocity_after_norm
                .moments
                .push_weighted(&d.speed, &d.mask);
        }
    }
    // Histograms: bins computed once per statistic (vectorised), each
    // impacting sample counted in its own contact set's histogram.
    for k in 0..3 {
        if !plan.quantiles.has(Statistic::ALL[k]) || (k == 1 && spin.is_some()) {
            continue;
        }
        let xs = [&d.ratio, &d.omega, &d.speed][k];
        let mut other = false;
        let mut negative = false;
        for s in 0..BLOCK {
            bins[s] = LogHistogram::bin_of(xs[s]);
            other |= (d.impacting[s] > T::ZERO) & !(xs[s] > T::ZERO);
            negative |= (d.impacting[s] > T::ZERO) & (xs[s] < T::ZERO);
        }
        // Branch-free: every lane adds its weight (0 or 1) to its set's
        // table, so every set present in the block gets one.
        let mut tables: [Option<&mut [u64; BINS]>; 8] = Default::default();
        for (m, g) in la.groups.iter_mut().enumerate() {
            if present[m] {
                tables[m] = Some(group_stat(g, k).hist.positive_bins());
            }
        }
        for s in 0..BLOCK {
            let on = (d.impacting[s] > T::ZERO) & (xs[s] > T::ZERO);
            if let Some(t) = &mut tables[d.active[s] as usize & 7] {
                t[bins[s] as usize & (BINS - 1)] += on as u64;
            }
        }
        if other {
            // Exact zeros per contact set by compare-and-sum passes (a
            // sphere's |ω⁺| is zero in every lane); negatives one by one.
            for (m, g) in la.groups.iter_mut().enumerate() {
                if !present[m] {
                    continue;
                }
                let mut zeros = 0u32;
                for s in 0..BLOCK {
                    zeros += ((d.active[s] == m as u32)
                        & (d.impacting[s] > T::ZERO)
                        & (xs[s] == T::ZERO)) as u32;
                }
                group_stat(g, k).hist.add_zeros(zeros as u64);
            }
            if negative {
                for s in 0..count {
                    if d.impacting[s] > T::ZERO && xs[s] < T::ZERO {
                        group_stat(&mut la.groups[d.active[s] as usize], k)
                            .hist
                            .push(xs[s].to_f64());
                    }
                }
            }
        }
    }
}

/// One law's friction statistics of a block (friction.md, "What the engine
/// reports"): `|f_i|` over impacting lanes (some λ > 0, zeros included),
/// `|c⁺_t,i|` and sticking over each contact's active lanes, and the
/// `ambiguous` and `unconverged` counts. Penetrating lanes and lanes past
/// `count` are left out.
pub(crate) fn record_friction<T: Real, const N: usize>(
    out: &LawOut<T, N>,
    count: usize,
    fr: &mut FrictionAcc,
) {
    let w01 = |c: bool| select(c, T::ONE, T::ZERO);
    let mut impacting = [T::ZERO; BLOCK];
    let mut active = [[T::ZERO; BLOCK]; N];
    let mut tangential = [[T::ZERO; BLOCK]; N];
    let mut sliding = [[T::ZERO; BLOCK]; N];
    for s in 0..count {
        let st = out.status[s];
        if st.has(Status::PENETRATING) {
            continue;
        }
        fr.ambiguous += (st.has(Status::AMBIGUOUS)) as u64;
        fr.unconverged += (st.has(Status::UNCONVERGED)) as u64;
        let any = st.active_mask::<N>() != 0;
        impacting[s] = w01(any);
        for i in 0..N {
            let on = st.has(Status::active(i));
            active[i][s] = w01(on);
            tangential[i][s] = select(any, out.tangential[i][s], T::ZERO);
            sliding[i][s] = select(on, out.sliding[i][s], T::ZERO);
            fr.active[i] += on as u64;
            fr.sticking[i] += (st.has(Status::sticking(i))) as u64;
        }
    }
    for i in 0..N {
        fr.tangential_impulse[i]
            .moments
            .push_weighted(&tangential[i], &impacting);
        fr.sliding_speed[i]
            .moments
            .push_weighted(&sliding[i], &active[i]);
    }
}
